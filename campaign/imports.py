"""Which modules of the campaign package a module imports, read with ``ast`` (nothing is imported).

Every import counts, also those inside functions: a lazy import defers the cost, not the
dependency. The workflow's stage digests take the import closure of their entry modules
(so editing any module a stage runs reruns it), and the layout test looks for cycles in
the same graph. Standard library only: the workflow reads this every time it starts.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

__all__ = ["PACKAGE", "module_name", "modules", "imports", "graph", "closure"]

#: the campaign package's folder
PACKAGE = Path(__file__).resolve().parent


def module_name(path: Path) -> str:
    """Dotted name of a package file (``campaign/rig/plant.py`` -> ``campaign.rig.plant``)."""
    parts = Path(path).resolve().relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    """Every module of the package by dotted name."""
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package modules ``name`` imports (absolute or relative, anywhere in the file)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            # `from pkg import sub` imports the module pkg.sub when it is one, else a name of pkg
            targets = [stem] + [f"{stem}.{alias.name}" for alias in node.names]
        else:
            continue
        out.update(t for t in targets if t in known and t != name)
    return out


@functools.lru_cache(maxsize=1)
def _cached_graph(stamp: tuple) -> dict[str, frozenset[str]]:
    known = modules()
    return {name: frozenset(imports(name, path, known)) for name, path in known.items()}


def graph() -> dict[str, frozenset[str]]:
    """{module: the package modules it imports} over the whole package."""
    known = modules()
    return _cached_graph(tuple((n, p.stat().st_mtime_ns, p.stat().st_size) for n, p in known.items()))


def closure(paths) -> list[Path]:
    """The package files ``paths`` and every package module they import, directly or not,
    with the ``__init__`` of each package on the way (Python runs it on import), sorted."""
    known, g = modules(), graph()
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
