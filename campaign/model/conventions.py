"""A robot's pose conventions, read from its drive file without building its model.

Users give an arm pose in the robot's own joint angles [deg] (``--q``, a campaign's
configurations, the scene's ``q_paper_deg``); the model's angles are

    q = radians(angle + angle_offset_deg)

with ``angle_offset_deg`` from the drive file (zeros when it has none). The drive file
also names the robot's configurations, the poses a campaign refers to by number: a
mapping ``{N: [angle, ...]}``, or the name of a YAML file in the project's ``config/``
folder whose ``configurations:`` it takes (the PUMA 560 takes the paper's Table 1 from
``paper.yaml``). The number of angles is the number of active joints.

Standard library and PyYAML only: the workflow reads a campaign's robot while Snakemake
builds the DAG, and the scene checks a pose without Pinocchio.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..core.errors import InputError
from ..core.yamlfile import config_file, read_yaml

__all__ = ["ROBOTS_DIR", "robot_dir", "drive_file", "read_drives", "angle_count", "angle_offset_deg",
           "configurations"]

#: the folder of the shipped robots, one sub-folder each
ROBOTS_DIR = Path(__file__).resolve().parent / "robot"


def robot_dir(name_or_path: str | Path) -> Path:
    """Folder of a robot: a name shipped with the package (``puma560``) or a path."""
    p = Path(name_or_path)
    if p.is_file():
        return p.parent
    if p.is_dir():
        return p
    shipped = ROBOTS_DIR / str(name_or_path)
    if shipped.is_dir():
        return shipped
    known = sorted(d.name for d in ROBOTS_DIR.iterdir() if (d / "drives.yaml").is_file())
    raise ValueError(f"unknown robot {str(name_or_path)!r}: not a folder or drive file, and not one of {known}")


def drive_file(name_or_path: str | Path) -> Path:
    """The drive file of a robot: the path itself when it is a file, else ``drives.yaml`` in its folder."""
    p = Path(name_or_path)
    return p if p.is_file() else robot_dir(name_or_path) / "drives.yaml"


def read_drives(name_or_path: str | Path) -> dict:
    """The parsed drive file of a robot (cached while the file is unchanged; treat as read-only)."""
    path = drive_file(name_or_path)
    spec = read_yaml(path, copy=False)
    if not isinstance(spec, dict) or not isinstance(spec.get("active_joints"), list) or not spec["active_joints"]:
        raise InputError(f"{path}: a drive file needs active_joints, a list of the joints that move")
    return spec


def angle_count(name_or_path: str | Path) -> int:
    """Number of joint angles a pose of the robot has (its active joints)."""
    return len(read_drives(name_or_path)["active_joints"])


def _angles(values, *, size: int, what: str) -> list[float]:
    """``values`` as ``size`` finite floats, or InputError naming ``what``."""
    try:
        out = [float(v) for v in values]
    except (TypeError, ValueError):
        raise InputError(f"{what} must be {size} numbers [deg], got {values!r}") from None
    if len(out) != size or not all(math.isfinite(v) for v in out):
        raise InputError(f"{what} must be {size} finite numbers [deg] (one per active joint), got {values!r}")
    return out


def angle_offset_deg(name_or_path: str | Path) -> list[float]:
    """The robot's ``angle_offset_deg`` [deg], one per active joint: its model angle is the
    pose's angle plus this (zeros when the drive file states none)."""
    spec = read_drives(name_or_path)
    n = len(spec["active_joints"])
    if spec.get("angle_offset_deg") is None:
        return [0.0] * n
    return _angles(spec["angle_offset_deg"], size=n, what=f"{drive_file(name_or_path)}: angle_offset_deg")


def configurations(name_or_path: str | Path) -> dict[int, list[float]]:
    """The robot's configurations ``{N: angles [deg]}`` (its own angles), ``{}`` when its
    drive file names none; a string names a file of ``config/`` holding them."""
    spec = read_drives(name_or_path)
    source = spec.get("configurations")
    where = f"{drive_file(name_or_path)}: configurations"
    if source is None:
        return {}
    if isinstance(source, str):
        path = config_file(source)
        if not path.is_file():
            raise InputError(f"{where}: {source!r} names {path}, which does not exist")
        where = f"{path} (configurations of {drive_file(name_or_path)})"
        source = (read_yaml(path, copy=False) or {}).get("configurations")
    if not isinstance(source, dict) or not source:
        raise InputError(f"{where}: expected a mapping of configuration numbers to joint angles [deg]")
    n = len(spec["active_joints"])
    out = {}
    for key, angles in source.items():
        if isinstance(key, bool) or not isinstance(key, int) or key < 1:
            raise InputError(f"{where}: configuration {key!r} is not a number >= 1")
        out[key] = _angles(angles, size=n, what=f"{where}: configuration {key}")
    return out
