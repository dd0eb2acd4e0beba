"""Modules imported on first use.

xarray (with pandas) costs ~0.6 s to import and scipy.optimize ~0.5 s. Each Snakemake job
is a fresh interpreter, so a job that never touches them (checking or indexing trial files,
drawing the set-up from the model) should not pay for them just because a module it needs
can also build datasets or fit curves.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

__all__ = ["LazyModule"]


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
