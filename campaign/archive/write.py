"""Writing trial files with h5py in the layout xarray's h5netcdf engine writes, atomically."""

from __future__ import annotations

import functools
import os
import tempfile
from pathlib import Path
from typing import Any, Callable, Iterator

import h5py
import numpy as np
from h5py import h5a, h5d, h5ds, h5p, h5s, h5t

from ..core.vocabulary import FIXED, FLEXIBLE
from .. import __version__
from ..core.errors import InputError
from ..core.files import replace_atomically, write_file
from ..core.lazy import LazyModule
from ..scene.description import Scene
from ..scene.schema import TrialArrays
from .fileformat import DEFLATE_LEVEL, GROUPS, TRIAL_SUFFIX, GroupPlan, plan_trial

#: a little less than a default scene's trial file takes [bytes], per base: the free space a
#: command asks for per trial before it simulates (denser channels, as the ideal scene's on
#: the flexible base, take more; a disk that fills part-way fails the write cleanly)
TRIAL_BYTES = {FIXED: 150_000, FLEXIBLE: 750_000}

#: xarray, imported on first use (:mod:`campaign.core.lazy`): jobs that only check or index
#: trial files (``finalize_archive``, ``verify``) never need it
xr: Any = LazyModule("xarray")


# ---------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------
# The writer uses h5py's low-level API: the high-level one costs about 0.1 ms of Python per
# attribute or dataset, a third of the write budget for a trial's ~50 variables and ~150
# attributes. What it creates is what h5py's high-level API (and so h5netcdf) creates:
# variable-length UTF-8 string attributes, scalar dataspaces for scalars, no timestamps,
# shuffle then deflate on chunked variables.
#: the HDF5 1.8 file format, which netCDF-C (4.4 on) writes too and every netCDF-4 reader
#: reads: its object headers take a trial's attributes and dimension scales in less time
#: than the library's earliest format (up to a quarter of the image's CPU, measured with
#: benchmarks/bench_identify_write.py's settings)
LIBVER = ("v108", "v108")
_VLEN_STR = h5py.string_dtype()
_VLEN_STR_TYPE = h5t.py_create(_VLEN_STR, logical=True)


def _lcpl() -> h5p.PropLCID:
    lcpl = h5p.create(h5p.LINK_CREATE)
    lcpl.set_char_encoding(h5t.CSET_UTF8)
    return lcpl


# made once and reused by every object created (HDF5 copies what it needs): a trial creates
# ~40 datasets and ~180 attributes, and each of these costs a few microseconds more to make
_LCPL = _lcpl()
_SCALAR = h5s.create(h5s.SCALAR)


@functools.cache
def _numeric_type(dtype: np.dtype, logical: bool) -> h5t.TypeID:
    """``h5t.py_create(dtype, logical=logical)`` of a numeric dtype, made once."""
    return h5t.py_create(dtype, logical=logical)


def _space(shape: tuple[int, ...]) -> h5s.SpaceID:
    return _SCALAR if shape == () else h5s.create_simple(shape)


def _put_attr(oid: Any, key: str, value: Any) -> None:
    """One attribute, as ``obj.attrs[key] = value`` would store it."""
    if isinstance(value, str) or (isinstance(value, np.ndarray) and value.dtype.kind in "UO"):
        data = np.array(value if isinstance(value, str) else value.tolist(), dtype=_VLEN_STR)
        tid = _VLEN_STR_TYPE
    else:
        data = np.asarray(value)
        tid = _numeric_type(data.dtype, False)
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
        tid = _numeric_type(data.dtype, True)
    if chunks is not None:
        dcpl.set_chunk(chunks)
        if shuffle:
            dcpl.set_shuffle()
        if level:
            dcpl.set_deflate(level)
        if fletcher32:
            dcpl.set_fletcher32()
    dsid = h5d.create(gid, name.encode(), tid, _space(data.shape), dcpl=dcpl, lcpl=_LCPL)
    if data.size:
        dsid.write(h5s.ALL, h5s.ALL, data)
    return dsid


def _write_group(gid: Any, group: GroupPlan, next_dimid: Iterator[int], *, level: int, fletcher32: bool) -> None:
    """Write one planned group in the netCDF-4 layout h5netcdf produces (dimension scales first).

    The arrays written are the ones :func:`plan_trial` digested, so the stored ``content_sha256``
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


def _fill_h5(f: h5py.File, plan: tuple[dict[str, Any], dict[str, GroupPlan]], *, level: int = DEFLATE_LEVEL,
             fletcher32: bool = False) -> None:
    """Write a planned trial into the open, empty HDF5 file ``f``."""
    root, groups = plan
    f.attrs["_NCProperties"] = np.bytes_(
        f"version=2,campaign={__version__},hdf5={h5py.version.hdf5_version},h5py={h5py.__version__}".encode())
    for key, value in root.items():
        _put_attr(f.id, key, value)
    dimids = iter(range(1 << 30))
    for name in GROUPS:
        _write_group(f.create_group(name, track_order=True).id, groups[name], dimids, level=level,
                     fletcher32=fletcher32)


def _write_h5(plan: tuple[dict[str, Any], dict[str, GroupPlan]], path: Path, *, level: int = DEFLATE_LEVEL,
              fletcher32: bool = False) -> None:
    """Write a planned trial to ``path`` with HDF5 (no atomicity here; see :func:`write_trial`)."""
    # track_order: netCDF-4 files keep creation order, and readers list variables in it
    with h5py.File(path, "w", track_order=True, libver=LIBVER) as f:
        _fill_h5(f, plan, level=level, fletcher32=fletcher32)


def _anonymous_file() -> int:
    """A file descriptor of a new file without a name: in memory where the system has
    ``memfd_create`` (Linux), else in the temporary folder."""
    memfd_create = getattr(os, "memfd_create", None)
    if memfd_create is not None:
        return memfd_create("campaign-trial", os.MFD_CLOEXEC)
    with tempfile.TemporaryFile() as fh:
        return os.dup(fh.fileno())


def _hdf5_image(plan: tuple[dict[str, Any], dict[str, GroupPlan]], tmp: Path, *, level: int = DEFLATE_LEVEL) -> bytes:
    """The bytes of a planned trial's file, as HDF5 writes them to ``tmp``.

    HDF5 creates ``tmp`` (a few bytes), then its file descriptor is pointed at an anonymous
    file holding the same bytes, where HDF5 does the rest. A full disk then fails in the
    caller's plain write of the returned bytes, which cleans up and names the file, never
    inside HDF5, which would leave its objects half-closed (tracebacks, leaked descriptors,
    a crash). The bytes are those HDF5 writes to a file on disk.
    """
    scratch = _anonymous_file()
    try:
        # track_order: netCDF-4 files keep creation order, and readers list variables in it
        with h5py.File(tmp, "w", track_order=True, libver=LIBVER) as f:
            fd = f.id.get_vfd_handle()
            started = os.pread(fd, os.fstat(fd).st_size, 0)
            os.pwrite(scratch, started, 0)
            os.dup2(scratch, fd, inheritable=False)
            _fill_h5(f, plan, level=level)
        with open(scratch, "rb", closefd=False) as fh:
            fh.seek(0)
            return fh.read()
    finally:
        os.close(scratch)


def replace_campaign_file(path: Path, write: Callable[[Path], None]) -> Path:
    """:func:`campaign.core.files.replace_atomically` for a campaign folder's files: one writer
    per file, so temporary files a killed writer of ``path`` left are removed first."""
    return replace_atomically(path, write, clear_stale=True)


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
        The trial breaks the schema, or ``path`` is a folder, device or FIFO (nothing is
        written).
    campaign.core.errors.WriteError
        Writing failed part-way (a full disk): nothing is left under ``path`` or a
        temporary name.

    Notes
    -----
    One writer per file: a rerun removes temporary files an earlier, killed writer of the
    same ``path`` left behind. Rewriting a trial of a finalized campaign makes its manifest
    stale until ``finalize_campaign`` runs again (``verify`` reports the mismatch).
    """
    return write_planned(plan_trial(tree), Path(path), fsync=fsync)


def write_planned(plan: tuple[dict[str, Any], dict[str, GroupPlan]], path: Path, *, fsync: bool) -> Path:
    """A validated trial (:func:`.fileformat.plan_trial`) written atomically to ``path``: its HDF5
    image is built in memory, then written in one call (:func:`campaign.core.files.write_file`
    names the file and the free space when the disk is full)."""
    return replace_campaign_file(path, lambda tmp: write_file(tmp, _hdf5_image(plan, tmp), fsync=fsync))


def trial_path(campaign_dir: str | os.PathLike, scene: Scene) -> Path:
    """Where a scene's trial lives in a campaign folder: ``<campaign_dir>/<scene.cell>.nc``."""
    if not isinstance(scene, Scene):
        raise InputError(f"trial_path needs a Scene, got {type(scene).__name__}")
    return Path(campaign_dir) / f"{scene.cell}{TRIAL_SUFFIX}"
