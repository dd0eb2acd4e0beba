"""The project's configuration folder and its YAML files (standard library and PyYAML only).

Every module reads ``config/`` through here: the workflow's helpers do so while Snakemake
builds the DAG, so nothing heavier than PyYAML is imported.
"""

from __future__ import annotations

import functools
import os
import re
from pathlib import Path

import yaml

from .errors import InputError
from .files import open_regular

__all__ = ["PROJECT_DIR", "MAX_YAML_BYTES", "MAX_YAML_NODES", "MAX_YAML_DEPTH", "yaml_load", "parse_yaml_bytes", "read_yaml_bytes",
           "read_yaml", "copy_tree", "config_dir", "config_file"]

#: the project folder this package lives in (``config/``, ``archive/``, ``benchmarks/`` beside it)
PROJECT_DIR = Path(__file__).resolve().parents[2]


#: the largest YAML file the project reads [bytes]: its own files are a few kB (config/rig.yaml,
#: the largest, 16 kB), so a larger one is a mistake, never parsed
MAX_YAML_BYTES = 1 << 20
#: the most nodes a YAML document may hold with every alias expanded: its own files hold under
#: a thousand; an alias bomb (a few lines whose aliases nest) is refused while it is composed,
#: before the tree is built or copied, in milliseconds and a few MB
MAX_YAML_NODES = 20_000
#: the deepest nesting of a YAML document (its own files nest 5 deep): deeper, the composer's
#: recursion would end in a RecursionError instead of a message
MAX_YAML_DEPTH = 50

try:    # libyaml's parser (C) reads the events: ten times faster than PyYAML's own
    from yaml.cyaml import CParser as _Parser

    def _init_parser(loader, stream) -> None:
        _Parser.__init__(loader, stream)
except ImportError:  # pragma: no cover - PyYAML built without libyaml
    from yaml.parser import Parser as _Parser
    from yaml.reader import Reader as _Reader
    from yaml.scanner import Scanner as _Scanner

    class _Parser(_Reader, _Scanner, _Parser):  # type: ignore[no-redef]
        pass

    def _init_parser(loader, stream) -> None:
        _Reader.__init__(loader, stream)
        _Scanner.__init__(loader)
        yaml.parser.Parser.__init__(loader)


class _Resolver(yaml.resolver.Resolver):
    """YAML 1.1's tags, with YAML 1.2 floats such as ``2.5e8`` read as floats (PyYAML needs ``2.5e+8``)."""


_Resolver.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)
    |[-+]?(?:[0-9][0-9_]*)\.[0-9_]*
    |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


class _Refused(yaml.MarkedYAMLError):
    """YAML that parses but that the project refuses: a key given twice, an alias bomb, a recursive alias."""


class _Loader(_Parser, yaml.composer.Composer, yaml.constructor.SafeConstructor, _Resolver):
    """PyYAML's safe loader with the refusals a plain ``safe_load`` lacks: a mapping that
    gives a key twice (PyYAML keeps the last value), a document of more than
    :data:`MAX_YAML_NODES` nodes with its aliases expanded (an alias bomb: a few lines whose
    expansion fills the memory when the tree is walked), nesting deeper than
    :data:`MAX_YAML_DEPTH`, and a recursive alias."""

    def __init__(self, stream):
        _init_parser(self, stream)
        yaml.composer.Composer.__init__(self)
        yaml.constructor.SafeConstructor.__init__(self)
        _Resolver.__init__(self)
        self._size: dict[int, int | None] = {}    # id(node) -> nodes with aliases expanded (None: open)
        self._expanded = 0
        self._depth = 0

    # the parser's events composed by PyYAML's own composer, node by node, counting
    get_node = yaml.composer.Composer.get_node
    check_node = yaml.composer.Composer.check_node
    get_single_node = yaml.composer.Composer.get_single_node

    def _count(self, n: int, event) -> None:
        self._expanded += n
        if self._expanded > MAX_YAML_NODES:
            raise _Refused(
                None, None, f"more than {MAX_YAML_NODES:,} nodes with its aliases expanded (an alias bomb?); "
                "a file of this project holds a few hundred", event.start_mark)

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            node = super().compose_node(parent, index)
            size = self._size.get(id(node))
            if size is None:    # sized once composed: an alias inside its own anchor's node
                raise _Refused(None, None, f"alias *{event.anchor} refers to a node that "
                                                  "holds it (a recursive alias)", event.start_mark)
            self._count(size, event)
            return node
        event = self.peek_event()
        self._count(1, event)
        self._depth += 1
        if self._depth > MAX_YAML_DEPTH:
            raise _Refused(None, None, f"nested more than {MAX_YAML_DEPTH} levels deep; a file of this project "
                           "nests a few", event.start_mark)
        before = self._expanded
        node = super().compose_node(parent, index)
        self._depth -= 1
        self._size[id(node)] = 1 + self._expanded - before
        return node

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.get(key)
                    seen[key] = key_node.start_mark.line + 1
                except TypeError:
                    continue        # an unhashable key: SafeConstructor names it
                if first is not None:
                    raise _Refused(
                        None, None, f"key {key!r} is given twice (first on line {first})", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


def yaml_load(stream):
    """Parse YAML (a string, bytes or a text stream) with scientific-notation floats read as
    floats, refusing a key given twice, an alias bomb, too deep a nesting and a recursive
    alias (a yaml.YAMLError naming the line)."""
    loader = _Loader(stream)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def config_dir() -> Path:
    """The project's ``config/`` folder (``$CAMPAIGN_CONFIG_DIR`` overrides it)."""
    env = os.environ.get("CAMPAIGN_CONFIG_DIR")
    path = Path(env) if env else PROJECT_DIR / "config"
    if not (path / "paper.yaml").is_file():
        raise FileNotFoundError(
            f"config folder {path} has no paper.yaml; install the project editable "
            "(pip install -e .) or set CAMPAIGN_CONFIG_DIR"
        )
    return path


def config_file(name: str) -> Path:
    """A file of the configuration folder, e.g. ``config_file("rig.yaml")``."""
    return config_dir() / name


@functools.lru_cache(maxsize=32)
def parse_yaml_bytes(path: str, content: bytes):
    """Parse YAML ``content`` read from ``path`` (cached per content; treat as read-only)."""
    try:
        return yaml_load(content.decode("utf-8"))
    except (ValueError, OverflowError) as exc:   # a scalar its constructor cannot take: 2001-13-45, 5000 digits
        if isinstance(exc, UnicodeDecodeError):
            raise InputError(f"{path}: not valid YAML: not UTF-8 text (byte {exc.start})") from None
        raise InputError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        at = f" (line {where.line + 1}, column {where.column + 1})" if where is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        what = "refused" if isinstance(exc, _Refused) else "not valid YAML"
        raise InputError(f"{path}: {what}{at}: {problem}") from None


def copy_tree(node):
    """Copy of a parsed YAML tree (its dicts and lists; the scalars are immutable)."""
    if isinstance(node, dict):
        return {k: copy_tree(v) for k, v in node.items()}
    if isinstance(node, list):
        return [copy_tree(v) for v in node]
    return node


def read_yaml_bytes(path, *, what: str = "") -> bytes:
    """The bytes of the YAML file ``path``: a regular file (a FIFO or a device is refused, never
    waited on) of at most :data:`MAX_YAML_BYTES` (InputError naming ``what`` and the path);
    a missing file raises FileNotFoundError."""
    with open_regular(path, "rb", missing_ok=True, what=what) as fh:
        content = fh.read(MAX_YAML_BYTES + 1)
    if len(content) > MAX_YAML_BYTES:
        raise InputError(f"{what + ' ' if what else ''}{path}: larger than {MAX_YAML_BYTES >> 20} MiB, not read "
                         "(a YAML file of this project holds a few kB)")
    return content


def read_yaml(path, *, copy: bool = True):
    """Parse the YAML file ``path``, once per content.

    The cache is keyed on the file's bytes (read every call, tens of microseconds), so a
    file edited on disk is picked up at once, even when rewritten within one tick of the
    file system's clock with the same size, where its mtime would not change. With
    ``copy=False`` the cached tree itself is returned: the caller must not modify it.
    Refused with InputError naming the file and line: a file over :data:`MAX_YAML_BYTES`, a
    key given twice, an alias bomb (:data:`MAX_YAML_NODES`), invalid YAML."""
    path = str(path)
    tree = parse_yaml_bytes(path, read_yaml_bytes(path))
    return copy_tree(tree) if copy else tree
