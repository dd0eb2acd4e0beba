"""The air-hockey hitting dataset's layout: a robot file and an object file per hit.

Robot file ``<ROBOT>_hit_<N>.csv``: a first line of metadata
(``DesiredFlux,<v>,HitTime,<unix s>,DesiredPos,<x y z>``), a header line
(``RobotName,RosTime,JointPosition,JointVelocity,JointEffort,TorqueCmd,EEF_Position,
EEF_Orientation,EEF_Velocity,EEF_DesiredVelocity,Inertia,DirGrad,HittingFlux``), then one row
per logger tick (ROS wall time, about 200 Hz); a vector is one comma field of numbers
separated by spaces, possibly with leading spaces. ``Inertia`` is the row-major 3 x 3 inverse
translational task-space inertia of the controller's model [1/kg].

Object file ``object_<K>_hit_<N>.csv``: header ``RosTime,PositionFor<Robot>,...``, one row per
robot frame with the object's motion-capture position in that robot's base frame.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.files import open_regular
from .cleaning import clock_offset, drop_stale, repair_stamps
from .fileformat import NO_LICENCE, Recording

__all__ = ["ROBOT_COLUMNS", "read_airhockey_hit", "airhockey_hits", "object_column"]

#: the robot file's header
ROBOT_COLUMNS = ("RobotName", "RosTime", "JointPosition", "JointVelocity", "JointEffort", "TorqueCmd", "EEF_Position",
                 "EEF_Orientation", "EEF_Velocity", "EEF_DesiredVelocity", "Inertia", "DirGrad", "HittingFlux")
_ROBOT_FILE = re.compile(r"^(?P<robot>.+)_hit_(?P<hit>[0-9]+)\.csv$")
_OBJECT_FILE = re.compile(r"^object_(?P<object>[0-9]+)_hit_(?P<hit>[0-9]+)\.csv$")
_SOURCE = "air-hockey hitting dataset layout (robot and object CSV files per hit)"


def object_column(robot_name: str) -> str:
    """The object file's position column for a robot: ``IIWA_7`` -> ``PositionForIiwa7``."""
    return "PositionFor" + robot_name.replace("_", "").capitalize()


def _vector(text: str, *, where: str, size: int | None = None) -> np.ndarray:
    try:
        values = np.array([float(x) for x in text.split()], dtype=float)
    except ValueError:
        raise InputError(f"{where}: {text.strip()[:40]!r} is not a list of numbers") from None
    if size is not None and len(values) != size:
        raise InputError(f"{where}: {len(values)} numbers, expected {size}")
    return values


def _read_rows(path: Path, *, skip: int) -> tuple[list[str], list[list[str]]]:
    with open_regular(path, "r", what="recording file", encoding="utf-8", newline="") as fh:
        lines = fh.read().splitlines()
    if len(lines) < skip + 2:
        raise InputError(f"{path}: too short for the air-hockey layout (no header or no rows)")
    rows = list(csv.reader(lines[skip:]))
    return [c.strip() for c in rows[0]], [r for r in rows[1:] if r]


def _column(header: list[str], name: str, path: Path) -> int:
    if name not in header:
        raise InputError(f"{path}: no column {name!r} (header: {','.join(header)[:120]})")
    return header.index(name)


def _metadata(path: Path) -> dict[str, str]:
    with open_regular(path, "r", what="recording file", encoding="utf-8") as fh:
        first = fh.readline().strip().split(",")
    meta = dict(zip(first[0::2], first[1::2], strict=False))
    if "HitTime" not in meta:
        raise InputError(f"{path}: first line is not the air-hockey metadata (DesiredFlux,...,HitTime,...)")
    return meta


def airhockey_hits(folder: str | Path) -> list[tuple[str, Path, Path, str]]:
    """The hits of one session folder: (hit id, robot file, object file, object number), by hit number.

    Raises
    ------
    InputError
        Not a folder, no robot file, or a robot file without its object file.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder of air-hockey hits")
    objects = {}
    for p in folder.iterdir():
        m = _OBJECT_FILE.match(p.name)
        if m:
            objects[m.group("hit")] = (p, m.group("object"))
    hits = []
    for p in folder.iterdir():
        m = _ROBOT_FILE.match(p.name)
        if m and not _OBJECT_FILE.match(p.name):
            hit = m.group("hit")
            if hit not in objects:
                raise InputError(f"{p}: no object file object_<K>_hit_{hit}.csv beside it")
            hits.append((hit, p, objects[hit][0], objects[hit][1]))
    if not hits:
        raise InputError(f"{folder}: no robot files <ROBOT>_hit_<N>.csv")
    return sorted(hits, key=lambda h: int(h[0]))


def read_airhockey_hit(robot_file: str | Path, object_file: str | Path, *, object_mass: float, session: str,
                       hit: str, licence: str = NO_LICENCE, source: str | None = None,
                       min_rows: int = 20) -> Recording:
    """Read one hit of the air-hockey layout, clean it, and return it as a :class:`Recording`.

    Rows that repeat the previous end-effector pose (no new message) are dropped, glitched
    stamps repaired (:func:`campaign.recordings.cleaning.repair_stamps`), and the object's
    stamps moved onto the robot's clock (:func:`campaign.recordings.cleaning.clock_offset`);
    what was done is stored in the recording's attributes.
    """
    robot_file, object_file = Path(robot_file), Path(object_file)
    meta = _metadata(robot_file)
    header, rows = _read_rows(robot_file, skip=1)
    cols = {name: _column(header, name, robot_file) for name in ("RobotName", "RosTime", "JointPosition",
                                                                 "EEF_Position")}
    optional = {name: header.index(name) for name in ("JointVelocity", "EEF_Velocity", "Inertia") if name in header}
    if len(rows) < min_rows:
        raise InputError(f"{robot_file}: {len(rows)} rows, fewer than the {min_rows} a hit needs "
                         "(fits before and after the contact)")
    robot_name = rows[0][cols["RobotName"]].strip()

    def field(row, i, line, name, size=None):
        if i >= len(row):
            raise InputError(f"{robot_file}: line {line}: no {name} field")
        return _vector(row[i], where=f"{robot_file}: line {line}, {name}", size=size)

    t = np.array([float(field(r, cols["RosTime"], k + 3, "RosTime", 1)[0]) for k, r in enumerate(rows)])
    q = np.array([field(r, cols["JointPosition"], k + 3, "JointPosition") for k, r in enumerate(rows)])
    ee = np.array([field(r, cols["EEF_Position"], k + 3, "EEF_Position", 3) for k, r in enumerate(rows)])
    extra = {name: np.array([field(r, i, k + 3, name) for k, r in enumerate(rows)]) for name, i in optional.items()}
    # a row that repeats the end effector's pose (and what the controller logged with it) is stale
    fresh = drop_stale(ee)
    t_fixed, in_order, stamps = repair_stamps(t)
    keep = fresh & in_order
    t0 = float(t_fixed[keep][0])

    oheader, orows = _read_rows(object_file, skip=0)
    ot_col, op_col = _column(oheader, "RosTime", object_file), _column(oheader, object_column(robot_name), object_file)
    ot = np.array([float(_vector(r[ot_col], where=f"{object_file}: line {k + 2}, RosTime", size=1)[0])
                   for k, r in enumerate(orows)])
    op = np.array([_vector(r[op_col], where=f"{object_file}: line {k + 2}, position", size=3)
                   for k, r in enumerate(orows)])
    ot_fixed, o_order, ostamps = repair_stamps(ot)
    ot_fixed, op = ot_fixed[o_order], op[o_order]
    tr, eer = t_fixed[keep] - t0, ee[keep]
    offset = clock_offset(tr, eer, ot_fixed - t0, op)
    inertia = extra.get("Inertia")
    return Recording(
        session=session, hit=hit, robot_name=robot_name, object_mass=object_mass, t_robot=tr, q=q[keep],
        ee_position=eer, t_object=ot_fixed - t0 + offset, object_position=op,
        qd=extra["JointVelocity"][keep] if "JointVelocity" in extra else None,
        ee_velocity=extra["EEF_Velocity"][keep] if "EEF_Velocity" in extra else None,
        inertia_inv=inertia[keep].reshape(-1, 3, 3) if inertia is not None and inertia.shape[1] == 9 else None,
        attrs={"source": source or f"{_SOURCE}: {robot_file.name}, {object_file.name}",
               "source_format": "airhockey", "license": licence,
               "source_files": f"{robot_file.name} {object_file.name}",
               "time_origin_unix": t0, "hit_time_unix": float(meta["HitTime"]),
               "robot_attrs": {"rows_read": len(rows), "stale_rows_dropped": int((~fresh).sum()),
                               "stamps_repaired": stamps.repaired, "stamps_dropped": stamps.dropped},
               "object_attrs": {"rows_read": len(orows), "stamps_repaired": ostamps.repaired,
                                "stamps_dropped": ostamps.dropped, "clock_offset": offset,
                                "clock_offset_units": "s",
                                "clock_alignment": ("object stamps + clock_offset: the object's acceleration along "
                                                    "the impact direction cross-correlated with the end "
                                                    "effector's deceleration")}})
