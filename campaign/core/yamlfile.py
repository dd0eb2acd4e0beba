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

__all__ = ["PROJECT_DIR", "yaml_load", "parse_yaml_bytes", "read_yaml", "copy_tree", "config_dir", "config_file"]

#: the project folder this package lives in (``config/``, ``archive/``, ``benchmarks/`` beside it)
PROJECT_DIR = Path(__file__).resolve().parents[2]


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as ``2.5e8`` (PyYAML needs ``2.5e+8``)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)
    |[-+]?(?:[0-9][0-9_]*)\.[0-9_]*
    |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


def yaml_load(stream):
    """Parse YAML with scientific-notation floats read as floats."""
    return yaml.load(stream, Loader=_Loader)


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
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        where = getattr(exc, "problem_mark", None)
        at = f" (line {where.line + 1}, column {where.column + 1})" if where is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise InputError(f"{path}: not valid YAML{at}: {problem}") from None


def copy_tree(node):
    """Copy of a parsed YAML tree (its dicts and lists; the scalars are immutable)."""
    if isinstance(node, dict):
        return {k: copy_tree(v) for k, v in node.items()}
    if isinstance(node, list):
        return [copy_tree(v) for v in node]
    return node


def read_yaml(path, *, copy: bool = True):
    """Parse the YAML file ``path``, once per content.

    The cache is keyed on the file's bytes (read every call, tens of microseconds), so a
    file edited on disk is picked up at once, even when rewritten within one tick of the
    file system's clock with the same size, where its mtime would not change. With
    ``copy=False`` the cached tree itself is returned: the caller must not modify it."""
    path = str(path)
    with open_regular(path, "rb", missing_ok=True) as fh:  # a FIFO or a device is refused, never waited on
        content = fh.read()
    tree = parse_yaml_bytes(path, content)
    return copy_tree(tree) if copy else tree
