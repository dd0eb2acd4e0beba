"""Opening trials: xarray's CF decoding of the arrays read (:func:`open_trial`, :func:`open_trial_tree`) or plain arrays (:func:`open_trial_arrays`)."""

from __future__ import annotations

import functools
import os
import warnings
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from ..core.errors import InputError, TrialFileError
from ..core.lazy import LazyModule
from ..scene.schema import ChannelArray, GroupArrays
from .fileformat import GROUPS
from .read import NC_HIDDEN_ATTRS, StoredGroup, StoredVar, checked_read

#: xarray, imported on first use (:mod:`campaign.core.lazy`): jobs that only check or index
#: trial files (``finalize_archive``, ``verify``) never need it
xr: Any = LazyModule("xarray")


def plain_value(value: Any) -> Any:
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
    return {k: _xr_attr(k, v, string_types) for k, v in attrs.items() if k not in NC_HIDDEN_ATTRS}


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


def _decoded(var: StoredVar) -> np.ndarray:
    """A variable's data as read, variable-length strings decoded as h5netcdf's
    ``decode_vlen_strings`` does (h5py's ``asstr()`` with the dataset's character set)."""
    info = h5py.check_string_dtype(var.dtype)
    if info is None or info.length is not None:
        return np.asarray(var.data)
    raw = np.asarray(var.data, dtype=object)
    return np.array([b.decode(info.encoding) if isinstance(b, bytes) else b for b in raw.ravel().tolist()],
                    dtype=object).reshape(raw.shape)


def _dataset(group: StoredGroup, source: str) -> xr.Dataset:
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
    read = checked_read(path, (group,))
    source = _source(path)
    try:
        ds = _dataset(read.groups[group], source)
    except Exception as exc:  # noqa: BLE001 - a file whose content xarray cannot decode
        raise TrialFileError(f"{path}: cannot read group /{group}: {exc}") from exc
    ds.encoding["source"] = source
    # the global attributes as xarray decodes the root group, numbers as Python numbers
    root = _xr_attrs(read.root, read.root_string_types)
    ds.attrs = {**{k: plain_value(v) for k, v in root.items() if k != "content_sha256"}, **ds.attrs}
    return ds


def open_trial_arrays(path: str | os.PathLike, *, group: str = "measured") -> GroupArrays:
    """:func:`open_trial` as plain NumPy arrays, without xarray (nor its import, ~0.6 s).

    Returns
    -------
    campaign.scene.schema.GroupArrays
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
    read = checked_read(path, (group,), encodings=False)
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
    attrs = {**{k: plain_value(v) for k, v in root.items() if k != "content_sha256"},
             **_xr_attrs(stored.attrs, stored.string_types)}
    return GroupArrays(data_vars, coords, attrs)


def open_trial_tree(path: str | os.PathLike) -> xr.DataTree:
    """Open a whole trial file (both groups), loaded into memory, the file closed again.

    Returns the tree exactly as stored, and as ``xr.open_datatree(path, engine="h5netcdf")``
    decodes it: ``open_trial_tree(p)`` is identical to ``prepare_trial(tree)`` of the tree
    written to ``p``. Raises :class:`TrialFileError` like :func:`open_trial`.
    """
    path = Path(path)
    read = checked_read(path, GROUPS)
    source = _source(path)
    try:
        nodes = {"/": _dataset(StoredGroup(read.root, read.root_string_types, [], set()), source)}
        nodes.update({f"/{g}": _dataset(read.groups[g], source) for g in GROUPS})
        tree = xr.DataTree.from_dict(nodes)
    except Exception as exc:  # noqa: BLE001 - a file whose content xarray cannot decode
        raise TrialFileError(f"{path}: cannot read the trial: {exc}") from exc
    tree.encoding["source"] = source
    return tree
