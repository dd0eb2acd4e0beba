"""The workspace map's grid: how many points a resolution gives, checked before anything is allocated.

Standard library only: the workflow checks ``plan_maps.resolution`` with it at start-up.
"""

from __future__ import annotations

import math

from ..core.errors import InputError

__all__ = ["MAX_GRID_POINTS", "MIN_POINTS_PER_SIDE", "WORKSPACE_RANGE", "grid_points"]

#: the most points the workspace map samples: a finer grid is refused before anything is
#: allocated (the map holds about 1 kB per point; a million points take tens of minutes)
MAX_GRID_POINTS = 1_000_000
#: the default x and z range of the workspace map [m], base frame
WORKSPACE_RANGE = (-1.0, 1.0)
#: the fewest points along x and along z the workspace map samples: a coarser grid is refused
#: (one or two points a side would draw a square or two, with colour bars of one value)
MIN_POINTS_PER_SIDE = 5


def grid_points(resolution, x_range=WORKSPACE_RANGE, z_range=WORKSPACE_RANGE, *, key: str = "map resolution") -> int:
    """The number of points of the workspace map's grid; InputError naming ``key`` (the
    option or configuration key that set ``resolution``) when it is not a finite step > 0,
    the grid would exceed :data:`MAX_GRID_POINTS` or hold fewer than
    :data:`MIN_POINTS_PER_SIDE` points along x or z. Arithmetic only: nothing is allocated."""
    try:
        res = float(resolution)
    except (TypeError, ValueError):
        res = math.nan
    if isinstance(resolution, bool) or not (math.isfinite(res) and res > 0):
        raise InputError(f"{key} = {resolution!r} m must be a finite grid step > 0")
    # steps per axis as floats first: a step of 1e-300 m gives 2e300 of them (4e600 points,
    # past what a float holds), and one of 5e-324 m an infinite number
    sx, sz = (x_range[1] - x_range[0]) / res, (z_range[1] - z_range[0]) / res
    nx, nz = (math.floor(s + 0.5) + 1 if s < 1e15 else s + 1 for s in (sx, sz))
    if nx * nz <= MAX_GRID_POINTS:
        _check_coarse(key, res, int(nx), int(nz), x_range, z_range)
        return int(nx * nz)
    finest = max(x_range[1] - x_range[0], z_range[1] - z_range[0]) / (math.isqrt(MAX_GRID_POINTS) - 1)
    raise InputError(f"{key} = {res:g} m gives a workspace grid of {_count(nx)} x {_count(nz)} = "
                     f"{_count(float(nx) * float(nz))} points, over the "
                     f"{MAX_GRID_POINTS:,} this map samples at most (a step of at least {finest:.4g} m over "
                     f"x {list(x_range)}, z {list(z_range)} m)")


def _count(n: float) -> str:
    """A count of grid points as text: whole below a billion, else ``2e+300`` (``inf`` past a float)."""
    return str(int(n)) if n < 1e9 else f"{n:.3g}"


def _check_coarse(key: str, res: float, nx: int, nz: int, x_range, z_range) -> None:
    """Refuse a grid with fewer than :data:`MIN_POINTS_PER_SIDE` points along x or z."""
    if min(nx, nz) >= MIN_POINTS_PER_SIDE:
        return
    coarsest = min(x_range[1] - x_range[0], z_range[1] - z_range[0]) / (MIN_POINTS_PER_SIDE - 1)
    raise InputError(f"{key} = {res:g} m gives a workspace grid of {nx} x {nz} points, fewer than the "
                     f"{MIN_POINTS_PER_SIDE} a side this map samples at least (a step of at most {coarsest:.4g} m "
                     f"over x {list(x_range)}, z {list(z_range)} m)")
