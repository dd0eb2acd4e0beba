"""Impact directions for the planner: checked unit vectors, horizontal fans and cones.

A direction ``n`` is the direction of the contact force on the arm (the object moves along
``n``); :func:`unit_directions` checks and normalises any set of them,
:func:`horizontal_directions` and :func:`cone_directions` generate the sets ``campaign plan``
and the maps search over.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError

__all__ = ["unit_directions", "horizontal_directions", "cone_directions"]


def unit_directions(directions) -> np.ndarray:
    """``directions`` (one 3-vector or rows of them) as unit rows, shape (D, 3); InputError
    for a non-finite or zero vector."""
    n = np.atleast_2d(np.asarray(directions, dtype=float))
    if n.ndim != 2 or n.shape[1] != 3 or not np.all(np.isfinite(n)):
        raise InputError(f"directions must be finite 3-vectors, got shape {np.shape(directions)}")
    scale = np.abs(n).max(axis=1)    # scaled first: a norm of 1e308 or 1e-320 parts would over- or underflow
    if np.any(scale == 0.0):
        i = int(np.flatnonzero(scale == 0.0)[0])
        raise InputError(f"direction {n[i].tolist()} is the zero vector")
    n = n / scale[:, None]
    return n / np.linalg.norm(n, axis=1)[:, None]


def horizontal_directions(count: int, *, start_deg: float = 180.0) -> np.ndarray:
    """``count`` horizontal unit directions evenly spaced from ``start_deg`` (from +x towards +y)."""
    if not (isinstance(count, (int, np.integer)) and count >= 1):
        raise InputError(f"number of directions must be an integer >= 1, got {count!r}")
    a = np.radians(start_deg) + 2.0 * np.pi * np.arange(count) / count
    return np.stack([np.cos(a), np.sin(a), np.zeros(count)], axis=1)


def cone_directions(axis, half_angle_deg: float, count: int) -> np.ndarray:
    """The axis and ``count - 1`` directions on the cone of ``half_angle_deg`` around it."""
    axis = unit_directions(axis)[0]
    a = float(half_angle_deg)
    if not (math.isfinite(a) and 0.0 <= a <= 180.0):
        raise InputError(f"cone half-angle = {half_angle_deg!r} deg must be in [0, 180]")
    if not (isinstance(count, (int, np.integer)) and count >= 1):
        raise InputError(f"number of directions must be an integer >= 1, got {count!r}")
    if count == 1 or a == 0.0:
        return axis[None]
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    t = 2.0 * np.pi * np.arange(count - 1) / (count - 1)
    ring = (np.cos(np.radians(a)) * axis[None]
            + np.sin(np.radians(a)) * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v))
    return np.vstack([axis[None], ring])
