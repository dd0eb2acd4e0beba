"""Recorded hits as archive files: the layout of a recording folder, writing, reading and verifying it.

A recorded hit is one NetCDF4/HDF5 file, ``<folder>/<session>/hit_<NNN>.nc``, with the
archive's conventions (CF units and long names, ACDD global attributes, provenance, a
content digest per group, written atomically) and two groups for what was recorded:
``/robot`` (its own clock: joint positions and velocities, end-effector position, the
end-effector velocity and the controller model's inverse task-space inertia when logged)
and ``/object`` (its own clock, aligned to the robot's: the struck object's position). There
is no ``/truth`` group: nothing but the recording is known. The folder holds ``index.csv``
(one row per hit), ``README.md`` and ``MANIFEST.sha256`` (``sha256sum`` format).
"""

from __future__ import annotations

import csv
import dataclasses
import datetime as _dt
import hashlib
import io
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import xarray as xr

from ..archive import MANIFEST, README, content_digest, provenance
from ..core.errors import InputError, TrialFileError
from ..core.files import not_regular, replace_atomically, sha256_file, source_date_epoch, write_atomic

__all__ = ["RECORDING_GROUPS", "RECORDING_INDEX", "RECORDING_SCHEMA", "INDEX_COLUMNS", "NO_LICENCE", "Recording",
           "write_recording", "read_recording", "recording_path", "finalize_recordings", "is_recording_folder",
           "verify_recordings", "recording_files"]

RECORDING_SCHEMA = "recording-1.0"
RECORDING_GROUPS = ("robot", "object")
RECORDING_INDEX = "index.csv"
#: index.csv of a recording folder; its header tells a recording folder from a campaign folder
INDEX_COLUMNS = ("path", "session", "hit", "robot_name", "object_mass", "source_format", "license")
#: the licence attribute of a recording whose source states none
NO_LICENCE = "none stated"
_HIT_RE = re.compile(r"^hit_[0-9A-Za-z_.-]+\.nc$")
_MANIFEST_LINE = re.compile(r"^([0-9a-f]{64}) [ *](.+)$")
_TEMP_RE = re.compile(r"^\..+\.tmp$")
#: keys of Recording.attrs that hold a group's attributes rather than a root attribute
_GROUP_ATTRS = ("robot_attrs", "object_attrs")

#: the variables of each group: name -> (dims, units, long_name, required)
VARIABLES = {
    "robot": {
        "q": (("t_robot", "joint"), "rad", "joint position", True),
        "qd": (("t_robot", "joint"), "rad s-1", "joint velocity", False),
        "ee_position": (("t_robot", "axis"), "m", "end-effector position, robot base frame", True),
        "ee_velocity": (("t_robot", "axis"), "m s-1", "end-effector velocity logged by the controller, robot base frame",
                        False),
        "inertia_inv": (("t_robot", "axis", "axis2"), "kg-1",
                        "inverse translational task-space inertia of the controller's rigid-body model", False),
    },
    "object": {
        "position": (("t_object", "axis"), "m", "struck object's position, robot base frame", True),
    },
}
_CLOCK_NAMES = {"t_robot": "robot sample time, seconds from the first robot sample",
                "t_object": "object sample time on the robot's clock, seconds from the first robot sample"}


@dataclasses.dataclass
class Recording:
    """One recorded hit in memory: what a recording file holds.

    Attributes
    ----------
    session, hit : str
        The session (a folder of hits) and the hit's id within it.
    robot_name : str
    object_mass : float
        The struck object's mass [kg].
    t_robot : ndarray, shape (N,)
        Robot sample times [s] from the first robot sample.
    q : ndarray, shape (N, n_joints)
        Joint positions [rad].
    ee_position : ndarray, shape (N, 3)
        End-effector position [m], robot base frame.
    t_object : ndarray, shape (M,)
        Object sample times [s] on the robot's clock.
    object_position : ndarray, shape (M, 3)
        Object position [m], robot base frame.
    qd, ee_velocity, inertia_inv : ndarray or None
        Joint velocities [rad/s], logged end-effector velocity [m/s], logged inverse
        task-space inertia (N, 3, 3) [1/kg], when recorded.
    attrs : dict
        Further root attributes: ``source`` (what the data came from), ``license`` (the
        source's licence), ``object_mass_source``, the import's report (rows dropped, stamps
        repaired, clock offset), ``time_origin_unix`` where known.
    """

    session: str
    hit: str
    robot_name: str
    object_mass: float
    t_robot: np.ndarray
    q: np.ndarray
    ee_position: np.ndarray
    t_object: np.ndarray
    object_position: np.ndarray
    qd: np.ndarray | None = None
    ee_velocity: np.ndarray | None = None
    inertia_inv: np.ndarray | None = None
    attrs: dict[str, Any] = dataclasses.field(default_factory=dict)

    def arrays(self, group: str) -> dict[str, np.ndarray]:
        """The group's variables that are present."""
        if group == "robot":
            found = {"q": self.q, "qd": self.qd, "ee_position": self.ee_position, "ee_velocity": self.ee_velocity,
                     "inertia_inv": self.inertia_inv}
        else:
            found = {"position": self.object_position}
        return {k: np.asarray(v, dtype=float) for k, v in found.items() if v is not None}


def _check_attr(key: str, value: Any) -> Any:
    if isinstance(value, (bool, np.bool_)) or value is None:
        raise InputError(f"recording attribute {key!r} is {value!r}: attributes are str or numbers")
    if isinstance(value, (str, int, float, np.integer, np.floating)):
        return value
    raise InputError(f"recording attribute {key!r} is a {type(value).__name__}: attributes are str or numbers")


def _check(rec: Recording) -> None:
    """Shapes, finiteness and order, before anything is written."""
    if not (np.isfinite(rec.object_mass) and rec.object_mass > 0):
        raise InputError(f"object mass {rec.object_mass!r} kg: must be a positive number")
    n, m = len(rec.t_robot), len(rec.t_object)
    shapes = {"q": (n, None), "qd": (n, None), "ee_position": (n, 3), "ee_velocity": (n, 3),
              "inertia_inv": (n, 3, 3), "position": (m, 3)}
    for group in RECORDING_GROUPS:
        for name, arr in rec.arrays(group).items():
            want = shapes[name]
            if arr.ndim != len(want) or any(w is not None and w != s for w, s in zip(want, arr.shape, strict=True)):
                raise InputError(f"recording {rec.session}/{rec.hit}: /{group}/{name} has shape {arr.shape}, "
                                 f"expected {tuple('J' if w is None else w for w in want)}")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"recording {rec.session}/{rec.hit}: /{group}/{name} holds non-finite values")
    for name, t in (("t_robot", rec.t_robot), ("t_object", rec.t_object)):
        if len(t) < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError(f"recording {rec.session}/{rec.hit}: {name} must hold at least two increasing times")


def _group_dataset(rec: Recording, group: str) -> xr.Dataset:
    clock = "t_robot" if group == "robot" else "t_object"
    t = np.asarray(rec.t_robot if group == "robot" else rec.t_object, dtype=float)
    coords: dict[str, Any] = {clock: (clock, t, {"units": "s", "long_name": _CLOCK_NAMES[clock],
                                                 "coverage_content_type": "coordinate"})}
    data = {}
    for name, arr in rec.arrays(group).items():
        dims, units, long_name, _ = VARIABLES[group][name]
        data[name] = (dims, arr, {"units": units, "long_name": long_name,
                                  "coverage_content_type": "physicalMeasurement"})
    coords["axis"] = ("axis", np.array(["x", "y", "z"]), {"long_name": "Cartesian axis, robot base frame"})
    if group == "robot":
        nj = rec.q.shape[1]
        coords["joint"] = ("joint", np.array([f"joint_{k + 1}" for k in range(nj)]), {"long_name": "joint"})
        if rec.inertia_inv is not None:
            coords["axis2"] = ("axis2", np.array(["x", "y", "z"]),
                               {"long_name": "Cartesian axis, robot base frame (second index of a tensor)"})
    ds = xr.Dataset(data, coords=coords)
    for name in ds.variables:
        ds[name].encoding = {"zlib": True, "complevel": 1, "shuffle": True} if ds[name].dtype.kind == "f" else {}
    return ds


def _digest(ds: xr.Dataset, attrs: Mapping[str, Any]) -> str:
    return content_digest(attrs, {name: (np.asarray(v.values), dict(v.attrs)) for name, v in ds.variables.items()})


def _root_attrs(rec: Recording) -> dict[str, Any]:
    when = source_date_epoch() or _dt.datetime.now(_dt.UTC)
    created = when.strftime("%Y-%m-%dT%H:%M:%SZ")
    given = {k: _check_attr(k, v) for k, v in rec.attrs.items() if k not in _GROUP_ATTRS}
    licence = str(given.pop("license", NO_LICENCE))
    source = str(given.pop("source", "unknown"))
    root = {
        "title": f"Recorded impact {rec.session}/{rec.hit}: {rec.robot_name} striking an object",
        "summary": ("One recorded hit of a robot arm striking an object, imported from its source files. Group "
                    "/robot holds the robot's samples, group /object the object's positions on the robot's clock; "
                    "there is no truth group."),
        "keywords": "impact dynamics, effective mass, restitution coefficient, robot arm, recorded data",
        "Conventions": "CF-1.11, ACDD-1.3",
        "id": "campaign-recording-" + hashlib.sha256(f"{source}|{rec.session}|{rec.hit}".encode()).hexdigest()[:32],
        "date_created": created,
        "creator_name": "the recording's authors (see source)",
        "creator_type": "group",
        "project": ("campaign: a reproducible simulated re-run of Yoshida, Mavroidis and Dubowsky, "
                    "Impact Dynamics of Space Long Reach Manipulators"),
        "processing_level": ("recorded samples; rows without a new pose dropped, stamp glitches repaired, the "
                             "object's clock aligned to the robot's (see the import attributes)"),
        "history": f"{created} imported by campaign {provenance()['campaign_version']}",
        "license": licence,
        "source": source,
        "recording_schema": RECORDING_SCHEMA,
        "session": rec.session,
        "hit": rec.hit,
        "robot_name": rec.robot_name,
        "object_mass": float(rec.object_mass),
        "object_mass_units": "kg",
        **given,
        **provenance(),
    }
    root["content_sha256"] = content_digest(root, {})
    return root


def recording_path(folder: str | os.PathLike, session: str, hit: str) -> Path:
    """``<folder>/<session>/hit_<hit>.nc`` (a numeric hit id is zero-padded to three digits)."""
    for what, name in (("session", session), ("hit", hit)):
        if not name or "/" in name or name.startswith(".") or not re.fullmatch(r"[0-9A-Za-z_.-]+", name):
            raise InputError(f"{what} name {name!r}: use letters, digits, '_', '-' and '.' only")
    label = f"{int(hit):03d}" if hit.isdigit() else hit
    return Path(folder) / session / f"hit_{label}.nc"


def write_recording(rec: Recording, folder: str | os.PathLike) -> Path:
    """Check a recorded hit and write it atomically at :func:`recording_path` in ``folder``."""
    _check(rec)
    root = _root_attrs(rec)
    groups = {}
    for group in RECORDING_GROUPS:
        ds = _group_dataset(rec, group)
        attrs = {"comment": ("the robot's samples as logged" if group == "robot"
                             else "the struck object's positions, on the robot's clock"),
                 **{k: _check_attr(k, v) for k, v in rec.attrs.get(f"{group}_attrs", {}).items()}}
        attrs["content_sha256"] = _digest(ds, attrs)
        ds.attrs = attrs
        groups[group] = ds
    path = recording_path(folder, rec.session, rec.hit)

    def write(tmp: Path) -> None:
        xr.Dataset(attrs=root).to_netcdf(tmp, engine="h5netcdf", mode="w")
        for group, ds in groups.items():
            ds.to_netcdf(tmp, engine="h5netcdf", mode="a", group=group)

    return replace_atomically(path, write, clear_stale=True)


def read_recording(path: str | os.PathLike) -> Recording:
    """A recorded hit read back (its group digests checked).

    Raises
    ------
    TrialFileError
        Not a regular file, not a recording, a required variable missing, or content that
        does not match its digest.
    """
    problems, rec = _inspect(Path(path))
    if problems or rec is None:
        raise TrialFileError(f"{path}: " + "; ".join(problems or ["not a recording"]))
    return rec


def _inspect(path: Path) -> tuple[list[str], Recording | None]:
    """(problems, the recording when readable)."""
    kind = not_regular(path)
    if kind:
        return [kind], None
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("recording_schema") != RECORDING_SCHEMA:
                return [f"not a recording of schema {RECORDING_SCHEMA}"], None
            missing = [g for g in RECORDING_GROUPS if g not in f]
            if missing:
                return [f"missing group(s) {', '.join(missing)}"], None
    except OSError as exc:
        return [f"unreadable ({exc})"], None
    try:
        with xr.open_dataset(path, engine="h5netcdf") as root_ds:
            root = dict(root_ds.attrs)
        data = {}
        problems = []
        for group in RECORDING_GROUPS:
            with xr.open_dataset(path, engine="h5netcdf", group=group) as ds:
                ds.load()
            attrs = {k: v for k, v in ds.attrs.items() if k != "content_sha256"}
            stored = ds.attrs.get("content_sha256")
            if stored != _digest(ds, attrs):
                problems.append(f"/{group}: content differs from its content_sha256 (altered or corrupt)")
            for name, (_, _, _, required) in VARIABLES[group].items():
                if required and name not in ds:
                    problems.append(f"/{group}: missing variable {name}")
            data[group] = ds
    except (OSError, ValueError, KeyError) as exc:
        return [f"unreadable ({exc})"], None
    if problems:
        return problems, None
    r, o = data["robot"], data["object"]

    def opt(name):
        return np.asarray(r[name].values) if name in r else None

    keep = {k: v for k, v in root.items() if k not in ("session", "hit", "robot_name", "object_mass")}
    rec = Recording(session=str(root["session"]), hit=str(root["hit"]), robot_name=str(root["robot_name"]),
                    object_mass=float(root["object_mass"]), t_robot=np.asarray(r["t_robot"].values),
                    q=np.asarray(r["q"].values), ee_position=np.asarray(r["ee_position"].values),
                    t_object=np.asarray(o["t_object"].values), object_position=np.asarray(o["position"].values),
                    qd=opt("qd"), ee_velocity=opt("ee_velocity"), inertia_inv=opt("inertia_inv"),
                    attrs={**keep, "robot_attrs": dict(r.attrs), "object_attrs": dict(o.attrs)})
    return [], rec


def recording_files(folder: str | os.PathLike) -> list[Path]:
    """The hit files of a recording folder (``<session>/hit_*.nc``), sorted."""
    return sorted(p for p in Path(folder).glob("*/hit_*.nc") if _HIT_RE.match(p.name))


def is_recording_folder(folder: str | os.PathLike) -> bool:
    """Whether ``folder`` is a recording folder: its ``index.csv`` has the recording header."""
    index = Path(folder) / RECORDING_INDEX
    if not_regular(index):
        return False
    with open(index, encoding="utf-8", errors="replace") as fh:
        return fh.readline().strip() == ",".join(INDEX_COLUMNS)


def _rows(folder: Path) -> list[dict[str, Any]]:
    rows = []
    for path in recording_files(folder):
        problems, rec = _inspect(path)
        if problems or rec is None:
            raise TrialFileError(f"cannot finalize {folder}: {path}: " + "; ".join(problems))
        rows.append({"path": path.relative_to(folder).as_posix(), "session": rec.session, "hit": rec.hit,
                     "robot_name": rec.robot_name, "object_mass": f"{rec.object_mass:g}",
                     "source_format": str(rec.attrs.get("source_format", "")),
                     "license": str(rec.attrs.get("license", ""))})
    return rows


def finalize_recordings(folder: str | os.PathLike) -> dict[str, Path]:
    """Write ``index.csv``, ``README.md`` and ``MANIFEST.sha256`` (last) of a recording folder."""
    folder = Path(folder)
    rows = _rows(folder)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=INDEX_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    index = write_atomic(folder / RECORDING_INDEX, buf.getvalue())
    readme = write_atomic(folder / README, _readme(folder.resolve().name, rows))
    lines = []
    for path in sorted(p for p in folder.rglob("*") if p.is_file() and p.name != MANIFEST):
        rel = path.relative_to(folder).as_posix()
        if _TEMP_RE.match(path.name):
            raise InputError(f"{path} is a temporary file of an interrupted write: delete it first")
        lines.append(f"{sha256_file(path)}  {rel}\n")
    manifest = write_atomic(folder / MANIFEST, "".join(lines))
    return {"index": index, "readme": readme, "manifest": manifest}


def _readme(name: str, rows: list[dict[str, Any]]) -> str:
    var_lines = [f"| `/{g}/{n}` | ({', '.join(spec[0])}) | `{spec[1]}` | {spec[2]} | {'yes' if spec[3] else 'if logged'} |"
                 for g in RECORDING_GROUPS for n, spec in VARIABLES[g].items()]
    sessions = sorted({r["session"] for r in rows})
    return "\n".join([
        f"# Recordings `{name}`", "",
        "Generated by `campaign import`; do not edit, regenerate it.", "",
        f"{len(rows)} recorded hit(s) in {len(sessions)} session(s): {', '.join(sessions) or '-'}.", "",
        "- `<session>/hit_<NNN>.nc`: one recorded hit, NetCDF4/HDF5, groups `/robot` and `/object` (no `/truth`).",
        f"- `{RECORDING_INDEX}`: one row per hit: " + ", ".join(f"`{c}`" for c in INDEX_COLUMNS) + ".",
        f"- `{MANIFEST}`: sha256 of every other file (`sha256sum -c {MANIFEST}`, or `campaign archive verify`).",
        "", "The root attributes carry the source (`source`), its licence (`license`), the object's mass "
        "(`object_mass`, kg) and where it came from (`object_mass_source`), and what the import changed.", "",
        "| variable | dims | units | long_name | present |", "|---|---|---|---|---|", *var_lines, ""])


def verify_recordings(folder: str | os.PathLike) -> list[tuple[str, str]]:
    """Check a recording folder: its manifest, every hit file (groups, variables, digests) and its index.

    Returns ``(relative path, message)`` pairs, empty when the folder is intact.
    """
    folder = Path(folder)
    problems: list[tuple[str, str]] = []
    listed: dict[str, str] = {}
    manifest = folder / MANIFEST
    if not_regular(manifest):
        problems.append((MANIFEST, "missing: the folder is not finalized"))
    else:
        for n, line in enumerate(manifest.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            m = _MANIFEST_LINE.match(line)
            if not m or m.group(2).startswith("/") or ".." in Path(m.group(2)).parts:
                problems.append((MANIFEST, f"line {n} is not '<sha256>  <relative path>': {line[:80]!r}"))
                continue
            listed[m.group(2)] = m.group(1)
        for rel, digest in listed.items():
            kind = not_regular(folder / rel)
            if kind:
                problems.append((rel, f"listed in {MANIFEST} but missing" if kind == "does not exist" else kind))
            elif sha256_file(folder / rel) != digest:
                problems.append((rel, f"sha256 differs from {MANIFEST} (altered, corrupt or truncated)"))
    for path in sorted(p for p in folder.rglob("*") if p.is_file() and p.name != MANIFEST):
        rel = path.relative_to(folder).as_posix()
        if rel not in listed and listed:
            problems.append((rel, f"not in {MANIFEST}"))
    hits = {p.relative_to(folder).as_posix(): p for p in recording_files(folder)}
    for rel, path in hits.items():
        problems += [(rel, message) for message in _inspect(path)[0]]
    if not not_regular(folder / RECORDING_INDEX):
        with open(folder / RECORDING_INDEX, newline="", encoding="utf-8") as fh:
            indexed = {row.get("path", "") for row in csv.DictReader(fh)}
        problems += [(RECORDING_INDEX, f"lists {rel}, which is not a hit file") for rel in sorted(indexed - set(hits))]
        problems += [(rel, f"not listed in {RECORDING_INDEX}") for rel in sorted(set(hits) - indexed)]
    return problems
