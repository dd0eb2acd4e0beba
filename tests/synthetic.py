"""Synthetic trials that follow ``campaign/scene/schema.py``, for tests that must not wait for the rig.

:func:`synthetic_trial` builds the ``xarray.DataTree`` the rig returns (groups ``measured``
and ``truth``, one float64 time coordinate per clock, ``units``/``long_name`` on every
variable, the root attributes of the trial contract) filled with seeded random data of the
right shapes. Every shape comes from the schema and the scene's sampling rates, so a schema
change shows up here without editing this file. The numbers mean nothing physically; tests of
identification that need physics must use the rig.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from campaign.scene.description import Scene, make_scene
from campaign.scene.schema import CLOCKS, COORDS, SCHEMA_VERSION, variables

__all__ = ["synthetic_trial", "synthetic_scene", "JOINTS"]

#: active joints of the shipped PUMA 560 (only joints 1-3 move, design section 3)
JOINTS = ("j1", "j2", "j3")


def synthetic_scene(*, base: str = "fixed", config: int = 1, gain: str = "zero", speed: float = 1.5,
                    repeat: int = 0, seed: int | None = None) -> Scene:
    """A real, validated :class:`~campaign.scene.description.Scene` of the given cell (rig file defaults)."""
    return make_scene(base=base, config=config, gain=gain, speed=speed, repeat=repeat, seed=seed)


def _clock_lengths(scene: Scene, duration: float) -> dict[str, int]:
    """Samples per time dimension: each clock runs at its scene rate for ``duration`` seconds."""
    return {dim: max(2, int(round(duration * float(scene.p(clock.rate_key))))) for dim, clock in CLOCKS.items()}


def _dataset(group: str, scene: Scene, lengths: dict[str, int], joints: tuple[str, ...],
             rng: np.random.Generator) -> xr.Dataset:
    coord_values = {"joint": list(joints), "axis": list(COORDS["axis"]), "axis2": list(COORDS["axis2"])}
    data_vars = {}
    used_dims: set[str] = set()
    for var in variables(group, scene.base):
        shape = tuple(lengths[d] if d in CLOCKS else len(coord_values[d]) for d in var.dims)
        if var.dims and var.dims[0] in CLOCKS:
            # a random walk plus noise: smooth-ish channels compress like real ones would
            values = np.cumsum(rng.normal(0.0, 1e-3, shape), axis=0) + rng.normal(0.0, 1e-4, shape)
        else:
            values = rng.normal(0.0, 1.0, shape)
        data_vars[var.name] = xr.Variable(var.dims, values.astype(np.float64),
                                          attrs={"units": var.units, "long_name": var.long_name})
        used_dims.update(var.dims)
    coords = {}
    for dim in sorted(used_dims):
        if dim in CLOCKS:
            rate = float(scene.p(CLOCKS[dim].rate_key))
            coords[dim] = xr.Variable(dim, np.arange(lengths[dim], dtype=np.float64) / rate, attrs={
                "units": "s", "long_name": CLOCKS[dim].long_name})
        else:
            coords[dim] = xr.Variable(dim, np.asarray(coord_values[dim], dtype=object).astype(str))
    return xr.Dataset(data_vars, coords=coords)


def synthetic_trial(*, base: str = "fixed", config: int = 1, gain: str = "zero", speed: float = 1.5,
                    repeat: int = 0, seed: int | None = None, duration: float = 1.0,
                    joints: tuple[str, ...] = JOINTS, scene: Scene | None = None) -> xr.DataTree:
    """One trial as the rig returns it, with seeded random channels.

    Parameters
    ----------
    base, config, gain, speed, repeat, seed
        The campaign cell (see :func:`campaign.scene.description.make_scene`); ignored when ``scene`` is given.
    duration : float
        Recording length [s]; each clock gets ``duration * rate`` samples at its scene rate.
    joints : tuple of str
        Names of the active joints (the ``joint`` coordinate).
    scene : Scene, optional
        Use this scene instead of building one.

    Returns
    -------
    xarray.DataTree
        Children ``measured`` and ``truth``; root attributes ``scene_json``, ``scene_sha256``,
        ``seed``, ``base``, ``config``, ``gain``, ``speed``, ``repeat``, ``robot`` and
        ``schema_version``. The same arguments always give the same numbers.
    """
    if scene is None:
        scene = synthetic_scene(base=base, config=config, gain=gain, speed=speed, repeat=repeat, seed=seed)
    rng = np.random.default_rng(scene.seed)
    lengths = _clock_lengths(scene, duration)
    measured = _dataset("measured", scene, lengths, joints, rng)
    truth = _dataset("truth", scene, lengths, joints, rng)
    attrs = {
        "schema_version": SCHEMA_VERSION,
        "scene_json": scene.to_json(),
        "scene_sha256": scene.sha256,
        "seed": int(scene.seed),
        "base": scene.base,
        "config": int(scene.config),
        "gain": scene.gain,
        "speed": float(scene.speed),
        "repeat": int(scene.repeat),
        "robot": str(scene.p("robot")),
    }
    return xr.DataTree.from_dict({"/": xr.Dataset(attrs=attrs), "/measured": measured, "/truth": truth})
