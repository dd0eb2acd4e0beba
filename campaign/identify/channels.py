"""Checked access to a trial's measured channels and constants."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError
from ..core.lazy import LazyModule

#: imported on first use: the campaign's identification jobs read trials as plain arrays
#: (``load_trial(path, arrays=True)``) and so never pay ~0.6 s for xarray and pandas
xr = LazyModule("xarray")


# ----------------------------------------------------------------------------------------
# measured channels
# ----------------------------------------------------------------------------------------
def check_channels(ds: xr.Dataset, names: Mapping[str, tuple], where: str) -> None:
    """Raise InputError (naming ``where``) unless ``ds`` holds each channel of ``names`` with its dims."""
    for name, dims in names.items():
        if name not in ds.variables:
            raise InputError(f"{where}: the measured group has no channel {name!r}")
        if tuple(ds[name].dims) != tuple(dims):
            raise InputError(f"{where}: channel {name!r} has dims {tuple(ds[name].dims)}, expected {dims}")


def time_coordinate(ds: xr.Dataset, dim: str, where: str) -> np.ndarray:
    """The clock ``dim`` of ``ds`` [s]; InputError unless finite, strictly increasing, >= 2 samples."""
    if dim not in ds.coords:
        raise InputError(f"{where}: time coordinate {dim!r} is missing")
    t = np.asarray(ds[dim].values, dtype=float)
    if t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError(f"{where}: time coordinate {dim!r} must be finite and strictly increasing "
                         f"with at least 2 samples")
    return t


def servo_channel(ds: xr.Dataset, nv: int, where: str):
    """``(t_servo, tau_cmd)`` when the trial has a usable commanded-torque channel (dims
    ``(t_servo, joint)``, ``nv`` joints, finite), else ``None`` (the joint model then falls
    back to ``arm_model="lti"``)."""
    if "tau_cmd" not in ds.variables or tuple(ds["tau_cmd"].dims) != ("t_servo", "joint"):
        return None
    tau = np.asarray(ds["tau_cmd"].values, float)
    if tau.shape[1] != nv or tau.shape[0] < 2 or not np.all(np.isfinite(tau)):
        return None
    return time_coordinate(ds, "t_servo", where), tau


def finite_constant(ds, name, where, positive=True) -> float:
    """The measured constant ``name`` of ``ds``; InputError unless finite (and > 0 when ``positive``)."""
    v = float(ds[name].values)
    if not math.isfinite(v) or (positive and v <= 0):
        raise InputError(f"{where}: constant {name} = {v!r} must be a finite number > 0")
    return v


def base_geometry(measured: xr.Dataset, meta: Mapping, where: str = "trial") -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass of the emulated base and the arm's mounting point, base frame [m].

    From the measured constants ``base_com`` and ``base_mount_position`` (axis) when the
    trial has them; otherwise the centre of mass at the base origin and the mount
    ``flexible.mount_height`` above it along z from the scene JSON (an instrument setting
    the experimenter knows), else at the origin. The mount's rotation is the identity.
    """
    def vec(name):
        v = np.asarray(measured[name].values, float)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise InputError(f"{where}: constant {name} = {v.tolist()} must be 3 finite numbers (m)")
        return v

    com = vec("base_com") if "base_com" in measured.variables else np.zeros(3)
    if "base_mount_position" in measured.variables:
        return com, vec("base_mount_position")
    h = 0.0
    text = meta.get("scene_json")
    if text:
        try:
            params = json.loads(text).get("params", {})
            h = float(params.get("flexible.mount_height", 0.0) or 0.0)
        except (ValueError, TypeError, AttributeError):
            h = 0.0
    return com, np.array([0.0, 0.0, h])


def int_or(v, default: int) -> int:
    """``int(v)``, or ``default`` when ``v`` is not a number."""
    try:
        return int(v)
    except (TypeError, ValueError):
        return default


def float_or_nan(v) -> float:
    """``float(v)``, or NaN when ``v`` is not a number."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")
