"""Any CSV layout of a recorded hit, described by a small YAML mapping file.

The mapping names a robot file and an object file (paths relative to the mapping), the
columns of each quantity with their units, the object's frame relative to the robot's base
frame, and the object's mass::

    object_mass: 1.915            # kg
    robot_name: my_arm
    session: bench
    hit: "1"
    license: CC-BY-4.0            # the source's licence
    robot:
      file: robot.csv
      time: {column: t, units: s}                     # s or ms
      ee_position: {columns: [x, y, z], units: m}     # m or mm
      joint_position: {columns: [q1, q2, q3], units: rad}   # rad or deg
    object:
      file: object.csv
      time: {column: t, units: s}
      position: {columns: [ox, oy, oz], units: mm}
      frame: {rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], translation: [0, 0, 0]}   # m, object -> robot base
      clock_offset: auto          # or seconds to add to the object's times
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.files import open_regular
from ..core.yamlfile import read_yaml
from .cleaning import clock_offset, drop_stale, repair_stamps
from .fileformat import NO_LICENCE, Recording

__all__ = ["MIN_ROWS", "UNITS", "read_mapped_hit"]

#: fewest rows of each file a hit needs
MIN_ROWS = 20

#: units each kind of quantity may be given in, with the factor to SI
UNITS = {"time": {"s": 1.0, "ms": 1e-3}, "length": {"m": 1.0, "mm": 1e-3},
         "angle": {"rad": 1.0, "deg": np.pi / 180.0}}
_KIND = {"time": "time", "ee_position": "length", "joint_position": "angle", "position": "length"}


def _table(path: Path) -> tuple[list[str], np.ndarray]:
    with open_regular(path, "r", what="recording file", encoding="utf-8", newline="") as fh:
        rows = [r for r in csv.reader(fh) if r]
    if len(rows) < 2:
        raise InputError(f"{path}: no header or no rows")
    header = [c.strip() for c in rows[0]]
    try:
        data = np.array([[float(x) for x in r] for r in rows[1:]], dtype=float)
    except ValueError as exc:
        raise InputError(f"{path}: not a table of numbers under its header ({exc})") from None
    return header, data


def _quantity(spec: dict, part: str, name: str, header: list[str], data: np.ndarray, mapping: Path,
              *, size: int | None = None) -> np.ndarray:
    entry = spec.get(name)
    if not isinstance(entry, dict):
        raise InputError(f"{mapping}: {part}.{name} is missing (a mapping of columns and units)")
    cols = [entry["column"]] if "column" in entry else entry.get("columns")
    if not isinstance(cols, list) or not cols or (size is not None and len(cols) != size):
        raise InputError(f"{mapping}: {part}.{name} needs {'column' if size == 1 else f'{size or 1}+ columns'}")
    units = entry.get("units")
    kind = _KIND[name]
    if isinstance(units, list):
        if len(set(units)) != 1:
            raise InputError(f"{mapping}: {part}.{name} has inconsistent units {units}: give one unit for all columns")
        units = units[0]
    if units not in UNITS[kind]:
        raise InputError(f"{mapping}: {part}.{name} units {units!r} are not a {kind} unit "
                         f"({', '.join(UNITS[kind])})")
    missing = [c for c in cols if c not in header]
    if missing:
        raise InputError(f"{mapping}: {part}.{name} names column(s) {', '.join(map(repr, missing))} that "
                         f"{spec.get('file')} does not have (header: {','.join(header)[:100]})")
    out = data[:, [header.index(c) for c in cols]] * UNITS[kind][units]
    return out[:, 0] if size == 1 else out


def read_mapped_hit(mapping: str | Path, *, object_mass: Any = None, licence: str | None = None) -> Recording:
    """Read the hit a mapping file describes, clean it and return it as a :class:`Recording`.

    Raises
    ------
    InputError
        The mapping or a file it names is malformed: a missing column, a unit that is not
        of the quantity's kind or differs between a quantity's columns, a missing object mass.
    """
    mapping = Path(mapping)
    spec = read_yaml(mapping)
    if not isinstance(spec, dict) or not isinstance(spec.get("robot"), dict) or not isinstance(spec.get("object"),
                                                                                                dict):
        raise InputError(f"{mapping}: a mapping needs sections robot: and object:")
    mass = object_mass if object_mass is not None else spec.get("object_mass")
    if mass is None:
        raise InputError(f"{mapping}: object_mass is missing: the object's mass [kg] (or --object-mass)")
    mass = float(mass)
    parts = {}
    for part, names in (("robot", ("time", "ee_position", "joint_position")), ("object", ("time", "position"))):
        sec = spec[part]
        if "file" not in sec:
            raise InputError(f"{mapping}: {part}.file is missing")
        header, data = _table(mapping.parent / str(sec["file"]))
        parts[part] = {n: _quantity(sec, part, n, header, data, mapping, size=1 if n == "time" else
                                    (3 if n.endswith("position") and n != "joint_position" else None))
                       for n in names if n in sec or n != "joint_position"}
    r, o = parts["robot"], parts["object"]
    for part, arrays in parts.items():
        if len(arrays["time"]) < MIN_ROWS:
            raise InputError(f"{mapping}: the {part} file has {len(arrays['time'])} rows, fewer than the {MIN_ROWS} a "
                             "hit needs (fits before and after the contact)")
    fresh = drop_stale(r["ee_position"])
    t, order, stamps = repair_stamps(r["time"])
    keep = fresh & order
    t0 = float(t[keep][0])
    frame = spec["object"].get("frame") or {}
    rot = np.asarray(frame.get("rotation", np.eye(3)), dtype=float)
    trans = np.asarray(frame.get("translation", np.zeros(3)), dtype=float)
    if rot.shape != (3, 3) or trans.shape != (3,):
        raise InputError(f"{mapping}: object.frame needs a 3x3 rotation and a 3-vector translation [m]")
    ot, oorder, ostamps = repair_stamps(o["time"])
    opos = o["position"][oorder] @ rot.T + trans
    ot = ot[oorder] - t0
    given = spec["object"].get("clock_offset", "auto")
    offset = clock_offset(t[keep] - t0, r["ee_position"][keep], ot, opos) if given == "auto" else float(given)
    q = r.get("joint_position")
    q = q[keep] if q is not None else np.zeros((int(keep.sum()), 0))
    return Recording(
        session=str(spec.get("session", mapping.stem)), hit=str(spec.get("hit", "1")),
        robot_name=str(spec.get("robot_name", "robot")), object_mass=mass, t_robot=t[keep] - t0, q=q,
        ee_position=r["ee_position"][keep], t_object=ot + offset, object_position=opos,
        attrs={"source": str(spec.get("source", f"CSV files mapped by {mapping.name}")), "source_format": "csv",
               "license": str(licence if licence is not None else spec.get("license", NO_LICENCE)),
               "object_mass_source": "--object-mass" if object_mass is not None else f"{mapping.name}: object_mass",
               "robot_attrs": {"stale_rows_dropped": int((~fresh).sum()), "stamps_repaired": stamps.repaired,
                               "stamps_dropped": stamps.dropped},
               "object_attrs": {"stamps_repaired": ostamps.repaired, "stamps_dropped": ostamps.dropped,
                                "clock_offset": offset, "clock_offset_units": "s"}})
