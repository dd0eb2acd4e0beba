"""Stage digests: which package modules a stage runs, read with ``ast`` (nothing is imported).

Every import counts, also one inside a function: a lazy import defers the cost, not the
dependency. Each workflow rule takes :func:`code_digest` of its stage's entry modules as a
parameter, so editing any module the stage runs reruns it; the layout test reads the same
import graph. Standard library only: the workflow reads this every time it starts.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import os
from pathlib import Path

from ..core.errors import InputError

__all__ = ["PACKAGE", "module_name", "modules", "lazy_face", "imports", "graph", "closure", "source_files",
           "code_digest"]

#: the campaign package's folder
PACKAGE = Path(__file__).resolve().parents[1]


def module_name(path: Path, *, root: Path = PACKAGE) -> str:
    """Dotted name of a file of the package at ``root`` (``campaign/rig/plant.py`` -> ``campaign.rig.plant``)."""
    parts = Path(path).resolve().relative_to(Path(root).resolve().parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _stamp(root: Path) -> tuple:
    """What the package's modules are now: each ``.py`` file with its modification time and size."""
    out = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.endswith(".py"):
                st = os.stat(os.path.join(folder, name))
                out.append((os.path.join(folder, name), st.st_mtime_ns, st.st_size))
    return tuple(out)


def _import_statements(tree: ast.AST):
    """The ``import`` and ``from ... import`` statements of a module, at any depth (in a
    function, a class, a ``try``), without visiting expressions: imports are statements."""
    todo = [tree]
    while todo:
        node = todo.pop()
        for _, value in ast.iter_fields(node):
            if isinstance(value, list):
                for item in value:
                    if isinstance(item, (ast.Import, ast.ImportFrom)):
                        yield item
                    elif isinstance(item, (ast.stmt, ast.excepthandler, ast.match_case)):
                        todo.append(item)


@functools.lru_cache(maxsize=4)
def _index(root: Path, stamp: tuple) -> tuple[dict[str, Path], dict[str, frozenset[str]]]:
    """({module: file}, {module: the package modules it imports}) of the package at ``root``
    as ``stamp`` describes it; built once per state of the files."""
    parent = root.parent
    known = {}
    for path, _, _ in stamp:
        parts = Path(path).relative_to(parent).with_suffix("").parts
        known[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = Path(path)
    faces = {name: {export: module for module, names in lazy_face(ast.parse(path.read_text())).items()
                    for export in names}
             for name, path in known.items() if path.name == "__init__.py"}
    return known, {name: frozenset(imports(name, path, known, faces=faces)) for name, path in known.items()}


def modules(*, root: Path = PACKAGE) -> dict[str, Path]:
    """Every module of the package at ``root`` (default: campaign) by dotted name."""
    root = Path(root).resolve()
    return dict(_index(root, _stamp(root))[0])


def lazy_face(tree: ast.AST) -> dict[str, tuple[str, ...]]:
    """The names a package's ``__init__`` exports on first use: ``{member module: names}`` of
    its ``lazy_exports(__name__, {...})`` call (:func:`campaign.core.lazy.lazy_exports`), read
    from the literal; empty when it has none."""
    out: dict[str, tuple[str, ...]] = {}
    for node in getattr(tree, "body", ()):
        call = getattr(node, "value", None)
        if not isinstance(call, ast.Call) or len(call.args) != 2:
            continue
        func = call.func
        if (func.id if isinstance(func, ast.Name) else getattr(func, "attr", "")) == "lazy_exports":
            out.update({str(k): tuple(v) for k, v in ast.literal_eval(call.args[1]).items()})
    return out


def imports(name: str, path: Path, known: dict[str, Path], *,
            faces: dict[str, dict[str, str]] | None = None) -> set[str]:
    """The package modules ``name`` imports (absolute or relative, anywhere in the file).

    A name taken from a package's lazy face (``faces``: ``{package: {name: member module}}``,
    :func:`lazy_face`) imports the member module that provides it: Python runs that module
    when the name is first used, not when the package is imported."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    faces = faces or {}
    out = set()
    for node in _import_statements(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        else:
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            # `from pkg import sub` imports the module pkg.sub when it is one, else a name of pkg
            face = faces.get(stem, {})
            targets = [stem] + [f"{stem}.{face.get(alias.name, alias.name)}" for alias in node.names]
        out.update(t for t in targets if t in known and t != name)
    return out


def graph(*, root: Path = PACKAGE) -> dict[str, frozenset[str]]:
    """{module: the package modules it imports} over the whole package at ``root``."""
    root = Path(root).resolve()
    return dict(_index(root, _stamp(root))[1])


def closure(paths) -> list[Path]:
    """The package files ``paths`` and every package module they import, directly or not,
    with the ``__init__`` of each package on the way (Python runs it on import), sorted."""
    known, g = _index(PACKAGE, _stamp(PACKAGE))
    todo = [module_name(p) for p in paths if Path(p).suffix == ".py"]
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        parts = name.split(".")
        todo.extend(".".join(parts[:i]) for i in range(1, len(parts)) if ".".join(parts[:i]) in known)
        todo.extend(g.get(name, ()))
    return sorted(known[n] for n in seen)


def source_files(*patterns: str) -> list[Path]:
    """Files of the package that glob ``patterns`` (relative to the package) match, sorted;
    a pattern matching nothing raises InputError (a moved module must not drop out of its
    stage's digest unnoticed)."""
    files: set[Path] = set()
    for pattern in patterns:
        matched = {f for f in PACKAGE.glob(pattern) if f.is_file()}
        if not matched:
            raise InputError(f"no package source matches {pattern!r} under {PACKAGE}")
        files |= matched
    return sorted(files)


def code_digest(*patterns: str) -> str:
    """sha256 over the names and contents of the files ``patterns`` name and every package
    module they import (:func:`closure`).

    A digest rather than the files as a rule's inputs: listed as inputs, the sources of
    every job would be stat'ed, sized and checksummed by Snakemake each time it schedules
    or finishes a job, hundreds of extra input files in the reduced campaign.
    """
    files = source_files(*patterns)
    digest = hashlib.sha256()
    for f in sorted(set(files) | set(closure(files))):
        data = _content(f, os.stat(f).st_mtime_ns)
        digest.update(f"{f.relative_to(PACKAGE).as_posix()}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()


@functools.lru_cache(maxsize=1024)
def _content(path: Path, mtime_ns: int) -> bytes:
    """A source file's bytes, read once per modification (the stages share most of their modules)."""
    return path.read_bytes()
