"""The trial file format: layout constants, provenance, the content digest, and the checked plan of what a trial file holds."""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import hashlib
import json
import re
import subprocess
import zlib
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _dist_version
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from .. import __version__
from ..core.errors import InputError
from ..core.files import source_date_epoch
from ..core.lazy import LazyModule
from ..scene.description import Scene
from ..scene.schema import (
    CLOCKS,
    COORDS,
    SCHEMA_VERSION,
    GroupArrays,
    TrialArrays,
    variables,
)
from .machine import platform_attributes, platform_summary

#: xarray, imported on first use (:mod:`campaign.core.lazy`): jobs that only check or index
#: trial files (``finalize_archive``, ``verify``) never need it
xr: Any = LazyModule("xarray")


GROUPS = ("measured", "truth")
TRIAL_SUFFIX = ".nc"
MANIFEST = "MANIFEST.sha256"
INDEX = "index.csv"
README = "README.md"
#: folder of the workflow's job manifests inside a campaign folder (:mod:`campaign.archive.jobs`)
JOBS = ".jobs"

#: the campaign cell: the dimensions of :func:`open_campaign` and :func:`to_cell_dataset`
CELL_KEYS = ("base", "config", "gain", "speed", "repeat")
#: columns of index.csv, in order
INDEX_COLUMNS = ("path", "base", "config", "gain", "speed", "repeat", "seed", "scene", "scene_sha256",
                 "robot", "schema_version", "q_paper_deg", "direction")
#: keys accepted by :func:`list_trials` filters, with the type a value is read as
FILTER_KEYS = {"base": str, "config": int, "gain": str, "speed": float, "repeat": int, "seed": int,
               "scene": str, "scene_sha256": str, "robot": str}

REFERENCES = ("Yoshida, K., Mavroidis, C. and Dubowsky, S., \"Impact Dynamics of Space Long Reach "
              "Manipulators\", Proc. 1996 IEEE International Conference on Robotics and Automation, "
              "Minneapolis, MN, pp. 1909-1916")

# Chosen with benchmarks/bench_archive.py and benchmarks/bench_identify_write.py: deflate
# level 1 + shuffle compresses float channels as well as level 4 or 9 (the noise bits
# dominate) at the lowest cost; one chunk holds up to 256 KiB, so a trial's channels are one
# chunk each and long recordings still split along time. Deflate is kept where it pays
# (clocks, quantised channels, smooth truth states: 1.5-28x) and left out where it does not
# (noisy F/T and base-pose channels: 1.1-1.3x, which cost as much to deflate as the rest):
# the user guide's *Benchmarks* page has the measurement.
DEFLATE_LEVEL = 1
_CHUNK_BYTES = 1 << 18
#: deflate a channel when its sample compresses to at most this fraction of its bytes
DEFLATE_PAYS = 0.7
#: bytes of a channel's sample for that test (from the middle of the record); channels
#: smaller than :data:`_PROBE_MIN_BYTES` are deflated untested (either way they cost little)
_PROBE_BYTES = 1 << 13
_PROBE_MIN_BYTES = 1 << 15

SCHEMA_MAJOR = int(SCHEMA_VERSION.split(".")[0])
_ROOT_REQUIRED = ("scene_json", "scene_sha256", "seed", "base", "config", "gain", "speed", "repeat", "robot")
# attributes HDF5/netCDF-4 bookkeeping owns: not content, excluded from content_sha256
STRUCTURAL_ATTRS = frozenset({"CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "_Netcdf4Dimid",
                         "_Netcdf4Coordinates", "_NCProperties", "content_sha256"})
_GROUP_COMMENT = {
    "measured": "channels a real VES-II records (noisy, quantised, each on its own clock) and the instrument "
                "constants an experimenter knows; identification reads only this group",
    "truth": "simulator truth (exact states, contact force and interval); kept apart from the measured "
             "channels, identification never reads it",
}
LABEL_LONG_NAMES = {"joint": "active joint name", "axis": "Cartesian axis, base frame",
                     "axis2": "Cartesian axis, base frame (second index of a tensor)"}
TEMP_FILE_RE = re.compile(r"^\..+\.tmp$")


# ---------------------------------------------------------------------------------------
# provenance
# ---------------------------------------------------------------------------------------
@functools.cache
def _git_commit() -> str:
    """Commit of the source tree this package runs from, ``-dirty`` if modified; else "unknown"."""
    here = Path(__file__).resolve().parent
    try:
        top = subprocess.run(["git", "-C", str(here), "rev-parse", "--show-toplevel"], capture_output=True,
                             text=True, timeout=10, check=True).stdout.strip()
        # an installed copy inside some other repository must not report that repository's commit
        if not top or not here.is_relative_to(Path(top).resolve()):
            return "unknown"
        head = subprocess.run(["git", "-C", top, "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", top, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=30, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return f"{head}-dirty" if dirty else head or "unknown"


def _dist(*names: str) -> str:
    """The installed version of the first distribution of ``names`` that is installed."""
    for name in names:
        try:
            return _dist_version(name)
        except PackageNotFoundError:
            continue
    return "not installed"


@functools.cache
def _provenance() -> tuple[tuple[str, str], ...]:
    found = {
        "campaign_version": __version__,
        "git_commit": _git_commit(),
        "numpy_version": _dist("numpy"),
        "scipy_version": _dist("scipy"),
        # "pin" on PyPI, "pinocchio" as conda-forge installs it
        "pinocchio_version": _dist("pin", "pinocchio"),
        "xarray_version": _dist("xarray"),
        "h5py_version": _dist("h5py"),
        "h5netcdf_version": _dist("h5netcdf"),
        "hdf5_version": h5py.version.hdf5_version,
        **platform_attributes(),
    }
    found["computing_platform"] = platform_summary(found)
    return tuple(found.items())


def provenance() -> dict[str, str]:
    """With what a trial was computed: stored in every trial, found once per process.

    A trial recomputed with other versions or on another platform is the same trial when its
    content is (:func:`campaign.archive.write_trial_entry` ignores these attributes).

    Returns
    -------
    dict of str to str
        ``campaign_version``, ``git_commit`` (``"unknown"`` outside a git checkout, suffixed
        ``-dirty`` when tracked files are modified), ``numpy_version``, ``scipy_version``,
        ``pinocchio_version``, ``xarray_version``, ``h5py_version``, ``h5netcdf_version``,
        ``hdf5_version``; the platform (:func:`campaign.archive.machine.platform_attributes`);
        and ``computing_platform``, its one-line summary
        (:func:`campaign.archive.machine.platform_summary`).
    """
    return dict(_provenance())


# ---------------------------------------------------------------------------------------
# content digest (shared by the writer and every reader)
# ---------------------------------------------------------------------------------------
def canonical_bytes(value: Any) -> bytes:
    """Canonical bytes of an attribute value or array, equal for what is written and read back.

    h5py returns variable-length strings as ``str`` (attributes) or ``bytes`` (datasets) and
    scalars as numpy scalars; the canonical form only keeps what the value means.
    """
    if isinstance(value, str):
        return b"s" + value.encode()
    if isinstance(value, bytes):
        return b"s" + value
    a = np.asarray(value)
    if a.dtype.kind in "OUS":
        parts = [x.encode() if isinstance(x, str) else bytes(x) for x in a.ravel().tolist()]
        return b"S" + repr(a.shape).encode() + b"".join(len(p).to_bytes(8, "little") + p for p in parts)
    a = np.asarray(a, order="C")
    return b"n" + a.dtype.str.encode() + repr(a.shape).encode() + a.tobytes()


def content_digest(attrs: Mapping[str, Any], variables_: Mapping[str, tuple[Any, Mapping[str, Any]]]) -> str:
    """sha256 of one group's content: its attributes and each variable's data and attributes."""
    h = hashlib.sha256()

    def feed_attrs(a: Mapping[str, Any]) -> None:
        for key in sorted(k for k in a if k not in STRUCTURAL_ATTRS):
            value = a[key]
            # netCDF attributes are 1-d: a number may come back as a scalar or a 1-element array
            if not isinstance(value, (str, bytes)):
                value = np.ravel(value)
            for part in (key.encode(), canonical_bytes(value)):
                h.update(len(part).to_bytes(8, "little"))
                h.update(part)

    feed_attrs(attrs)
    for name in sorted(variables_):
        data, vattrs = variables_[name]
        for part in (b"\x00var", name.encode(), canonical_bytes(data)):
            h.update(len(part).to_bytes(8, "little"))
            h.update(part)
        feed_attrs(vattrs)
    return h.hexdigest()


# ---------------------------------------------------------------------------------------
# checking and completing a trial before it is written
# ---------------------------------------------------------------------------------------
def _check_attr(where: str, key: str, value: Any) -> None:
    """Attributes must be str, numbers or numeric/str arrays: what every netCDF reader keeps."""
    if key in STRUCTURAL_ATTRS or key.startswith("_"):
        raise InputError(f"attribute {key!r} of {where}: names starting with '_' and HDF5 dimension-scale "
                         "names are reserved for the file format")
    ok = False
    if isinstance(value, str):
        ok = True
    elif isinstance(value, (bool, np.bool_)) or value is None:
        ok = False
    elif isinstance(value, (int, float, np.integer, np.floating)):
        ok = True
    elif isinstance(value, np.ndarray) and value.dtype.kind in "iufU" and value.ndim == 1:
        ok = True
    if not ok:
        raise InputError(f"attribute {key!r} of {where} is a {type(value).__name__} ({value!r:.60}); "
                         "trial attributes must be str, numbers or 1-d numeric/str arrays (no dict, None, bool)")


@dataclasses.dataclass
class VariablePlan:
    """One variable as it will be stored (plain numpy + dicts: cheaper than xarray objects)."""

    name: str
    dims: tuple[str, ...]
    data: np.ndarray
    attrs: dict[str, Any]
    encoding: dict[str, Any]


@dataclasses.dataclass
class GroupPlan:
    attrs: dict[str, Any]
    variables: list[VariablePlan]  # dimension coordinates first, then the schema's variables in schema order


#: ACDD coverage_content_type of a group's time series; constants of the rig (no clock)
#: are "referenceInformation", coordinates "coordinate"
_COVERAGE = {"measured": "physicalMeasurement", "truth": "modelResult"}


def _validate_group(group: str, ds: xr.Dataset | GroupArrays, base: str) -> GroupPlan:
    """Check one group against the schema; fill units/long_name the rig left out."""
    expected = {v.name: v for v in variables(group, base)}
    names = set(ds.data_vars)
    missing = [n for n in expected if n not in names]
    if missing:
        raise InputError(f"trial group /{group} ({base} base) is missing {', '.join(missing)} "
                         f"(schema {SCHEMA_VERSION}, campaign/scene/schema.py)")
    unknown = sorted(names - set(expected))
    if unknown:
        raise InputError(f"trial group /{group} ({base} base) has variables not in schema {SCHEMA_VERSION}: "
                         f"{', '.join(unknown)}; add them to campaign/scene/schema.py with a version bump")
    out = []
    for name, spec in expected.items():
        var = ds.variables[name]
        if var.dims != spec.dims:
            raise InputError(f"/{group}/{name} has dims {var.dims}, schema says {spec.dims}")
        if var.dtype.kind not in "iuf":
            raise InputError(f"/{group}/{name} has dtype {var.dtype}; channels must be integer or float")
        attrs = dict(var.attrs)
        if "units" in attrs and attrs["units"] != spec.units:
            raise InputError(f"/{group}/{name} has units {attrs['units']!r}, schema says {spec.units!r}")
        attrs.setdefault("units", spec.units)
        attrs.setdefault("long_name", spec.long_name)
        attrs.setdefault("coverage_content_type", _COVERAGE[group] if any(d in CLOCKS for d in spec.dims)
                         else "referenceInformation")
        for key, value in attrs.items():
            _check_attr(f"/{group}/{name}", key, value)
        data = np.asarray(var.values, order="C")
        out.append(VariablePlan(name, var.dims, data, attrs, _encoding(var.dims, data)))
    coords = []
    for dim in ds.dims:
        if dim in CLOCKS:
            if dim not in ds.coords:
                raise InputError(f"/{group} time dimension {dim} has no coordinate (seconds from recording start)")
            c = ds.variables[dim]
            if c.dtype != np.float64:
                raise InputError(f"/{group} time coordinate {dim} has dtype {c.dtype}, expected float64 seconds")
            attrs = dict(c.attrs)
            if attrs.get("units", "s") != "s":
                raise InputError(f"/{group} time coordinate {dim} has units {attrs['units']!r}, expected 's'")
            # seconds from the start of the recording: a duration, not a date, so no
            # standard_name "time" (CF reserves it for coordinates with a "since" epoch)
            attrs.pop("standard_name", None)
            attrs.update(units="s")
            attrs.setdefault("long_name", CLOCKS[dim].long_name)
            values = np.asarray(c.values, order="C")
        elif dim in COORDS:
            if dim in ds.coords:
                values = np.asarray(ds.variables[dim].values)
                attrs = dict(ds.variables[dim].attrs)
            elif COORDS[dim] is not None:
                values, attrs = np.asarray(COORDS[dim]), {}
            else:
                raise InputError(f"/{group} dimension {dim} has no coordinate (the robot's active joint names)")
            if values.dtype.kind not in "UO" or not all(isinstance(x, str) for x in values.tolist()):
                raise InputError(f"/{group} coordinate {dim} must hold names (str), got dtype {values.dtype}")
            if COORDS[dim] is not None and tuple(values.tolist()) != tuple(COORDS[dim]):
                raise InputError(f"/{group} coordinate {dim} is {values.tolist()}, schema says {list(COORDS[dim])}")
            values = values.astype(str)
            attrs.setdefault("long_name", LABEL_LONG_NAMES[dim])
        else:
            raise InputError(f"/{group} has dimension {dim!r}, which is neither a schema clock nor a label dimension")
        attrs.setdefault("coverage_content_type", "coordinate")
        for key, value in attrs.items():
            _check_attr(f"/{group}/{dim}", key, value)
        coords.append(VariablePlan(dim, (dim,), values, attrs, _encoding((dim,), values)))
    extra = sorted(set(ds.coords) - set(ds.dims))
    if extra:
        raise InputError(f"/{group} has non-dimension coordinates {extra}; the schema has none")
    given = {k: v for k, v in ds.attrs.items() if k != "content_sha256"}
    for key, value in given.items():
        _check_attr(f"/{group}", key, value)
    attrs = {"comment": _GROUP_COMMENT[group], **given, "schema_version": SCHEMA_VERSION}
    variables_ = coords + out
    attrs["content_sha256"] = content_digest(attrs, {v.name: (v.data, v.attrs) for v in variables_})
    return GroupPlan(attrs, variables_)


def _scene_of(attrs: Mapping[str, Any]) -> Scene:
    """The Scene a trial's root attributes describe, checked against the cell attributes."""
    missing = [k for k in _ROOT_REQUIRED if k not in attrs]
    if missing:
        raise InputError(f"trial root attributes are missing {', '.join(missing)}")
    text = attrs["scene_json"]
    if not isinstance(text, str) or hashlib.sha256(text.encode()).hexdigest() != attrs["scene_sha256"]:
        raise InputError("trial attribute scene_sha256 is not the sha256 of scene_json")
    try:
        scene = Scene.from_json(text)
    except (KeyError, TypeError, json.JSONDecodeError) as exc:
        raise InputError(f"trial attribute scene_json is not a scene: {exc}") from None
    for key in ("base", "config", "gain", "speed", "repeat", "seed"):
        if attrs[key] != getattr(scene, key):
            raise InputError(f"trial attribute {key}={attrs[key]!r} disagrees with its scene ({getattr(scene, key)!r})")
    return scene


def _deflate_pays(data: np.ndarray) -> bool:
    """Whether shuffle + deflate stores ``data`` in at most :data:`DEFLATE_PAYS` of its
    bytes, judged on a sample of :data:`_PROBE_BYTES` from the middle of the record."""
    flat = data.reshape(-1)
    n = min(flat.size, max(1, _PROBE_BYTES // data.dtype.itemsize))
    start = (flat.size - n) // 2
    sample = np.ascontiguousarray(flat[start:start + n])
    # HDF5's shuffle filter: the first bytes of every element, then the second bytes, ...
    shuffled = sample.view(np.uint8).reshape(n, data.dtype.itemsize).T.tobytes()
    return len(zlib.compress(shuffled, DEFLATE_LEVEL)) <= DEFLATE_PAYS * len(shuffled)


def _encoding(dims: tuple[str, ...], data: np.ndarray) -> dict[str, Any]:
    """Storage of one variable (xarray encoding keys): time series chunked along time and
    deflated where deflate pays (:func:`_deflate_pays`; a small one always), else contiguous
    like constants and labels."""
    if data.ndim and dims[0] in CLOCKS and data.size and (data.nbytes < _PROBE_MIN_BYTES or _deflate_pays(data)):
        row_bytes = data.dtype.itemsize * int(np.prod(data.shape[1:], dtype=np.int64))
        rows = int(min(data.shape[0], max(1, _CHUNK_BYTES // max(row_bytes, 1))))
        return {"dtype": data.dtype, "zlib": True, "complevel": DEFLATE_LEVEL, "shuffle": True,
                "fletcher32": False, "chunksizes": (rows,) + tuple(data.shape[1:]), "_FillValue": None}
    if data.dtype.kind in "UO":
        return {}
    return {"dtype": data.dtype, "zlib": False, "shuffle": False, "fletcher32": False, "chunksizes": None,
            "_FillValue": None}


def _now() -> str:
    """ACDD date_created: UTC, ISO 8601, to the second; ``$SOURCE_DATE_EPOCH`` (seconds since
    1970-01-01 UTC, the reproducible-builds convention) replaces the clock when set, so
    two runs write byte-identical files."""
    when = source_date_epoch() or _dt.datetime.now(_dt.timezone.utc)
    return when.strftime("%Y-%m-%dT%H:%M:%SZ")


def plan_trial(tree: xr.DataTree | TrialArrays) -> tuple[dict[str, Any], dict[str, GroupPlan]]:
    """Validate a trial and return exactly what will be stored: (root attributes, groups)."""
    if isinstance(tree, TrialArrays):
        children, root_vars, given = set(tree.groups), (), tree.attrs
    elif isinstance(tree, xr.DataTree):
        children, root_vars, given = set(tree.children), tree.ds.variables, tree.attrs
    else:
        raise InputError("a trial is an xarray.DataTree (or campaign.archive.TrialArrays) with groups measured and "
                         f"truth, got {type(tree).__name__}")
    if children != set(GROUPS):
        raise InputError(f"a trial has exactly the groups {list(GROUPS)}, got {sorted(children)}")
    if root_vars:
        raise InputError(f"a trial's root group holds attributes only, got variables {sorted(root_vars)}")
    # a tree read back from a file (or prepared) carries digests: they are recomputed here
    attrs = {k: v for k, v in given.items() if k != "content_sha256"}
    scene = _scene_of(attrs)
    for key, value in attrs.items():
        _check_attr("the trial root", key, value)
    version = attrs.get("schema_version", SCHEMA_VERSION)
    if version != SCHEMA_VERSION:
        raise InputError(f"trial says schema_version {version!r}, this archive writes {SCHEMA_VERSION}")
    groups = {g: _validate_group(g, tree[g] if isinstance(tree, TrialArrays) else tree[g].to_dataset(inherit=False),
                                 scene.base) for g in GROUPS}
    created = _now()
    root = {
        "title": f"Simulated VES-II impact trial {scene.cell}",
        "summary": (
            "One trial of a simulated re-run of the impact experiments of Yoshida, Mavroidis and Dubowsky "
            f"on the MIT Vehicle Emulation System II: a {scene.p('robot')} arm on a {scene.base} base, struck "
            f"by a pendulum hammer at {scene.speed:g} m/s (configuration {scene.config}, {scene.gain} gains, "
            f"repeat {scene.repeat}). Group /measured holds what a real rig records, each channel on its own "
            "clock; group /truth holds the simulator's exact states, kept apart."),
        "keywords": ("space robotics, impact dynamics, effective mass, virtual rotor inertia, restitution "
                     "coefficient, long-reach manipulator, flexible base, VES-II, PUMA 560, simulation"),
        "id": f"campaign-trial-{scene.sha256}",
        "creator_name": "The campaign developers",
        "creator_type": "group",
        "project": ("campaign: a reproducible simulated re-run of Yoshida, Mavroidis and Dubowsky, "
                    "Impact Dynamics of Space Long Reach Manipulators"),
        "references": REFERENCES,
        "license": "BSD-3-Clause",
        "processing_level": ("simulated raw sensor channels (noisy, quantised, unprocessed) and simulator "
                             "truth, no derived quantities"),
        "source": "numerical simulation: campaign rig (simulated MIT VES-II)",
        **attrs,
        "Conventions": "CF-1.11, ACDD-1.3",
        "date_created": created,
        "history": f"{created} simulated by campaign {provenance()['campaign_version']} (trial {scene.cell})",
        "schema_version": SCHEMA_VERSION,
        **provenance(),
        "seed": int(scene.seed),
    }
    root["content_sha256"] = content_digest(root, {})
    return root, groups


def prepare_trial(tree: xr.DataTree) -> xr.DataTree:
    """Validate a trial against the schema and complete it exactly as it will be stored.

    Parameters
    ----------
    tree : xarray.DataTree
        The rig's trial: children ``measured`` and ``truth`` following
        :mod:`campaign.scene.schema`, root attributes ``scene_json``, ``scene_sha256``, ``seed``,
        ``base``, ``config``, ``gain``, ``speed``, ``repeat``, ``robot``.

    Returns
    -------
    xarray.DataTree
        A new tree: ``units``/``long_name`` filled from the schema where the rig left them
        out, ACDD-1.3 and provenance global attributes added, and each variable's
        ``encoding`` set to what the file stores (what :func:`open_trial_tree` reads back).

    Raises
    ------
    InputError
        A group, variable, dimension, coordinate or attribute that breaks the schema or the
        attribute rules (str, numbers or arrays only), named in the message.
    """
    root, groups = plan_trial(tree)
    nodes: dict[str, xr.Dataset] = {"/": xr.Dataset(attrs=root)}
    for name, group in groups.items():
        made = {}
        for v in group.variables:
            var = xr.Variable(v.dims, v.data, v.attrs)
            var.encoding = dict(v.encoding)
            made[v.name] = var
        coords = {k: made.pop(k) for k in list(made) if made[k].dims == (k,)}
        nodes[f"/{name}"] = xr.Dataset(made, coords=coords, attrs=group.attrs)
    return xr.DataTree.from_dict(nodes)
