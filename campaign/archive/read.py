"""Reading and checking trial files with h5py: structure, schema, content digest; isolated checks for crash-prone files."""

from __future__ import annotations

import dataclasses
import json
import os
import re
from pathlib import Path
from typing import Any, Mapping, Sequence

import h5py
import numpy as np
from h5py import h5, h5a, h5d, h5ds, h5i, h5o, h5p, h5r, h5s, h5t

from ..core.errors import TrialFileError
from ..core.files import not_regular
from ..core.progress import progress
from ..core.vocabulary import bases
from ..scene.schema import CLOCKS, COORDS, SCHEMA_VERSION, variables
from .fileformat import GROUPS, SCHEMA_MAJOR, STRUCTURAL_ATTRS, content_digest

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
#   (:data:`NC_HIDDEN_ATTRS`) left out, 1-element arrays returned as their element, string arrays as
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
# data types other than numbers and strings. tests/archive/test_archive.py checks the result against
# ``xr.open_dataset``/``xr.open_datatree`` (``assert_identical`` and equal encodings) on rig
# trials of both bases and on a file xarray writes itself.

#: attributes h5netcdf hides from its attribute mappings (h5netcdf.attrs._HIDDEN_ATTRS)
NC_HIDDEN_ATTRS = frozenset({"REFERENCE_LIST", "CLASS", "DIMENSION_LIST", "NAME", "_Netcdf4Dimid",
                             "_Netcdf4Coordinates",
                        "_nc3_strict", "_NCProperties"})
# read for neither the digest nor xarray (content_sha256 is read: xarray shows it)
_NOT_READ = STRUCTURAL_ATTRS - {"content_sha256"}
_NC_DIM_ONLY = b"This is a netCDF dimension but not a netCDF variable"
# HDF5 filters h5netcdf reports as compression flags (h5netcdf.core.Variable.filters)
_H5_FILTER_TO_COMPRESSION = {"1": "zlib", "2": "szip", "307": "bzip2", "32004": "blosc", "32015": "zstd",
                             "zlib": "zlib", "szip": "szip", "bzip2": "bzip2", "blosc": "blosc", "zstd": "zstd"}


@dataclasses.dataclass
class StoredVar:
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
class StoredGroup:
    attrs: dict[str, Any]
    string_types: dict[str, np.dtype]
    variables: list[StoredVar]
    unlimited: set[str]


@dataclasses.dataclass
class _Read:
    root: dict[str, Any]      # root attributes, h5py values (content_sha256 included)
    problems: list[str]
    values: dict[str, Any]    # "group/name" -> data, for the variables asked for
    groups: dict[str, StoredGroup]
    root_string_types: dict[str, np.dtype] = dataclasses.field(default_factory=dict)


def _attr_value(oid: Any, name: bytes) -> Any:
    """One attribute's value exactly as h5py's ``obj.attrs[name]`` gives it (its steps
    without the high-level layer's locking and name handling, a third of the cost)."""
    attr = h5a.open(oid, name)
    shape = attr.shape
    if shape is None:   # an empty dataspace
        return h5py.Empty(attr.dtype)
    dtype = attr.dtype
    htype = h5t.py_create(dtype)
    if dtype.subdtype is not None:   # a top-level array type: numpy has none
        dtype, subshape = dtype.subdtype
        shape = shape + subshape
    arr = np.zeros(shape, dtype=dtype, order="C")
    attr.read(arr, mtype=htype)
    info = h5t.check_string_dtype(dtype)
    if info and info.length is None:   # variable-length strings: bytes to str
        arr = np.array([b.decode("utf-8", "surrogateescape") for b in arr.flat], dtype=dtype).reshape(arr.shape)
    return arr[()] if arr.ndim == 0 else arr


def _attr_names(oid: Any) -> list[bytes]:
    """An HDF5 object's attribute names in the order h5py lists them (creation order when tracked)."""
    cpl = oid.get_create_plist()
    tracked = cpl.get_attr_creation_order() & h5p.CRT_ORDER_TRACKED
    names: list[bytes] = []
    h5a.iterate(oid, lambda name, *_: names.append(name),
                index_type=h5.INDEX_CRT_ORDER if tracked else h5.INDEX_NAME)
    return names


def _read_data(dset: h5py.Dataset) -> Any:
    """A dataset's values exactly as h5py's ``dset[()]`` gives them; numbers read through the
    low-level API (a tenth of the high-level call's cost on a trial's small channels)."""
    dsid = dset.id
    dtype = dsid.dtype
    shape = dsid.shape
    if dtype.kind not in "iuf" or shape is None:   # strings, an empty dataspace: h5py's own way
        return dset[()]
    arr = np.empty(shape, dtype=dtype)
    if arr.size:
        dsid.read(h5s.ALL, h5s.ALL, arr)
    return arr[()] if arr.ndim == 0 else arr


def _read_attrs(obj: h5py.HLObject) -> dict[str, Any]:
    """An HDF5 object's attributes in file order (h5py values), HDF5/netCDF-4 bookkeeping left out."""
    oid = (obj["/"] if isinstance(obj, h5py.File) else obj).id   # a file's attributes are its root group's
    out = {}
    for raw in _attr_names(oid):
        key = raw.decode("utf-8", "surrogateescape")
        if key not in _NOT_READ:
            out[key] = _attr_value(oid, raw)
    return out


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
    refs = _attr_value(dset.id, b"DIMENSION_LIST") if h5a.exists(dset.id, b"DIMENSION_LIST") else None
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
                ) -> tuple[StoredGroup, dict[str, Any]]:
    """Read and check one group: every channel present, dims, readable data; digest checked by the caller."""
    grp = f[group]
    names = list(grp.keys())
    present = set(names)
    for spec in variables(group, base):
        if spec.name not in present:
            problems.append(f"channel {group}/{spec.name} is missing")
    schema_dims = {spec.name: spec.dims for spec in variables(group, base)}
    scales: dict[Any, tuple[str, int]] = {}
    stored: list[StoredVar] = []
    unlimited: set[str] = set()
    values: dict[str, Any] = {}
    for name in names:
        oid = h5o.open(grp.id, name.encode())  # what grp[name] does, at half the cost
        if not isinstance(oid, h5d.DatasetID):
            problems.append(f"{group}/{name} is not a variable")
            continue
        dset = h5py.Dataset(oid)
        try:
            data = _read_data(dset)
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
        stored.append(StoredVar(name, data, vattrs, dims, dset, is_variable, dtype, _string_types(dset, vattrs)))
        if name in want:
            values[f"{group}/{name}"] = data
    gattrs = _read_attrs(grp)
    return StoredGroup(gattrs, _string_types(grp, gattrs), stored, unlimited), values


def _read_trial(path: Path, *, groups: Sequence[str] = GROUPS, want: Mapping[str, Sequence[str]] | None = None,
                encodings: bool = False) -> _Read:
    """Read and check a trial file with h5py: readable, schema version, every channel, dims,
    content digests. Never raises for a bad file: each problem is a message.

    With ``encodings``, each variable's storage encoding is read as well (what the Datasets
    of :func:`open_trial` report), while the file is open.
    """
    out = _Read({}, [], {}, {})
    problems = out.problems
    kind = not_regular(path)  # never opened otherwise: opening a FIFO waits for a writer
    if kind:
        problems.append("file does not exist" if kind == "does not exist" else kind)
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
            if version[0] > SCHEMA_MAJOR:
                problems.append(f"schema version {version[0]}.{version[1]} is newer than this campaign reads "
                                f"({SCHEMA_VERSION}); upgrade the campaign package")
                return out
            if version[0] < SCHEMA_MAJOR:
                problems.append(f"schema version {version[0]}.{version[1]} is older than this campaign reads "
                                f"({SCHEMA_VERSION}) and there is no converter")
                return out
            base = root.get("base")
            if base not in bases():
                problems.append(f"root attribute base is {base!r}, expected one of {list(bases())}")
                return out
            stored = root.get("content_sha256")
            if stored is None:
                problems.append("root group has no content_sha256")
            elif stored != content_digest(root, {}):
                problems.append("root attributes do not match their content_sha256 (altered or corrupt)")
            # nothing beside the groups, whichever a reader opens (listing the root costs nothing)
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
                elif stored != content_digest(read.attrs, contents):
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


def inspect_trial(path: Path, *, groups: Sequence[str] = GROUPS, want: Mapping[str, Sequence[str]] | None = None
             ) -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """Check a trial file with h5py (:func:`_read_trial`).

    Returns (root attributes, problems, values of the variables asked for in ``want`` as
    ``{"group/name": value}``). Never raises for a bad file: each problem is a message.
    """
    read = _read_trial(path, groups=groups, want=want)
    return {k: v for k, v in read.root.items() if k != "content_sha256"}, read.problems, read.values


def _inspect_isolated(path: Path) -> list[str]:
    """:func:`inspect_trial` of one file in a forked child process; returns its problems
    (:func:`inspect_isolated_many`)."""
    return inspect_isolated_many([path])[0]


def inspect_isolated_many(paths: Sequence[Path]) -> list[list[str]]:
    """:func:`inspect_trial` of each file, in forked child processes; returns each file's problems.

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
        return [inspect_trial(p)[1] for p in paths]
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
                        out.write(json.dumps(inspect_trial(path)[1]).encode() + b"\n")
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


def checked_read(path: Path, groups: Sequence[str], *, encodings: bool = True) -> _Read:
    """:func:`_read_trial` (with encodings unless told); raises TrialFileError naming the file
    on any problem."""
    read = _read_trial(path, groups=groups, encodings=encodings)
    problems = read.problems
    if problems:
        raise TrialFileError(f"{path}: {problems[0]}" + (f" (and {len(problems) - 1} more problems)"
                                                          if len(problems) > 1 else ""))
    return read
