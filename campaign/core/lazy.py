"""Modules imported on first use: a third-party module (:class:`LazyModule`) and the
public names of a package's face (:func:`lazy_exports`).

xarray (with pandas) costs ~0.6 s to import and scipy.optimize ~0.5 s, NumPy and Pinocchio
together about as much. Each Snakemake job is a fresh interpreter, so a job that never
touches them (checking or indexing trial files, drawing the set-up from the model, the
workflow's start-up) should not pay for them just because a module it needs can also build
datasets or fit curves, or because its package names them.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping, Sequence
from types import ModuleType
from typing import Any

__all__ = ["LazyModule", "lazy_exports"]


class LazyModule:
    """Stand-in for the module ``name``: imports it on the first attribute access.

    Examples
    --------
    >>> xr = LazyModule("xarray")      # nothing imported yet
    >>> ds = xr.Dataset()              # xarray is imported here
    """

    __slots__ = ("_name", "_module")

    def __init__(self, name: str):
        self._name = name
        self._module: ModuleType | None = None

    def __getattr__(self, attr: str) -> Any:
        module = self._module
        if module is None:
            module = self._module = importlib.import_module(self._name)
        return getattr(module, attr)

    def __repr__(self) -> str:
        state = "imported" if self._module is not None else "not imported yet"
        return f"<LazyModule {self._name!r} ({state})>"


def lazy_exports(package: str, exports: Mapping[str, Sequence[str]]) -> tuple[Callable[[str], Any],
                                                                               Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` of a package whose public names are imported on first use.

    ``exports`` maps each member module (relative to ``package``, dotted for a sub-package's
    module: ``"robot.ik"``) to the names it provides. The first access to one of them imports
    its module and keeps the value on the package, so later accesses are plain attributes.
    Written as a literal in the package's ``__init__``, the mapping is also what the layout
    test and the stage digests read (:mod:`campaign.pipeline.digests`).

    Examples
    --------
    In ``campaign/plan/__init__.py``::

        __all__ = ["build_planner"]
        __getattr__, __dir__ = lazy_exports(__name__, {"factory": ("build_planner",)})
    """
    where = {name: module for module, names in exports.items() for name in names}

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(where))

    return __getattr__, __dir__
