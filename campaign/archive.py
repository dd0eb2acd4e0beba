"""The campaign's data archive: self-describing trial files, campaign folders, verification.

One trial is one NetCDF4/HDF5 file (design brief section 6)::

    /                 ACDD-1.3 global attributes, schema version, scene JSON + sha256,
                      provenance (package version, git commit, library versions), seed
    /measured         what a real VES-II records (campaign.schema.MEASURED), one time
                      dimension per sampling clock
    /truth            what only the simulator knows (campaign.schema.TRUTH)

Every variable carries CF ``units`` and ``long_name``; every time coordinate is float64
seconds from the start of the recording (``units = "s"``, no ``standard_name``: CF keeps
``time`` for coordinates with a ``since`` epoch, and a simulated trial has none). Time
series are chunked along time and compressed losslessly (deflate + shuffle, the filters
every netCDF-4 reader has). Anyone opens a trial
with plain xarray, no project import needed::

    xr.open_dataset(path, engine="h5netcdf", group="measured")

**Writer.** Files are written with h5py in exactly the layout xarray's h5netcdf engine
writes (HDF5 dimension scales, ``_Netcdf4Dimid``, creation order tracked). Writing through
xarray/h5netcdf costs about 5 ms of Python per variable, i.e. 250-330 ms for a trial's 36
(fixed base) to 51 (flexible base) variables, six times the archive's 50 ms budget; h5py
writes the same file in 25-35 ms (``benchmarks/bench_archive.py``, ``benchmarks/README.md``).
The test suite checks that xarray decodes our files identically to files xarray writes itself
(values, dtypes, attributes, encodings).

**Reader.** For the same reason files are read with h5py, once: the integrity check reads
every array anyway, and :func:`open_trial` hands those arrays to xarray's own CF decoding
(through an in-memory data store) instead of reopening the file with the h5netcdf engine,
which took 5-8 times as long. The result is identical to ``xr.open_dataset(path,
engine="h5netcdf", group=...)``; the section "reading" below lists what of the h5netcdf layer
is reproduced and why, and the tests compare both readers on rig trials.

**Without xarray.** Importing xarray (with pandas) costs each Snakemake job ~0.6 s, more than
a job's trials take to simulate or identify. So the rig can hand :func:`write_trial` a trial
as plain arrays (:class:`campaign.schema.TrialArrays`; the same file, byte for byte) and
:func:`open_trial_arrays` reads a group into plain arrays with :func:`open_trial`'s values
(:class:`campaign.schema.GroupArrays`): the campaign's simulation and identification jobs
never import xarray. Users open trials with xarray as above.

**Integrity.** Each group stores ``content_sha256``: a digest of its attributes and of every
variable's bytes and attributes (:func:`_digest`). Readers recompute it, so a flipped byte
anywhere in the content is reported even for a file outside any campaign. A campaign
folder's ``MANIFEST.sha256`` (``sha256sum`` format) checks whole files; HDF5 bytes are not
reproducible run to run (``date_created``), so reproducibility is checked on decoded arrays
with ``xarray.testing`` instead (or on the groups' digests, which do not depend on the date).
A few corruptions make the HDF5 library crash rather than raise; :func:`verify` and
:func:`finalize_campaign` check each file in a child process so that they report it.

**Safe I/O.** Writes go to a temporary file in the target folder, then ``os.replace``: a
killed writer never leaves a file under the final name. Reads open, load and close.

Campaign folder (``archive/<name>/``)::

    <base>/config<N>/<gain>/v<speed>/r<NN>.nc     one file per trial (Scene.cell)
    index.csv                                      one row per trial with its scene parameters
    README.md                                      every variable, unit and clock (generated)
    MANIFEST.sha256                                sha256 of every other file
"""

from __future__ import annotations

import csv
import dataclasses
import datetime as _dt
import functools
import hashlib
import io
import json
import math
import os
import re
import secrets
import subprocess
import warnings
from importlib.metadata import PackageNotFoundError, version as _dist_version
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import h5py
import numpy as np
from h5py import h5a, h5d, h5ds, h5i, h5o, h5p, h5r, h5s, h5t

from . import __version__
from ._lazy import LazyModule
from .errors import InputError, TrialFileError
from .filing import filing_problems
from .progress import progress
from .scene import BASES, GAINS, Scene
from .schema import (CLOCKS, COORDS, MEASURED, SCHEMA_VERSION, TRUTH, ChannelArray, GroupArrays, TrialArrays,
                     variables)


#: xarray, imported on first use (:mod:`campaign._lazy`): jobs that only check or index
#: trial files (``finalize_archive``, ``verify``) never need it
xr: Any = LazyModule("xarray")

__all__ = [
    "GROUPS", "MANIFEST", "INDEX", "README", "TRIAL_SUFFIX", "CELL_KEYS", "INDEX_COLUMNS", "FILTER_KEYS",
    "REFERENCES",
    "TrialRecord", "Problem", "ChannelArray", "GroupArrays", "TrialArrays",
    "provenance", "prepare_trial", "write_trial", "open_trial", "open_trial_arrays", "open_trial_tree", "trial_path",
    "list_trials", "open_campaign", "to_cell_dataset",
    "write_manifest", "write_index", "write_readme", "finalize_campaign", "verify",
]

GROUPS = ("measured", "truth")
TRIAL_SUFFIX = ".nc"
MANIFEST = "MANIFEST.sha256"
INDEX = "index.csv"
README = "README.md"

#: the campaign cell: the dimensions of :func:`open_campaign` and :func:`to_cell_dataset`
CELL_KEYS = ("base", "config", "gain", "speed", "repeat")
#: columns of index.csv, in order
INDEX_COLUMNS = ("path", "base", "config", "gain", "speed", "repeat", "seed", "scene", "scene_sha256",
                 "robot", "schema_version")
#: keys accepted by :func:`list_trials` filters, with the type a value is read as
FILTER_KEYS = {"base": str, "config": int, "gain": str, "speed": float, "repeat": int, "seed": int,
               "scene": str, "scene_sha256": str, "robot": str}

REFERENCES = ("Yoshida, K., Mavroidis, C. and Dubowsky, S., \"Impact Dynamics of Space Long Reach "
              "Manipulators\", Proc. 1996 IEEE International Conference on Robotics and Automation, "
              "Minneapolis, MN, pp. 1909-1916")

# Chosen with benchmarks/bench_archive.py: deflate level 1 + shuffle compresses float channels
# as well as level 4 or 9 (the noise bits dominate) at the lowest cost; one chunk holds up to
# 256 KiB, so a trial's channels are one chunk each and long recordings still split along time.
_DEFLATE_LEVEL = 1
_CHUNK_BYTES = 1 << 18

_SCHEMA_MAJOR = int(SCHEMA_VERSION.split(".")[0])
_ROOT_REQUIRED = ("scene_json", "scene_sha256", "seed", "base", "config", "gain", "speed", "repeat", "robot")
# attributes HDF5/netCDF-4 bookkeeping owns: not content, excluded from content_sha256
_STRUCTURAL = frozenset({"CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "_Netcdf4Dimid",
                         "_Netcdf4Coordinates", "_NCProperties", "content_sha256"})
_GROUP_COMMENT = {
    "measured": "channels a real VES-II records (noisy, quantised, each on its own clock) and the instrument "
                "constants an experimenter knows; identification reads only this group",
    "truth": "simulator truth (exact states, contact force and interval); kept apart from the measured "
             "channels, identification never reads it",
}
_LABEL_LONG_NAMES = {"joint": "active joint name", "axis": "Cartesian axis, base frame",
                     "axis2": "Cartesian axis, base frame (second index of a tensor)"}
_TEMP_RE = re.compile(r"^\..+\.tmp$")


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


def _dist(name: str) -> str:
    try:
        return _dist_version(name)
    except PackageNotFoundError:
        return "not installed"


@functools.cache
def _provenance() -> tuple[tuple[str, str], ...]:
    return (
        ("campaign_version", __version__),
        ("git_commit", _git_commit()),
        ("numpy_version", _dist("numpy")),
        ("scipy_version", _dist("scipy")),
        ("pinocchio_version", _dist("pin")),
        ("xarray_version", _dist("xarray")),
        ("h5py_version", _dist("h5py")),
        ("h5netcdf_version", _dist("h5netcdf")),
        ("hdf5_version", h5py.version.hdf5_version),
    )


def provenance() -> dict[str, str]:
    """Package version, git commit and library versions stored in every trial (computed once).

    Returns
    -------
    dict of str to str
        ``campaign_version``, ``git_commit`` (``"unknown"`` outside a git checkout, suffixed
        ``-dirty`` when tracked files are modified), and ``numpy_version``, ``scipy_version``,
        ``pinocchio_version``, ``xarray_version``, ``h5py_version``, ``h5netcdf_version``,
        ``hdf5_version``.
    """
    return dict(_provenance())


# ---------------------------------------------------------------------------------------
# content digest (shared by the writer and every reader)
# ---------------------------------------------------------------------------------------
def _canon(value: Any) -> bytes:
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


def _digest(attrs: Mapping[str, Any], variables_: Mapping[str, tuple[Any, Mapping[str, Any]]]) -> str:
    """sha256 of one group's content: its attributes and each variable's data and attributes."""
    h = hashlib.sha256()

    def feed_attrs(a: Mapping[str, Any]) -> None:
        for key in sorted(k for k in a if k not in _STRUCTURAL):
            value = a[key]
            # netCDF attributes are 1-d: a number may come back as a scalar or a 1-element array
            if not isinstance(value, (str, bytes)):
                value = np.ravel(value)
            for part in (key.encode(), _canon(value)):
                h.update(len(part).to_bytes(8, "little"))
                h.update(part)

    feed_attrs(attrs)
    for name in sorted(variables_):
        data, vattrs = variables_[name]
        for part in (b"\x00var", name.encode(), _canon(data)):
            h.update(len(part).to_bytes(8, "little"))
            h.update(part)
        feed_attrs(vattrs)
    return h.hexdigest()


# ---------------------------------------------------------------------------------------
# checking and completing a trial before it is written
# ---------------------------------------------------------------------------------------
def _check_attr(where: str, key: str, value: Any) -> None:
    """Attributes must be str, numbers or numeric/str arrays: what every netCDF reader keeps."""
    if key in _STRUCTURAL or key.startswith("_"):
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
class _Var:
    """One variable as it will be stored (plain numpy + dicts: cheaper than xarray objects)."""

    name: str
    dims: tuple[str, ...]
    data: np.ndarray
    attrs: dict[str, Any]
    encoding: dict[str, Any]


@dataclasses.dataclass
class _Group:
    attrs: dict[str, Any]
    variables: list[_Var]  # dimension coordinates first, then the schema's variables in schema order


#: ACDD coverage_content_type of a group's time series; constants of the rig (no clock)
#: are "referenceInformation", coordinates "coordinate"
_COVERAGE = {"measured": "physicalMeasurement", "truth": "modelResult"}


def _validate_group(group: str, ds: xr.Dataset | GroupArrays, base: str) -> _Group:
    """Check one group against the schema; fill units/long_name the rig left out."""
    expected = {v.name: v for v in variables(group, base)}
    names = set(ds.data_vars)
    missing = [n for n in expected if n not in names]
    if missing:
        raise InputError(f"trial group /{group} ({base} base) is missing {', '.join(missing)} "
                         f"(schema {SCHEMA_VERSION}, campaign/schema.py)")
    unknown = sorted(names - set(expected))
    if unknown:
        raise InputError(f"trial group /{group} ({base} base) has variables not in schema {SCHEMA_VERSION}: "
                         f"{', '.join(unknown)}; add them to campaign/schema.py with a version bump")
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
        out.append(_Var(name, var.dims, data, attrs, _encoding(var.dims, data)))
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
            attrs.setdefault("long_name", _LABEL_LONG_NAMES[dim])
        else:
            raise InputError(f"/{group} has dimension {dim!r}, which is neither a schema clock nor a label dimension")
        attrs.setdefault("coverage_content_type", "coordinate")
        for key, value in attrs.items():
            _check_attr(f"/{group}/{dim}", key, value)
        coords.append(_Var(dim, (dim,), values, attrs, _encoding((dim,), values)))
    extra = sorted(set(ds.coords) - set(ds.dims))
    if extra:
        raise InputError(f"/{group} has non-dimension coordinates {extra}; the schema has none")
    given = {k: v for k, v in ds.attrs.items() if k != "content_sha256"}
    for key, value in given.items():
        _check_attr(f"/{group}", key, value)
    attrs = {"comment": _GROUP_COMMENT[group], **given, "schema_version": SCHEMA_VERSION}
    variables_ = coords + out
    attrs["content_sha256"] = _digest(attrs, {v.name: (v.data, v.attrs) for v in variables_})
    return _Group(attrs, variables_)


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


def _encoding(dims: tuple[str, ...], data: np.ndarray) -> dict[str, Any]:
    """Storage of one variable (xarray encoding keys): time series chunked along time and
    deflated, constants and labels contiguous."""
    if data.ndim and dims[0] in CLOCKS:
        row_bytes = data.dtype.itemsize * int(np.prod(data.shape[1:], dtype=np.int64))
        rows = int(min(data.shape[0], max(1, _CHUNK_BYTES // max(row_bytes, 1))))
        return {"dtype": data.dtype, "zlib": True, "complevel": _DEFLATE_LEVEL, "shuffle": True,
                "fletcher32": False, "chunksizes": (rows,) + tuple(data.shape[1:]), "_FillValue": None}
    if data.dtype.kind in "UO":
        return {}
    return {"dtype": data.dtype, "zlib": False, "shuffle": False, "fletcher32": False, "chunksizes": None,
            "_FillValue": None}


def _now() -> str:
    """ACDD date_created: UTC, ISO 8601, to the second; ``$SOURCE_DATE_EPOCH`` (seconds since
    1970-01-01 UTC, the reproducible-builds convention) replaces the clock when set, so
    two runs write byte-identical files."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    if epoch:
        try:
            when = _dt.datetime.fromtimestamp(int(epoch), _dt.timezone.utc)
        except (ValueError, OverflowError, OSError):
            raise InputError(f"SOURCE_DATE_EPOCH = {epoch!r} is not a whole number of seconds since 1970-01-01 UTC") \
                from None
    else:
        when = _dt.datetime.now(_dt.timezone.utc)
    return when.strftime("%Y-%m-%dT%H:%M:%SZ")


def _plan(tree: xr.DataTree | TrialArrays) -> tuple[dict[str, Any], dict[str, _Group]]:
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
    root["content_sha256"] = _digest(root, {})
    return root, groups


def prepare_trial(tree: xr.DataTree) -> xr.DataTree:
    """Validate a trial against the schema and complete it exactly as it will be stored.

    Parameters
    ----------
    tree : xarray.DataTree
        The rig's trial: children ``measured`` and ``truth`` following
        :mod:`campaign.schema`, root attributes ``scene_json``, ``scene_sha256``, ``seed``,
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
    root, groups = _plan(tree)
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


# ---------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------
# The writer uses h5py's low-level API: the high-level one costs about 0.1 ms of Python per
# attribute or dataset, a third of the write budget for a trial's ~50 variables and ~150
# attributes. What it creates is what h5py's high-level API (and so h5netcdf) creates:
# variable-length UTF-8 string attributes, scalar dataspaces for scalars, no timestamps,
# shuffle then deflate on chunked variables.
_VLEN_STR = h5py.string_dtype()
_VLEN_STR_TYPE = h5t.py_create(_VLEN_STR, logical=True)


def _lcpl() -> h5p.PropLCID:
    lcpl = h5p.create(h5p.LINK_CREATE)
    lcpl.set_char_encoding(h5t.CSET_UTF8)
    return lcpl


def _space(shape: tuple[int, ...]) -> h5s.SpaceID:
    return h5s.create(h5s.SCALAR) if shape == () else h5s.create_simple(shape)


def _put_attr(oid: Any, key: str, value: Any) -> None:
    """One attribute, as ``obj.attrs[key] = value`` would store it."""
    if isinstance(value, str) or (isinstance(value, np.ndarray) and value.dtype.kind in "UO"):
        data = np.array(value if isinstance(value, str) else value.tolist(), dtype=_VLEN_STR)
        tid = _VLEN_STR_TYPE
    else:
        data = np.asarray(value)
        tid = h5t.py_create(data.dtype)
    attr = h5a.create(oid, key.encode(), tid, _space(data.shape))
    attr.write(data)


def _create_dataset(gid: Any, name: str, data: np.ndarray, *, chunks: tuple[int, ...] | None = None,
                    level: int = 0, shuffle: bool = False, fletcher32: bool = False) -> Any:
    """One dataset, as ``group.create_dataset(name, data=..., chunks=..., compression="gzip", ...)``."""
    dcpl = h5p.create(h5p.DATASET_CREATE)
    dcpl.set_obj_track_times(False)  # h5py's default: no timestamps in the file
    if data.dtype.kind in "UO":
        data = np.array(data.tolist(), dtype=_VLEN_STR)
        tid = _VLEN_STR_TYPE
    else:
        tid = h5t.py_create(data.dtype, logical=True)
    if chunks is not None:
        dcpl.set_chunk(chunks)
        if shuffle:
            dcpl.set_shuffle()
        if level:
            dcpl.set_deflate(level)
        if fletcher32:
            dcpl.set_fletcher32()
    dsid = h5d.create(gid, name.encode(), tid, _space(data.shape), dcpl=dcpl, lcpl=_lcpl())
    if data.size:
        dsid.write(h5s.ALL, h5s.ALL, data)
    return dsid


def _write_group(gid: Any, group: _Group, next_dimid: Iterator[int], *, level: int, fletcher32: bool) -> None:
    """Write one planned group in the netCDF-4 layout h5netcdf produces (dimension scales first).

    The arrays written are the ones :func:`_plan` digested, so the stored ``content_sha256``
    holds for the file.
    """
    scales = {}
    for var in group.variables:
        if var.encoding.get("zlib"):
            dsid = _create_dataset(gid, var.name, var.data, chunks=tuple(var.encoding["chunksizes"]), level=level,
                                   shuffle=bool(var.encoding.get("shuffle")), fletcher32=fletcher32)
        else:
            dsid = _create_dataset(gid, var.name, var.data)
        if var.dims == (var.name,):
            h5ds.set_scale(dsid, var.name.encode())
            _put_attr(dsid, "_Netcdf4Dimid", np.int32(next(next_dimid)))
            scales[var.name] = dsid
        else:
            for i, dim in enumerate(var.dims):
                h5ds.attach_scale(dsid, scales[dim], i)
        for key, value in var.attrs.items():
            _put_attr(dsid, key, value)
    for key, value in group.attrs.items():
        _put_attr(gid, key, value)


def _write_h5(plan: tuple[dict[str, Any], dict[str, _Group]], path: Path, *, level: int = _DEFLATE_LEVEL,
              fletcher32: bool = False) -> None:
    """Write a planned trial to ``path`` (no atomicity here; see :func:`write_trial`)."""
    root, groups = plan
    # track_order: netCDF-4 files keep creation order, and readers list variables in it
    with h5py.File(path, "w", track_order=True) as f:
        f.attrs["_NCProperties"] = np.bytes_(
            f"version=2,campaign={__version__},hdf5={h5py.version.hdf5_version},h5py={h5py.__version__}".encode())
        for key, value in root.items():
            _put_attr(f.id, key, value)
        dimids = iter(range(1 << 30))
        for name in GROUPS:
            _write_group(f.create_group(name, track_order=True).id, groups[name], dimids, level=level,
                         fletcher32=fletcher32)


def _temp_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")


def _replace_atomically(path: Path, write: Callable[[Path], None], *, fsync: bool = False) -> Path:
    """Run ``write(tmp)`` on a temp file beside ``path``, then rename it over ``path``.

    Stale temp files of ``path`` (left by a killed writer) are removed first: there is one
    writer per file, so any such file is an abandoned attempt.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    for stale in path.parent.glob(f".{_glob_escape(path.name)}.*.tmp"):
        stale.unlink(missing_ok=True)
    tmp = _temp_name(path)
    try:
        write(tmp)
        if fsync:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def _glob_escape(name: str) -> str:
    """``name`` with glob metacharacters escaped (``[``, ``*``, ``?``)."""
    return re.sub(r"([\[\]*?])", r"[\1]", name)


def write_trial(tree: xr.DataTree | TrialArrays, path: str | os.PathLike, *, fsync: bool = True) -> Path:
    """Validate a trial and write it atomically as one NetCDF4/HDF5 file.

    Parameters
    ----------
    tree : xarray.DataTree or TrialArrays
        The trial as the rig returns it (see :func:`prepare_trial`), or the same as plain
        arrays (``campaign.rig.simulate_arrays``): the file is the same.
    path : path-like
        Final file name; its folder is created. Usually ``trial_path(campaign_dir, scene)``.
    fsync : bool
        Flush the file to disk before the rename (default). The rename alone is atomic
        against a killed process; the flush also keeps a power loss from leaving an empty
        file under the final name. It costs about 1 ms per trial on a local disk.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    InputError
        The trial breaks the schema (nothing is written).

    Notes
    -----
    One writer per file: a rerun removes temporary files an earlier, killed writer of the
    same ``path`` left behind. Rewriting a trial of a finalized campaign makes its manifest
    stale until ``finalize_campaign`` runs again (``verify`` reports the mismatch).
    """
    plan = _plan(tree)
    return _replace_atomically(Path(path), lambda tmp: _write_h5(plan, tmp), fsync=fsync)


def trial_path(campaign_dir: str | os.PathLike, scene: Scene) -> Path:
    """Where a scene's trial lives in a campaign folder: ``<campaign_dir>/<scene.cell>.nc``."""
    if not isinstance(scene, Scene):
        raise InputError(f"trial_path needs a Scene, got {type(scene).__name__}")
    return Path(campaign_dir) / f"{scene.cell}{TRIAL_SUFFIX}"


# ---------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------
# _CORRUPT: a corrupt HDF5 file can make h5py/h5netcdf raise nearly any exception type (OSError,
# KeyError, TypeError for an attribute name that is no longer UTF-8, ...). Readers of a trial
# file therefore turn every Exception into a problem or TrialFileError naming the file.
#
# One read per file. The integrity check (:func:`_read_trial`) reads every variable of a group
# with h5py to recompute its content_sha256, and :func:`open_trial` / :func:`open_trial_tree`
# build their Datasets from exactly those arrays, instead of opening the file a second time
# with xarray's h5netcdf engine (about 5 ms of Python per variable: 0.15-0.35 s per trial).
# The decoding itself stays xarray's: the arrays and attributes are handed to xarray as a data
# store (:class:`_GroupStore`, xarray's documented backend API) and opened with
# ``xr.open_dataset(store, engine="store")``, which runs the same CF decoding
# (``conventions.decode_cf_variables``: _FillValue/scale_factor masking, CF times and
# timedeltas, string decoding, coordinates) and the same default-index creation as
# ``xr.open_dataset(path, engine="h5netcdf")``. What is reproduced here is only the layer below,
# what the h5netcdf engine (h5netcdf + xarray's H5NetCDFStore) makes of the HDF5 objects:
#
# - dimension names: a dimension scale names its own dimension; any other variable takes the
#   names of the scales its DIMENSION_LIST references (the last scale per axis), as h5netcdf
#   does (:func:`_dims_of`); a scale whose NAME says "not a netCDF variable" is a dimension only;
# - attributes (:func:`_xr_attr`): the netCDF-4/HDF5 bookkeeping attributes h5netcdf hides
#   (:data:`_NC_HIDDEN`) left out, 1-element arrays returned as their element, string arrays as
#   lists, fixed-length strings decoded (h5netcdf), then bytes decoded to str except
#   ``_FillValue``/``missing_value`` (xarray);
# - variable-length string data decoded to str (h5netcdf's decode_vlen_strings, which xarray
#   turns on), with the dataset's h5py dtype presented as the array's dtype;
# - encodings: per variable ``dtype`` (``str`` for vlen strings), ``contiguous``,
#   ``chunksizes``, ``preferred_chunks``, the filter flags and ``complevel``, ``source``,
#   ``original_shape``; per Dataset ``unlimited_dims`` and ``source`` (xarray's api sets it).
#
# What this layer does not reproduce it reports as a problem of the file (so ``verify`` reports
# it as well), none of which a trial file written by this archive or by xarray has: a variable
# without a dimension scale on every axis (xarray needs ``phony_dims`` for it), a variable whose
# length disagrees with its dimension's (h5netcdf would pad it), a multi-dimensional scale, and
# data types other than numbers and strings. tests/test_archive.py checks the result against
# ``xr.open_dataset``/``xr.open_datatree`` (``assert_identical`` and equal encodings) on rig
# trials of both bases and on a file xarray writes itself.

#: attributes h5netcdf hides from its attribute mappings (h5netcdf.attrs._HIDDEN_ATTRS)
_NC_HIDDEN = frozenset({"REFERENCE_LIST", "CLASS", "DIMENSION_LIST", "NAME", "_Netcdf4Dimid", "_Netcdf4Coordinates",
                        "_nc3_strict", "_NCProperties"})
# read for neither the digest nor xarray (content_sha256 is read: xarray shows it)
_NOT_READ = _STRUCTURAL - {"content_sha256"}
_NC_DIM_ONLY = b"This is a netCDF dimension but not a netCDF variable"
# HDF5 filters h5netcdf reports as compression flags (h5netcdf.core.Variable.filters)
_H5_FILTER_TO_COMPRESSION = {"1": "zlib", "2": "szip", "307": "bzip2", "32004": "blosc", "32015": "zstd",
                             "zlib": "zlib", "szip": "szip", "bzip2": "bzip2", "blosc": "blosc", "zstd": "zstd"}


@dataclasses.dataclass
class _StoredVar:
    """One HDF5 dataset of a group as the check read it: what the digest covers and what the
    Dataset is built from (no second read)."""

    name: str
    data: Any                 # as h5py reads it (variable-length strings as bytes)
    attrs: dict[str, Any]     # h5py values in file order, bookkeeping attributes left out
    dims: tuple[str, ...]
    dset: Any                 # the h5py Dataset while the file is open (storage properties)
    is_variable: bool         # False for a netCDF dimension without a coordinate variable
    dtype: np.dtype           # the dataset's h5py dtype
    string_types: dict[str, np.dtype]  # HDF5 types of the fixed-length string attributes
    encoding: dict[str, Any] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class _StoredGroup:
    attrs: dict[str, Any]
    string_types: dict[str, np.dtype]
    variables: list[_StoredVar]
    unlimited: set[str]


@dataclasses.dataclass
class _Read:
    root: dict[str, Any]      # root attributes, h5py values (content_sha256 included)
    problems: list[str]
    values: dict[str, Any]    # "group/name" -> data, for the variables asked for
    groups: dict[str, _StoredGroup]
    root_string_types: dict[str, np.dtype] = dataclasses.field(default_factory=dict)


def _read_attrs(obj: h5py.HLObject) -> dict[str, Any]:
    """An HDF5 object's attributes in file order (h5py values), HDF5/netCDF-4 bookkeeping left out."""
    attrs = obj.attrs
    return {k: attrs[k] for k in attrs.keys() if k not in _NOT_READ}


def _string_types(obj: h5py.HLObject, attrs: Mapping[str, Any]) -> dict[str, np.dtype]:
    """HDF5 types of an object's fixed-length string attributes (their character set and length
    decide how h5netcdf decodes them); h5py's value does not carry them."""
    return {k: obj.attrs.get_id(k).dtype for k, v in attrs.items()
            if getattr(v, "dtype", None) is not None and v.dtype.kind == "S"}


def _parse_version(value: Any) -> tuple[int, int] | None:
    m = re.fullmatch(r"(\d+)\.(\d+)", str(value))
    return (int(m.group(1)), int(m.group(2))) if m else None


def _dims_of(f: h5py.File, dset: h5py.Dataset, scales: dict[Any, tuple[str, int]]) -> tuple[str, ...]:
    """Dimension names of a non-scale dataset, as h5netcdf looks them up: per axis, the name of
    the last dimension scale its DIMENSION_LIST references.

    ``scales`` maps the object ids of known scales to (name, length) and is filled as a cache
    (h5py's ``.name`` costs about 0.1 ms an object). Raises ValueError for a dataset xarray
    cannot read without phony dims, or one whose length disagrees with its dimension's.
    """
    if dset.ndim == 0:
        return ()
    refs = dset.attrs.get("DIMENSION_LIST")
    if refs is None or len(refs) != dset.ndim or any(len(r) == 0 for r in refs):
        raise ValueError("has no dimension scale on every axis (not a netCDF-4 variable)")
    dims = []
    for axis, axis_refs in enumerate(refs):
        oid = h5r.dereference(axis_refs[-1], f.id)
        if oid not in scales:
            scales[oid] = (h5i.get_name(oid).decode().rsplit("/", 1)[-1], oid.shape[0] if len(oid.shape) == 1 else -1)
        dim, length = scales[oid]
        if length != dset.shape[axis]:
            raise ValueError(f"has length {dset.shape[axis]} along dimension {dim!r} of length {length}")
        dims.append(dim)
    return tuple(dims)


def _storage_encoding(dset: h5py.Dataset, dims: tuple[str, ...]) -> dict[str, Any]:
    """A variable's encoding as xarray's H5NetCDFStore.open_store_variable reports it (minus source)."""
    dtype = dset.dtype
    enc: dict[str, Any] = {"dtype": str if h5py.check_dtype(vlen=dtype) is str else dtype}
    chunks = dset.chunks if dset.shape != () else None
    if chunks:
        enc.update(contiguous=False, chunksizes=chunks, preferred_chunks=dict(zip(dims, chunks, strict=True)))
    else:
        enc.update(contiguous=True, chunksizes=None)
    # h5netcdf Variable.filters()
    compression = dset.compression
    enc.update(zlib=False, szip=False, bzip2=False, blosc=False, zstd=False, shuffle=dset.shuffle,
               fletcher32=dset.fletcher32)
    if compression == "gzip":
        enc["zlib"] = True
        enc["complevel"] = dset.compression_opts
    for filter_id, opts in dset._filters.items():  # the attribute h5netcdf reads too
        name = _H5_FILTER_TO_COMPRESSION.get(filter_id)
        if name is not None:
            enc[name] = True
            if opts and len(opts) > 0:
                enc["complevel"] = opts[0]
    # H5NetCDFStore: gzip as above; other h5py compression kept as h5py names it
    if compression == "gzip":
        enc["complevel"] = dset.compression_opts
    elif compression is not None:
        enc["compression"] = compression
        enc["compression_opts"] = dset.compression_opts
    return enc


def _read_group(f: h5py.File, group: str, base: str, problems: list[str], want: Sequence[str]
                ) -> tuple[_StoredGroup, dict[str, Any]]:
    """Read and check one group: every channel present, dims, readable data; digest checked by the caller."""
    grp = f[group]
    names = list(grp.keys())
    present = set(names)
    for spec in variables(group, base):
        if spec.name not in present:
            problems.append(f"channel {group}/{spec.name} is missing")
    schema_dims = {spec.name: spec.dims for spec in variables(group, base)}
    scales: dict[Any, tuple[str, int]] = {}
    stored: list[_StoredVar] = []
    unlimited: set[str] = set()
    values: dict[str, Any] = {}
    for name in names:
        oid = h5o.open(grp.id, name.encode())  # what grp[name] does, at half the cost
        if not isinstance(oid, h5d.DatasetID):
            problems.append(f"{group}/{name} is not a variable")
            continue
        dset = h5py.Dataset(oid)
        try:
            data = dset[()]
            vattrs = _read_attrs(dset)
        except Exception as exc:  # noqa: BLE001 - see _CORRUPT
            problems.append(f"{group}/{name}: cannot read data (corrupt): {exc}")
            continue
        is_variable = True
        dtype = dset.dtype
        dims: tuple[str, ...] | None = None  # None: unreadable (reported); still digested
        try:
            info = h5py.check_string_dtype(dtype)
            if dtype.kind not in "iufS" and not (info is not None and info.length is None):
                raise ValueError(f"has HDF5 type {dtype}, neither numbers nor strings")
            if h5ds.is_scale(dset.id):
                if dset.ndim != 1:
                    raise ValueError(f"is a {dset.ndim}-d dimension scale")
                dims = (name,)
                scales[dset.id] = (name, dset.shape[0])
                if dset.maxshape == (None,):
                    unlimited.add(name)
                is_variable = _NC_DIM_ONLY not in (h5ds.get_scale_name(dset.id) or b"")
            else:
                dims = _dims_of(f, dset, scales)
        except ValueError as exc:  # a layout this reader (and xarray without phony_dims) does not take
            problems.append(f"{group}/{name} {exc}")
        except Exception as exc:  # noqa: BLE001 - see _CORRUPT
            problems.append(f"{group}/{name}: cannot read its dimensions (corrupt): {exc}")
        if dims is not None and name in schema_dims and dims != schema_dims[name]:
            problems.append(f"{group}/{name} has dims {dims}, schema says {schema_dims[name]}")
        if name not in CLOCKS and name not in COORDS:
            for key in ("units", "long_name"):
                if key not in vattrs:
                    problems.append(f"{group}/{name} has no {key} attribute")
        stored.append(_StoredVar(name, data, vattrs, dims, dset, is_variable, dtype, _string_types(dset, vattrs)))
        if name in want:
            values[f"{group}/{name}"] = data
    gattrs = _read_attrs(grp)
    return _StoredGroup(gattrs, _string_types(grp, gattrs), stored, unlimited), values


def _read_trial(path: Path, *, groups: Sequence[str] = GROUPS, want: Mapping[str, Sequence[str]] | None = None,
                encodings: bool = False) -> _Read:
    """Read and check a trial file with h5py: readable, schema version, every channel, dims,
    content digests. Never raises for a bad file: each problem is a message.

    With ``encodings``, each variable's storage encoding is read as well (what the Datasets
    of :func:`open_trial` report), while the file is open.
    """
    out = _Read({}, [], {}, {})
    problems = out.problems
    if not path.is_file():
        problems.append("file does not exist")
        return out
    try:
        f = h5py.File(path, "r")
    except Exception as exc:  # noqa: BLE001 - see _CORRUPT
        problems.append(f"not a readable HDF5 file (truncated or corrupt): {exc}")
        return out
    try:
        with f:
            root = out.root = _read_attrs(f)
            out.root_string_types = _string_types(f, root)
            version = _parse_version(root.get("schema_version"))
            if version is None:
                problems.append(f"no valid schema_version attribute ({root.get('schema_version')!r}): "
                                "not a campaign trial file")
                return out
            if version[0] > _SCHEMA_MAJOR:
                problems.append(f"schema version {version[0]}.{version[1]} is newer than this campaign reads "
                                f"({SCHEMA_VERSION}); upgrade the campaign package")
                return out
            if version[0] < _SCHEMA_MAJOR:
                problems.append(f"schema version {version[0]}.{version[1]} is older than this campaign reads "
                                f"({SCHEMA_VERSION}) and there is no converter")
                return out
            base = root.get("base")
            if base not in BASES:
                problems.append(f"root attribute base is {base!r}, expected one of {list(BASES)}")
                return out
            stored = root.get("content_sha256")
            if stored is None:
                problems.append("root group has no content_sha256")
            elif stored != _digest(root, {}):
                problems.append("root attributes do not match their content_sha256 (altered or corrupt)")
            if set(groups) == set(GROUPS):  # the whole file: nothing beside the groups
                extra = sorted(set(f.keys()) - set(GROUPS))
                if extra:
                    problems.append(f"the root group holds {', '.join(extra)}; a trial file holds only the "
                                    f"groups {', '.join(GROUPS)}")
            for group in groups:
                if group not in f:
                    problems.append(f"group /{group} is missing")
                    continue
                read, values = _read_group(f, group, base, problems, (want or {}).get(group, ()))
                out.values.update(values)
                contents = {v.name: (v.data, v.attrs) for v in read.variables}
                stored = read.attrs.get("content_sha256")
                if stored is None:
                    problems.append(f"group /{group} has no content_sha256")
                elif stored != _digest(read.attrs, contents):
                    problems.append(f"group /{group} does not match its content_sha256 (altered or corrupt)")
                if encodings and not problems:
                    for var in read.variables:
                        var.encoding = _storage_encoding(var.dset, var.dims)
                for var in read.variables:
                    var.dset = None  # closed with the file
                out.groups[group] = read
    except Exception as exc:  # noqa: BLE001 - see _CORRUPT
        problems.append(f"cannot read the file (corrupt): {exc}")
        out.root, out.groups = {}, {}
    return out


def _inspect(path: Path, *, groups: Sequence[str] = GROUPS, want: Mapping[str, Sequence[str]] | None = None
             ) -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """Check a trial file with h5py (:func:`_read_trial`).

    Returns (root attributes, problems, values of the variables asked for in ``want`` as
    ``{"group/name": value}``). Never raises for a bad file: each problem is a message.
    """
    read = _read_trial(path, groups=groups, want=want)
    return {k: v for k, v in read.root.items() if k != "content_sha256"}, read.problems, read.values


def _inspect_isolated(path: Path) -> list[str]:
    """:func:`_inspect` of one file in a forked child process; returns its problems
    (:func:`_inspect_isolated_many`)."""
    return _inspect_isolated_many([path])[0]


def _inspect_isolated_many(paths: Sequence[Path]) -> list[list[str]]:
    """:func:`_inspect` of each file, in forked child processes; returns each file's problems.

    The HDF5 library trusts a file's internal pointers: some corruptions (a flipped byte in the
    heap of variable-length strings) make it crash the process instead of raising. Commands
    that look at many possibly damaged files (:func:`verify`, :func:`finalize_campaign`)
    therefore check the files in a child, which sends one result line per file as it goes.
    A crash is reported as a problem of the file the child was reading (the one after the
    last result received) and the remaining files go on in a new child, so an intact
    campaign costs one fork, not one per trial (~50 ms each).
    """
    paths = [Path(p) for p in paths]
    if not hasattr(os, "fork"):  # pragma: no cover - Windows: no isolation
        return [_inspect(p)[1] for p in paths]
    results: list[list[str]] = []
    while len(results) < len(paths):
        todo = paths[len(results):]
        read_fd, write_fd = os.pipe()
        pid = os.fork()
        if pid == 0:  # child: check, send the problems line by line, leave without any cleanup
            code = 1
            try:
                os.close(read_fd)
                with os.fdopen(write_fd, "wb", buffering=0) as out:
                    for path in todo:
                        out.write(json.dumps(_inspect(path)[1]).encode() + b"\n")
                code = 0
            finally:
                os._exit(code)
        os.close(write_fd)
        with os.fdopen(read_fd, "rb") as fh:   # line by line, as the child checks the files
            lines = [line.rstrip(b"\n") for line in progress(fh, desc="check", total=len(todo))]
        _, status = os.waitpid(pid, 0)
        for line in lines[:len(todo)]:
            try:
                results.append(json.loads(line))
            except ValueError:
                break
        if len(results) == len(paths):
            break
        # the child stopped on the next file: report it and go on with the ones after it
        if os.WIFSIGNALED(status):
            results.append([f"reading it crashed the HDF5 library (signal {os.WTERMSIG(status)}): the file is corrupt"])
        else:
            results.append(["the checker failed on this file (corrupt?)"])
    return results


def _checked_read(path: Path, groups: Sequence[str], *, encodings: bool = True) -> _Read:
    """:func:`_read_trial` (with encodings unless told); raises TrialFileError naming the file
    on any problem."""
    read = _read_trial(path, groups=groups, encodings=encodings)
    problems = read.problems
    if problems:
        raise TrialFileError(f"{path}: {problems[0]}" + (f" (and {len(problems) - 1} more problems)"
                                                          if len(problems) > 1 else ""))
    return read


def _plain(value: Any) -> Any:
    """numpy scalars from h5py attributes -> Python numbers (what the trial was written with)."""
    if isinstance(value, np.generic):
        return value.item()
    return value


def _xr_attr(key: str, value: Any, string_types: Mapping[str, np.dtype]) -> Any:
    """An attribute's h5py value as xarray's h5netcdf engine returns it.

    h5netcdf (``Attributes.__getitem__``): an empty attribute is b"" (1-char string type) or an
    empty array; fixed-length strings (longer than 1) are decoded with their HDF5 character set;
    string arrays become lists; a 1-element array or list becomes its element. xarray
    (``_read_attributes``): bytes are decoded as UTF-8, except ``_FillValue``/``missing_value``.
    ``string_types`` holds the HDF5 types of the fixed-length string attributes.
    """
    if isinstance(value, h5py.Empty):
        info = h5py.check_string_dtype(value.dtype)
        value = b"" if info and info.length == 1 else np.array([], dtype=value.dtype)
    else:
        dtype = getattr(value, "dtype", None)  # None for str/bytes: variable-length, left as they are
        info = None
        if dtype is not None and dtype.kind == "S":
            info = h5py.check_string_dtype(string_types[key])
        elif dtype is not None and dtype.kind == "O":
            info = h5py.check_string_dtype(dtype)
        if info is not None:
            if info.length is not None and info.length > 1:
                if np.isscalar(value):
                    value = value.decode(info.encoding, "surrogateescape")
                else:
                    value = [b.decode(info.encoding, "surrogateescape") for b in value.flat]
            elif not np.isscalar(value):
                value = value.tolist()
        if not np.isscalar(value) and len(value) == 1:
            value = value[0]
    if key not in ("_FillValue", "missing_value") and isinstance(value, bytes):
        try:
            value = value.decode("utf-8")
        except UnicodeDecodeError:
            warnings.warn(f"'utf-8' codec can't decode bytes for attribute {key!r}, returning bytes undecoded.",
                          UnicodeWarning, stacklevel=3)
    return value


def _xr_attrs(attrs: Mapping[str, Any], string_types: Mapping[str, np.dtype]) -> dict[str, Any]:
    return {k: _xr_attr(k, v, string_types) for k, v in attrs.items() if k not in _NC_HIDDEN}


@functools.lru_cache(maxsize=None)
def _store_classes() -> tuple[type, type]:
    """The xarray backend classes the reader hands its arrays to, defined on first use (they
    subclass xarray's, which is imported on first use)."""
    from xarray.backends import AbstractDataStore, BackendArray
    from xarray.core import indexing as xr_indexing

    class _Loaded(BackendArray):
        """A variable's data, read by the check, served to xarray's decoding as a backend array.

        Indexed like h5netcdf's variables: the dtype is the HDF5 dataset's (variable-length strings:
        object dtype with h5py's metadata) and a 0-d index returns a scalar.
        """

        def __init__(self, data: np.ndarray, dtype: np.dtype):
            self.array = data
            self.shape = data.shape
            self.dtype = dtype

        def __getitem__(self, key: Any) -> Any:
            return xr_indexing.explicit_indexing_adapter(key, self.shape, xr_indexing.IndexingSupport.OUTER_1VECTOR,
                                                         self.array.__getitem__)


    class _GroupStore(AbstractDataStore):
        """One group of a trial file, already read and checked, as an xarray data store."""

        def __init__(self, variables_: Mapping[str, xr.Variable], attrs: Mapping[str, Any], unlimited: set[str]):
            self._variables = dict(variables_)
            self._attrs = dict(attrs)
            self._unlimited = set(unlimited)

        def get_variables(self) -> dict[str, xr.Variable]:
            return self._variables

        def get_attrs(self) -> dict[str, Any]:
            return self._attrs

        def get_dimensions(self) -> dict[str, int]:
            return {d: n for v in self._variables.values() for d, n in zip(v.dims, v.shape)}

        def get_encoding(self) -> dict[str, Any]:
            return {"unlimited_dims": set(self._unlimited)}

    return _Loaded, _GroupStore


def _decoded(var: _StoredVar) -> np.ndarray:
    """A variable's data as read, variable-length strings decoded as h5netcdf's
    ``decode_vlen_strings`` does (h5py's ``asstr()`` with the dataset's character set)."""
    info = h5py.check_string_dtype(var.dtype)
    if info is None or info.length is not None:
        return np.asarray(var.data)
    raw = np.asarray(var.data, dtype=object)
    return np.array([b.decode(info.encoding) if isinstance(b, bytes) else b for b in raw.ravel().tolist()],
                    dtype=object).reshape(raw.shape)


def _dataset(group: _StoredGroup, source: str) -> xr.Dataset:
    """One group as ``xr.open_dataset(path, engine="h5netcdf", group=...).load()`` returns it.

    The group's dataset encoding is ``unlimited_dims`` only (as in ``open_datatree``'s nodes);
    :func:`open_trial` adds ``source`` as ``open_dataset`` does.
    """
    from xarray.core import indexing as xr_indexing

    _Loaded, _GroupStore = _store_classes()
    made = {}
    for var in group.variables:
        if not var.is_variable:
            continue
        dtype = var.dtype
        data = _decoded(var)
        encoding = {**var.encoding, "source": source, "original_shape": data.shape}
        made[var.name] = xr.Variable(var.dims, xr_indexing.LazilyIndexedArray(_Loaded(data, dtype)),
                                     _xr_attrs(var.attrs, var.string_types), encoding)
    store = _GroupStore(made, _xr_attrs(group.attrs, group.string_types), group.unlimited)
    return xr.open_dataset(store, engine="store").load()


def _source(path: Path) -> str:
    """The ``source`` encoding xarray records: the absolute path as given (xarray's _normalize_path)."""
    return os.path.abspath(os.path.expanduser(os.fspath(path)))


def open_trial(path: str | os.PathLike, *, group: str = "measured") -> xr.Dataset:
    """Open one group of a trial file, loaded into memory, the file closed again.

    Parameters
    ----------
    path : path-like
        A trial file.
    group : {"measured", "truth"}
        ``measured`` (what identification may read) by default.

    Returns
    -------
    xarray.Dataset
        The group's variables, exactly as ``xr.open_dataset(path, engine="h5netcdf",
        group=group)`` decodes them (values, dtypes, attributes, encodings), built from the
        arrays the content check read (one read of the file); its attributes are the file's
        global attributes (scene JSON, provenance, ACDD) followed by the group's own.

    Raises
    ------
    TrialFileError
        Naming the file: it is missing, unreadable or truncated, of another schema major
        version, lacks a channel, or its content does not match its ``content_sha256``.
    InputError
        ``group`` is not one of ``measured``, ``truth``.
    """
    if group not in GROUPS:
        raise InputError(f"unknown trial group {group!r}; expected one of {list(GROUPS)}")
    path = Path(path)
    read = _checked_read(path, (group,))
    source = _source(path)
    try:
        ds = _dataset(read.groups[group], source)
    except Exception as exc:  # noqa: BLE001 - a file whose content xarray cannot decode
        raise TrialFileError(f"{path}: cannot read group /{group}: {exc}") from exc
    ds.encoding["source"] = source
    # the global attributes as xarray decodes the root group, numbers as Python numbers
    root = _xr_attrs(read.root, read.root_string_types)
    ds.attrs = {**{k: _plain(v) for k, v in root.items() if k != "content_sha256"}, **ds.attrs}
    return ds


def open_trial_arrays(path: str | os.PathLike, *, group: str = "measured") -> GroupArrays:
    """:func:`open_trial` as plain NumPy arrays, without xarray (nor its import, ~0.6 s).

    Returns
    -------
    campaign.schema.GroupArrays
        The group's variables with the values, dtypes and dims :func:`open_trial` gives
        (labels as Python strings), each variable's attributes as stored, and the file's
        global attributes followed by the group's own. The file is checked as by
        :func:`open_trial` (schema version, channels, content digests). Identification in
        the campaign's jobs reads trials this way (``campaign.identify.load_trial``).

    Raises
    ------
    TrialFileError, InputError
        As :func:`open_trial`.
    """
    if group not in GROUPS:
        raise InputError(f"unknown trial group {group!r}; expected one of {list(GROUPS)}")
    path = Path(path)
    read = _checked_read(path, (group,), encodings=False)
    stored = read.groups[group]
    data_vars, coords = {}, {}
    for var in stored.variables:
        if not var.is_variable:
            continue
        data = _decoded(var)
        if data.dtype == object and var.dims == (var.name,):
            data = data.astype(str)   # a label coordinate: xarray's index holds str, not objects
        item = ChannelArray(tuple(var.dims), data, _xr_attrs(var.attrs, var.string_types))
        (coords if var.dims == (var.name,) else data_vars)[var.name] = item
    root = _xr_attrs(read.root, read.root_string_types)
    attrs = {**{k: _plain(v) for k, v in root.items() if k != "content_sha256"},
             **_xr_attrs(stored.attrs, stored.string_types)}
    return GroupArrays(data_vars, coords, attrs)


def open_trial_tree(path: str | os.PathLike) -> xr.DataTree:
    """Open a whole trial file (both groups), loaded into memory, the file closed again.

    Returns the tree exactly as stored, and as ``xr.open_datatree(path, engine="h5netcdf")``
    decodes it: ``open_trial_tree(p)`` is identical to ``prepare_trial(tree)`` of the tree
    written to ``p``. Raises :class:`TrialFileError` like :func:`open_trial`.
    """
    path = Path(path)
    read = _checked_read(path, GROUPS)
    source = _source(path)
    try:
        nodes = {"/": _dataset(_StoredGroup(read.root, read.root_string_types, [], set()), source)}
        nodes.update({f"/{g}": _dataset(read.groups[g], source) for g in GROUPS})
        tree = xr.DataTree.from_dict(nodes)
    except Exception as exc:  # noqa: BLE001 - a file whose content xarray cannot decode
        raise TrialFileError(f"{path}: cannot read the trial: {exc}") from exc
    tree.encoding["source"] = source
    return tree

# ---------------------------------------------------------------------------------------
# campaign folders
# ---------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class TrialRecord:
    """One trial of a campaign folder, as listed by :func:`list_trials` and ``index.csv``.

    Attributes
    ----------
    path : str
        Trial file relative to the campaign folder (``fixed/config1/zero/v1.500/r00.nc``).
    file : pathlib.Path
        The trial file itself.
    base, config, gain, speed, repeat, seed
        The scene's cell and RNG seed.
    scene : str
        Scene preset name (``default``, ``ideal``).
    scene_sha256, robot, schema_version : str
    scene_json : str
        The full scene (``Scene.from_json``).
    """

    path: str
    file: Path
    base: str
    config: int
    gain: str
    speed: float
    repeat: int
    seed: int
    scene: str
    scene_sha256: str
    robot: str
    schema_version: str
    scene_json: str = dataclasses.field(repr=False)

    def row(self) -> dict[str, Any]:
        """The ``index.csv`` row."""
        return {k: getattr(self, k) for k in INDEX_COLUMNS}


@dataclasses.dataclass(frozen=True)
class Problem:
    """One problem :func:`verify` found: the file (relative to the campaign) and what is wrong."""

    file: str
    message: str

    def __str__(self) -> str:
        return f"{self.file}: {self.message}"


def _campaign(campaign_dir: str | os.PathLike) -> Path:
    path = Path(campaign_dir)
    if not path.is_dir():
        raise InputError(f"{path} is not a campaign folder: no such directory")
    if not (path / MANIFEST).is_file() and not any(_trial_files(path)):
        raise InputError(f"{path} is not a campaign folder: it has no {MANIFEST} and no trial files "
                         f"(<base>/config<N>/<gain>/v<speed>/r<NN>{TRIAL_SUFFIX})")
    return path


def _trial_files(campaign: Path) -> Iterator[Path]:
    """Trial files at the Scene.cell layout, sorted."""
    for base in BASES:
        yield from sorted((campaign / base).glob(f"*/*/*/*{TRIAL_SUFFIX}"))


def _rel(campaign: Path, file: Path) -> str:
    return file.relative_to(campaign).as_posix()


def _record(campaign: Path, file: Path) -> TrialRecord:
    """A trial's record from its root attributes (h5py: a few ms, no data read)."""
    try:
        with h5py.File(file, "r") as f:
            attrs = {k: _plain(f.attrs[k]) for k in f.attrs.keys() if k not in _STRUCTURAL}
    except Exception as exc:  # noqa: BLE001 - see _CORRUPT
        raise TrialFileError(f"{file}: not a readable HDF5 file (truncated or corrupt): {exc}") from exc
    try:
        scene = json.loads(attrs["scene_json"])
        return TrialRecord(
            path=_rel(campaign, file), file=file, base=str(attrs["base"]), config=int(attrs["config"]),
            gain=str(attrs["gain"]), speed=float(attrs["speed"]), repeat=int(attrs["repeat"]),
            seed=int(attrs["seed"]), scene=str(scene["name"]), scene_sha256=str(attrs["scene_sha256"]),
            robot=str(attrs["robot"]), schema_version=str(attrs["schema_version"]),
            scene_json=str(attrs["scene_json"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise TrialFileError(f"{file}: not a campaign trial file (root attribute {exc} missing or malformed)") from exc


def _filter_values(key: str, value: Any) -> set:
    """A filter's accepted values, read as the key's type (a list, or "a,b" from the CLI)."""
    kind = FILTER_KEYS[key]
    items = value.split(",") if isinstance(value, str) else (
        list(value) if isinstance(value, (list, tuple, set, frozenset)) else [value])
    out = set()
    for item in items:
        try:
            v = kind(item.strip() if isinstance(item, str) else item)
        except (TypeError, ValueError):
            raise InputError(f"filter {key}={item!r}: expected {kind.__name__}") from None
        # speeds are matched at the precision of the cell path (v1.500)
        out.add(f"{v:.3f}" if key == "speed" else v)
    return out


def list_trials(campaign_dir: str | os.PathLike, **filters: Any) -> list[TrialRecord]:
    """The trials of a campaign folder, optionally filtered, sorted by path.

    Parameters
    ----------
    campaign_dir : path-like
        A campaign folder (``archive/<name>/``).
    **filters
        ``key=value`` with a key of :data:`FILTER_KEYS` (base, config, gain, speed, repeat,
        seed, scene, scene_sha256, robot). A value may be a list (any of) or a
        comma-separated string; speeds match to 1 mm/s (the cell path's precision).

    Returns
    -------
    list of TrialRecord

    Raises
    ------
    InputError
        Not a campaign folder, or an unknown filter key or unreadable filter value.
    TrialFileError
        A trial file whose root attributes cannot be read (named).
    """
    unknown = sorted(set(filters) - set(FILTER_KEYS))
    if unknown:
        raise InputError(f"unknown filter key(s) {', '.join(map(repr, unknown))}; known keys: {', '.join(FILTER_KEYS)}")
    wanted = {k: _filter_values(k, v) for k, v in filters.items()}
    campaign = _campaign(campaign_dir)
    out = []
    for file in progress(list(_trial_files(campaign)), desc="read"):
        rec = _record(campaign, file)
        if all((f"{rec.speed:.3f}" if k == "speed" else getattr(rec, k)) in vals for k, vals in wanted.items()):
            out.append(rec)
    return out


def _resolve_scalar(spec: str) -> tuple[str, Any]:
    """``"truth/v_a_pre"`` or ``"hammer_mass_eff"`` -> (group, schema Var) of a scalar variable."""
    if "/" in spec:
        group, name = spec.split("/", 1)
        if group not in GROUPS:
            raise InputError(f"variable {spec!r}: unknown group {group!r}; expected one of {list(GROUPS)}")
        table = {"measured": MEASURED, "truth": TRUTH}[group]
        found = [(group, v) for v in table if v.name == name]
    else:
        found = [(g, v) for g, table in (("measured", MEASURED), ("truth", TRUTH)) for v in table if v.name == spec]
    if not found:
        raise InputError(f"variable {spec!r} is not in schema {SCHEMA_VERSION}")
    if len(found) > 1:
        raise InputError(f"variable {spec!r} is in both groups; write measured/{spec} or truth/{spec}")
    group, var = found[0]
    if var.dims:
        raise InputError(f"open_campaign collects scalar per-trial variables; {group}/{var.name} has dims "
                         f"{var.dims}: open it per trial with open_trial")
    return group, var


def open_campaign(campaign_dir: str | os.PathLike, *, variables: Sequence[str] = (),
                  func: Callable[[xr.Dataset], Mapping[str, Any]] | None = None, group: str = "measured",
                  **filters: Any) -> xr.Dataset:
    """Per-trial results of a campaign as one labelled Dataset over (base, config, gain, speed, repeat).

    Parameters
    ----------
    campaign_dir : path-like
        A campaign folder.
    variables : sequence of str
        Scalar schema variables to collect, ``"group/name"`` or a bare name found in one
        group (``"hammer_mass_eff"``, ``"truth/v_a_pre"``, ``"truth/impulse"``). Read with
        h5py and checked against each group's ``content_sha256``.
    func : callable, optional
        Called with each trial's ``group`` Dataset (:func:`open_trial`); returns a mapping of
        result name to a scalar (number or str) or a 0-d DataArray (its attributes, e.g.
        units, are kept). This is how identification reruns on an archive without
        re-simulating.
    group : {"measured", "truth"}
        The group ``func`` receives.
    **filters
        As :func:`list_trials`.

    Returns
    -------
    xarray.Dataset
        Dims (base, config, gain, speed, repeat) over the values present; cells without a
        trial hold NaN (numbers) or "" (strings). Always has ``path`` (the trial file relative
        to the campaign folder); schema variables carry their units and long_name.
    """
    if group not in GROUPS:
        raise InputError(f"unknown trial group {group!r}; expected one of {list(GROUPS)}")
    if isinstance(variables, str):
        variables = [variables]
    resolved = list(dict.fromkeys(_resolve_scalar(v) for v in variables))
    records = list_trials(campaign_dir, **filters)
    if not records:
        raise InputError(f"{campaign_dir}: no trial matches the filters {filters}")
    want: dict[str, list[str]] = {}
    for g, var in resolved:
        want.setdefault(g, []).append(var.name)
    rows = []
    attrs: dict[str, dict[str, Any]] = {}
    for rec in records:
        row: dict[str, Any] = {k: getattr(rec, k) for k in CELL_KEYS}
        row["path"] = rec.path
        if resolved:
            _, problems, values = _inspect(rec.file, groups=tuple(want), want=want)
            if problems:
                raise TrialFileError(f"{rec.file}: {problems[0]}")
            for g, var in resolved:
                # a variable the trial's base does not carry (base_mass of a fixed base) stays NaN
                value = values.get(f"{g}/{var.name}")
                row[var.name] = float(value) if value is not None else math.nan
                attrs[var.name] = {"units": var.units, "long_name": var.long_name}
        if func is not None:
            result = func(open_trial(rec.file, group=group))
            if not isinstance(result, Mapping):
                raise InputError(f"open_campaign func must return a mapping of name to scalar, got "
                                 f"{type(result).__name__} for {rec.path}")
            for key, value in result.items():
                if key in row:
                    raise InputError(f"open_campaign func returned {key!r}, which clashes with a cell key or variable")
                row[key] = value
        rows.append(row)
    ds = to_cell_dataset(rows, attrs=attrs)
    ds.attrs.update(campaign=Path(campaign_dir).resolve().name, schema_version=SCHEMA_VERSION, trials=len(records))
    return ds


_CELL_TYPES = {"base": str, "config": int, "gain": str, "speed": float, "repeat": int}
_CELL_ATTRS = {
    "base": {"long_name": "base of the arm (fixed or flexible)"},
    "config": {"long_name": "arm configuration (paper Table 1; 0 = custom pose)"},
    "gain": {"long_name": "controller gain set (paper Table 1)"},
    "speed": {"units": "m s-1", "long_name": "impact speed of the hammer along n"},
    "repeat": {"long_name": "repeat index"},
}


def _coord_order(key: str, values: set) -> list:
    known = {"base": BASES, "gain": GAINS}.get(key)
    if known:
        return [v for v in known if v in values] + sorted(v for v in values if v not in known)
    return sorted(values)


def to_cell_dataset(records: Iterable[Mapping[str, Any]] | str | os.PathLike | Any, *,
                    attrs: Mapping[str, Mapping[str, Any]] | None = None) -> xr.Dataset:
    """Per-trial records -> a labelled Dataset with dims (base, config, gain, speed, repeat).

    Parameters
    ----------
    records : iterable of mapping, pandas.DataFrame, or path to a CSV file
        One record per trial with the cell keys ``base``, ``config``, ``gain``, ``speed``,
        ``repeat`` and any result columns (numbers, strings or 0-d DataArrays), e.g. the
        identified ``m_eff`` and ``e`` of each trial.
    attrs : mapping, optional
        Attributes per result column (``{"m_eff": {"units": "kg", "long_name": ...}}``).

    Returns
    -------
    xarray.Dataset
        Numeric columns as float64 with NaN in cells without a record (int64 if every cell is
        filled), strings with "" there.

    Raises
    ------
    InputError
        A record without a cell key, a cell value of the wrong type, or two records of the
        same cell (named).
    """
    if isinstance(records, (str, os.PathLike)):
        import pandas as pd  # xarray's own dependency; it reads numbers back as numbers

        if not Path(records).is_file():
            raise InputError(f"results table {records} does not exist")
        records = pd.read_csv(records).to_dict("records")
    elif hasattr(records, "to_dict") and hasattr(records, "columns"):
        records = records.to_dict("records")
    rows = list(records)
    if not rows:
        raise InputError("to_cell_dataset needs at least one record")
    cells = []
    columns: dict[str, None] = {}
    col_attrs: dict[str, dict[str, Any]] = {k: dict(v) for k, v in (attrs or {}).items()}
    for i, row in enumerate(rows):
        missing = [k for k in CELL_KEYS if k not in row]
        if missing:
            raise InputError(f"record {i} has no {', '.join(missing)} (each record needs {', '.join(CELL_KEYS)})")
        try:
            cell = tuple(_CELL_TYPES[k](row[k]) for k in CELL_KEYS)
        except (TypeError, ValueError) as exc:
            raise InputError(f"record {i}: bad cell value ({exc})") from None
        cells.append(cell)
        for k in row:
            if k not in CELL_KEYS:
                columns.setdefault(k)
    seen: dict[tuple, int] = {}
    for i, cell in enumerate(cells):
        if cell in seen:
            raise InputError(f"records {seen[cell]} and {i} are the same cell {dict(zip(CELL_KEYS, cell))}")
        seen[cell] = i
    coords = {k: _coord_order(k, {c[j] for c in cells}) for j, k in enumerate(CELL_KEYS)}
    index = [{v: n for n, v in enumerate(coords[k])} for k in CELL_KEYS]
    shape = tuple(len(coords[k]) for k in CELL_KEYS)
    positions = [tuple(index[j][c[j]] for j in range(len(CELL_KEYS))) for c in cells]
    data_vars = {}
    for col in columns:
        values = []
        for row in rows:
            v = row.get(col)
            if isinstance(v, xr.DataArray):
                col_attrs.setdefault(col, dict(v.attrs))
                v = v.item()
            values.append(v)
        present = [v for v in values if v is not None]
        if present and all(isinstance(v, str) for v in present):
            arr = np.full(shape, "", dtype=object)
        elif len(present) == len(cells) == math.prod(shape) and all(
                isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in present):
            arr = np.zeros(shape, dtype=np.int64)
        else:
            arr = np.full(shape, np.nan)
        for i, (pos, v) in enumerate(zip(positions, values)):
            if v is None:
                continue
            try:
                arr[pos] = v
            except (TypeError, ValueError):
                raise InputError(f"column {col!r}: value {v!r} of cell {dict(zip(CELL_KEYS, cells[i]))} "
                                 "is neither a number nor a string (mixed types in one column?)") from None
        if arr.dtype == object:
            arr = arr.astype(str)
        data_vars[col] = xr.Variable(CELL_KEYS, arr, col_attrs.get(col, {}))
    coord_vars = {k: xr.Variable(k, np.asarray(coords[k]), _CELL_ATTRS[k]) for k in CELL_KEYS}
    return xr.Dataset(data_vars, coords=coord_vars)


# ---------------------------------------------------------------------------------------
# manifest, index, README
# ---------------------------------------------------------------------------------------
def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _all_files(campaign: Path) -> list[Path]:
    return sorted(p for p in campaign.rglob("*") if p.is_file() and p.name != MANIFEST)


def _write_text(path: Path, text: str) -> Path:
    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
    return _replace_atomically(path, write)


def write_manifest(campaign_dir: str | os.PathLike) -> Path:
    """Write ``MANIFEST.sha256``: the sha256 of every file of the campaign folder.

    The format is ``sha256sum``'s (``<hex>  <relative path>``, sorted), so
    ``cd <campaign_dir> && sha256sum -c MANIFEST.sha256`` checks it without this package.

    Raises
    ------
    InputError
        Not a campaign folder, or it holds a temporary file of an interrupted write (named)
        or a file name ``sha256sum`` cannot list plainly (newline or backslash).
    """
    campaign = _campaign(campaign_dir)
    lines = []
    for file in progress(_all_files(campaign), desc="sha256", unit="file"):
        rel = _rel(campaign, file)
        if _TEMP_RE.match(file.name):
            raise InputError(f"{campaign / rel} is a temporary file of an interrupted write: delete it "
                             "(or rerun that trial) before finalizing")
        if "\n" in rel or "\\" in rel:
            raise InputError(f"{campaign / rel}: file names with newlines or backslashes cannot be listed")
        lines.append(f"{_sha256_file(file)}  {rel}\n")
    return _write_text(campaign / MANIFEST, "".join(lines))


def write_index(campaign_dir: str | os.PathLike, *, records: Sequence[TrialRecord] | None = None) -> Path:
    """Write ``index.csv``: one row per trial (:data:`INDEX_COLUMNS`), sorted by path.

    ``records`` are the folder's :func:`list_trials`, when the caller has them already."""
    campaign = _campaign(campaign_dir)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=INDEX_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for rec in (list_trials(campaign) if records is None else records):
        writer.writerow(rec.row())
    return _write_text(campaign / INDEX, buf.getvalue())


def _md_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _readme_text(name: str, records: Sequence[TrialRecord]) -> str:
    rates: dict[str, set] = {dim: set() for dim in CLOCKS}
    for rec in records:
        params = json.loads(rec.scene_json)["params"]
        for dim, clock in CLOCKS.items():
            if clock.rate_key in params:
                rates[dim].add(float(params[clock.rate_key]))
    counts = {b: sum(r.base == b for r in records) for b in BASES}
    clock_rows = [(f"`{dim}`", c.long_name, f"`{c.rate_key}`",
                   ", ".join(f"{r:g}" for r in sorted(rates[dim])) or "-") for dim, c in CLOCKS.items()]

    def var_rows(table):
        return [(f"`{v.name}`", "(" + ", ".join(v.dims) + ")" if v.dims else "scalar", f"`{v.units}`",
                 v.long_name, ", ".join(v.bases)) for v in table]

    label_rows = [(f"`{d}`", _LABEL_LONG_NAMES[d], ", ".join(COORDS[d]) if COORDS[d] else "the robot's active joints")
                  for d in COORDS]
    header = ("variable", "dims", "units", "long_name", "bases")
    parts = [
        f"# Campaign archive `{name}`",
        "",
        f"Generated from `campaign/schema.py` (schema {SCHEMA_VERSION}) by `campaign archive finalize`; "
        "do not edit, regenerate it.",
        "",
        f"{len(records)} trials: " + ", ".join(f"{counts[b]} {b}-base" for b in BASES) + ".",
        "",
        "## Files",
        "",
        f"- `<base>/config<N>/<gain>/v<speed m/s>/r<repeat>{TRIAL_SUFFIX}`: one trial, NetCDF4/HDF5 "
        "(`config-custom` for a pose that is not a paper configuration).",
        f"- `{INDEX}`: one row per trial: " + ", ".join(f"`{c}`" for c in INDEX_COLUMNS) + ".",
        f"- `{MANIFEST}`: sha256 of every other file; check with `sha256sum -c {MANIFEST}` in this folder, "
        "or `campaign archive verify <folder>` (also checks every trial against the schema).",
        "",
        "## Opening a trial",
        "",
        "```python",
        "import xarray as xr",
        f'with xr.open_dataset("fixed/config1/zero/v1.500/r00{TRIAL_SUFFIX}", engine="h5netcdf", group="measured") as ds:',
        "    ds.load()",
        "```",
        "",
        "Group `measured` holds what a real VES-II records (noisy, quantised, each channel on its own "
        "clock) plus the instrument constants an experimenter knows; group `truth` holds the simulator's "
        "exact states, kept apart (identification never reads it). The root group holds the global "
        "attributes: ACDD-1.3 (`title`, `summary`, `keywords`, `Conventions`, `id`, `date_created`, "
        "`creator_name`, `project`, `references`, `license`, `processing_level`), `schema_version`, the "
        "full scene as `scene_json` with its `scene_sha256`, the RNG `seed`, the cell (`base`, `config`, "
        "`gain`, `speed`, `repeat`, `robot`) and provenance (`campaign_version`, `git_commit`, library "
        "versions). Each group also stores `content_sha256`, a digest of its attributes and data that "
        "`campaign` checks on every read.",
        "",
        "## Clocks (time dimensions)",
        "",
        "Each time coordinate is float64 seconds from the start of the recording (`units = \"s\"`; no "
        "`standard_name`, which CF keeps for times with a `since` epoch); the contact happens at a seeded, "
        "jittered instant inside it.",
        "",
        _md_table(("dimension", "clock", "rate key (scene parameter)", "rate in this campaign [Hz]"), clock_rows),
        "",
        "## Label dimensions",
        "",
        _md_table(("dimension", "long_name", "values"), label_rows),
        "",
        "## Group `/measured`",
        "",
        _md_table(header, var_rows(MEASURED)),
        "",
        "## Group `/truth`",
        "",
        _md_table(header, var_rows(TRUTH)),
        "",
    ]
    return "\n".join(parts)


def write_readme(campaign_dir: str | os.PathLike, *, records: Sequence[TrialRecord] | None = None) -> Path:
    """Write ``README.md``: every variable, unit, dims and clock of the schema, and the rates used.

    Generated from :mod:`campaign.schema` and the trials' scenes, without a date, so the same
    campaign always gets the same README. ``records`` as in :func:`write_index`.
    """
    campaign = _campaign(campaign_dir)
    return _write_text(campaign / README, _readme_text(campaign.resolve().name,
                                                       list_trials(campaign) if records is None else records))


def finalize_campaign(campaign_dir: str | os.PathLike) -> dict[str, Path]:
    """Check every trial, then write ``index.csv``, ``README.md`` and ``MANIFEST.sha256`` (last).

    Returns
    -------
    dict
        ``{"index": path, "readme": path, "manifest": path}``.

    Raises
    ------
    TrialFileError
        A trial fails its schema or content check (each named): a broken file is never
        entered into the manifest.
    InputError
        Not a campaign folder, or a leftover temporary file.
    """
    campaign = _campaign(campaign_dir)
    bad = []
    files = list(_trial_files(campaign))
    for file, found in zip(files, _inspect_isolated_many(files)):
        bad += [f"{file}: {p}" for p in found]
    if bad:
        raise TrialFileError("cannot finalize, broken trial files: " + "; ".join(bad))
    # the index and the README describe the same trials: their root attributes are read once
    # (a few ms per file; 216 files in the full campaign)
    records = list_trials(campaign)
    misfiled = filing_problems(campaign, [_filing_record(r) for r in records])
    if misfiled:
        raise TrialFileError("cannot finalize, misfiled or duplicate trials: "
                             + "; ".join(f"{campaign / rel}: {message}" for rel, message in misfiled))
    return {"index": write_index(campaign, records=records), "readme": write_readme(campaign, records=records),
            "manifest": write_manifest(campaign)}


_MANIFEST_LINE = re.compile(r"^([0-9a-f]{64}) [ *](.+)$")


def verify(campaign_dir: str | os.PathLike) -> list[Problem]:
    """Check a campaign folder against its manifest and every trial against the schema.

    Reports, each with the file it concerns: a missing or malformed manifest, a file listed
    but missing, a sha256 mismatch (altered, flipped bytes, truncated), a file not in the
    manifest (including temporary files of interrupted writes), and for every trial file an
    unreadable or truncated file, a schema version of another major, a missing channel or
    group, content that does not match its ``content_sha256``; and an index that disagrees
    with the trial files. Nothing is skipped: every file is looked at.

    Returns
    -------
    list of Problem
        Empty when the campaign is intact.

    Raises
    ------
    InputError
        Not a campaign folder.
    """
    campaign = _campaign(campaign_dir)
    problems: list[Problem] = []
    listed: dict[str, str] = {}
    manifest = campaign / MANIFEST
    if not manifest.is_file():
        problems.append(Problem(MANIFEST, "missing: the campaign is not finalized (campaign archive finalize)"))
    else:
        for n, line in enumerate(manifest.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            m = _MANIFEST_LINE.match(line)
            if not m:
                problems.append(Problem(MANIFEST, f"line {n} is not '<sha256>  <path>': {line[:80]!r}"))
                continue
            rel = m.group(2)
            if rel.startswith("/") or ".." in Path(rel).parts:
                problems.append(Problem(MANIFEST, f"line {n} names a path outside the campaign: {rel!r}"))
                continue
            listed[rel] = m.group(1)
        for rel, digest in progress(listed.items(), desc="sha256", unit="file"):
            file = campaign / rel
            if not file.is_file():
                problems.append(Problem(rel, f"listed in {MANIFEST} but missing"))
            elif _sha256_file(file) != digest:
                problems.append(Problem(rel, f"sha256 differs from {MANIFEST} (altered, corrupt or truncated)"))
    on_disk = {_rel(campaign, f) for f in _all_files(campaign)}
    for rel in sorted(on_disk - set(listed)):
        if _TEMP_RE.match(Path(rel).name):
            problems.append(Problem(rel, "temporary file of an interrupted write (delete it)"))
        elif manifest.is_file():
            problems.append(Problem(rel, f"not in {MANIFEST}"))
    trials = [_rel(campaign, f) for f in _trial_files(campaign)]
    for rel, found in zip(trials, _inspect_isolated_many([campaign / rel for rel in trials])):
        problems += [Problem(rel, p) for p in found]
    readable = []
    for rel in trials:
        try:
            readable.append(_filing_record(_record(campaign, campaign / rel)))
        except TrialFileError:
            pass  # reported by the inspection above
    index = campaign / INDEX
    rows = None
    if index.is_file():
        try:
            with open(index, newline="", encoding="utf-8") as fh:
                rows = list(csv.DictReader(fh))
            indexed = {row["path"] for row in rows}
        except (KeyError, csv.Error, UnicodeDecodeError) as exc:
            problems.append(Problem(INDEX, f"unreadable: {exc}"))
            rows = None
        else:
            for rel in sorted(indexed - set(trials)):
                problems.append(Problem(INDEX, f"lists {rel}, which is not a trial file of this campaign"))
            for rel in sorted(set(trials) - indexed):
                problems.append(Problem(rel, f"trial file not listed in {INDEX}"))
    elif manifest.is_file():
        problems.append(Problem(INDEX, "missing (campaign archive finalize writes it)"))
    problems += [Problem(rel, message) for rel, message in filing_problems(campaign, readable, rows)]
    return problems


def _filing_record(rec: TrialRecord) -> dict[str, Any]:
    """What :func:`campaign.filing.filing_problems` reads of a trial."""
    return {"path": rec.path, "base": rec.base, "config": rec.config, "gain": rec.gain, "speed": rec.speed,
            "repeat": rec.repeat, "seed": rec.seed, "scene_json": rec.scene_json}
