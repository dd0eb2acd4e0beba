"""The parameter protocol the campaign's estimators share (scikit-learn's shape).

An estimator lists its constructor parameters in ``_PARAMS``; ``get_params`` returns them
and ``set_params`` changes them, refusing a name that is not one of them.
"""

from __future__ import annotations

from ..core.errors import InputError

__all__ = ["Params"]


class Params:
    """``get_params`` / ``set_params`` over the names in ``_PARAMS``."""

    _PARAMS: tuple[str, ...] = ()

    def get_params(self, deep: bool = True) -> dict:
        return {k: getattr(self, k) for k in self._PARAMS}

    def set_params(self, **params):
        for k, v in params.items():
            if k not in self._PARAMS:
                raise InputError(f"{type(self).__name__} has no parameter {k!r}; parameters: {list(self._PARAMS)}")
            setattr(self, k, v)
        return self
