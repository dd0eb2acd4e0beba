"""The trial's plain arrays (:class:`campaign.scene.schema.TrialArrays`) as an
``xarray.DataTree``: what :func:`.trial.simulate` returns.

xarray and pandas are imported on first use: the campaign's simulation jobs store the
plain arrays and never pay ~0.7 s for them.
"""

from __future__ import annotations

from ..core.lazy import LazyModule
from ..scene import schema
from ..scene.schema import ChannelArray, TrialArrays

__all__ = ["to_tree"]

xr = LazyModule("xarray")
pd = LazyModule("pandas")


def to_tree(trial: TrialArrays) -> xr.DataTree:
    """The trial as an ``xarray.DataTree`` (what :func:`.trial.simulate` returns): each group is
    built from its Variables and indexed coordinates in one constructor call, and attached
    to the root without the copies ``DataTree.from_dict`` makes."""
    children = {}
    for name, group in trial.groups.items():
        coords = {dim: _time(dim, c) if dim in schema.CLOCKS else _labels(dim, c.values.tolist())
                  for dim, c in group.coords.items()}
        ds = xr.Dataset({k: xr.Variable(v.dims, v.values, v.attrs) for k, v in group.data_vars.items()},
                        coords=_coords(coords), attrs=group.attrs)
        children[name] = xr.DataTree(ds)
    tree = xr.DataTree(xr.Dataset(attrs=trial.attrs))
    tree.children = children
    return tree


def _time(dim: str, clock: ChannelArray):
    """A clock's time coordinate (``simulate._clock``) as ``(index, index variable)``: the
    ``PandasIndex`` and the variable xarray's default index of the dimension coordinate
    would give it."""
    var = xr.Variable((dim,), clock.values, clock.attrs)
    index = xr.indexes.PandasIndex(pd.Index(var.values, name=dim), dim, coord_dtype=var.dtype)
    return index, index.create_variables({dim: var})[dim]


#: (dim, labels) -> (index, index variable) of the label coordinates (joints, axes): the
#: same in every trial, indexed once (xarray indexes are immutable; every Dataset and tree
#: built from them holds its own shallow copies of the variable)
_LABELS: dict = {}


def _labels(dim: str, labels) -> tuple:
    key = (dim, tuple(labels))
    hit = _LABELS.get(key)
    if hit is None:
        var = xr.Variable((dim,), list(labels))
        index = xr.indexes.PandasIndex.from_variables({dim: var}, options={})
        hit = _LABELS[key] = (index, index.create_variables({dim: var})[dim])
    return hit


def _coords(coords: dict) -> xr.Coordinates:
    """Indexed coordinates of one group from its ``(index, index variable)`` pairs (what
    the Dataset constructor would build from the bare dimension coordinates)."""
    return xr.Coordinates({name: v for name, (_, v) in coords.items()},
                          indexes={name: i for name, (i, _) in coords.items()})
