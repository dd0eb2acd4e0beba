"""The same trial: a trial file against a trial just computed, under the tolerance policy.

Two computations of one trial hold the same trial when they describe the same scene (their
root attributes agree but for when and with what the file was written) and every channel of
both groups agrees within :data:`campaign.core.tolerance.CROSS_MACHINE_RTOL` of its scale,
a quantised channel allowing its one-step flips
(:data:`campaign.core.tolerance.QUANTUM_FLIP_FRACTION`, steps from
:func:`campaign.rig.sensors.measured_quanta`). On the machine that wrote the file they agree
bit for bit; on another CPU, BLAS kernel or cluster node they agree to roundoff.
:func:`campaign.archive.write_trial_entry` keeps a file that holds the same trial, so a
rerun anywhere leaves an archive that reproduces unchanged.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..core.tolerance import CROSS_MACHINE_RTOL, Difference, compare, differences
from ..scene.description import Scene
from ..scene.schema import TrialArrays
from .fileformat import GROUPS, STRUCTURAL_ATTRS, GroupPlan, canonical_bytes, content_digest, plan_trial, provenance

__all__ = ["trial_differences"]

#: root attributes that say when a file was written, not what it holds (with those of
#: :func:`campaign.archive.provenance`: with what)
_WHEN_WRITTEN = frozenset({"date_created", "history", "content_sha256"})


def what_it_holds(root: Mapping[str, Any]) -> str:
    """Digest of a trial's root attributes without those that say when and with what it was written."""
    skip = _WHEN_WRITTEN | set(provenance())
    return content_digest({k: v for k, v in root.items() if k not in skip}, {})


def _attrs(obj: Any) -> dict[str, Any]:
    """An HDF5 object's attributes without the file format's bookkeeping."""
    return {k: obj.attrs[k] for k in obj.attrs.keys() if k not in STRUCTURAL_ATTRS and not k.startswith("_")}


def _same_attrs(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    """Attributes equal as the content digest sees them (a number stored as a 1-element array is that number)."""
    def canon(attrs):
        return {k: canonical_bytes(v if isinstance(v, (str, bytes)) else np.ravel(v)) for k, v in attrs.items()}
    return canon(a) == canon(b)


def _attr_differences(group: str, stored: Mapping[str, Any], new: Mapping[str, Any]) -> list[Difference]:
    """A group's attributes: text exactly, numbers (the time the arm came to rest, counts) on their own magnitude."""
    out = []
    for key in sorted(set(stored) | set(new)):
        name = f"{group} attribute {key}"
        if key not in stored or key not in new:
            out.append(Difference(name, math.inf, 0.0, 0.0, note="in one computation only"))
        else:
            a, b = stored[key], new[key]
            text = isinstance(a, (str, bytes)) or isinstance(b, (str, bytes))
            out.append(compare(np.ravel(a).astype(str) if text else np.ravel(a),
                               np.ravel(b).astype(str) if text else np.ravel(b), name=name, rtol=CROSS_MACHINE_RTOL))
    return out


def plan_differences(path: Path, root: Mapping[str, Any], groups: Mapping[str, GroupPlan]) -> list[Difference]:
    """:func:`trial_differences` of a trial already planned for writing (``fileformat.plan_trial``)."""
    from ..rig.sensors import measured_quanta  # the rig, only where two trials are compared

    found: list[Difference] = []
    with h5py.File(path, "r") as f:
        old_root = _attrs(f)
        if what_it_holds(old_root) != what_it_holds(root):
            skip = _WHEN_WRITTEN | set(provenance())
            keys = sorted(k for k in set(old_root) | set(root) if k not in skip
                          and (k not in old_root or k not in root or not _same_attrs({k: old_root[k]}, {k: root[k]})))
            found.append(Difference("root attributes", math.inf, 0.0, 0.0,
                                    note=f"another scene or trial: {', '.join(keys) or 'their digest'} differ(s)"))
            return found
        quanta = measured_quanta(Scene.from_json(str(root["scene_json"])))
        for g in GROUPS:
            stored = f[g]
            new = groups[g]
            found += _attr_differences(g, _attrs(stored),
                                       {k: v for k, v in new.attrs.items() if k not in STRUCTURAL_ATTRS})
            old_vars = {name: stored[name] for name in stored.keys()}
            new_vars = {v.name: v for v in new.variables}
            for name in sorted(set(old_vars) & set(new_vars)):
                if not _same_attrs(_attrs(old_vars[name]), new_vars[name].attrs):
                    found.append(Difference(f"{g}/{name}", math.inf, 0.0, 0.0, note="its attributes differ"))
            found += differences({k: v[()] for k, v in old_vars.items()}, {k: v.data for k, v in new_vars.items()},
                                 rtol=CROSS_MACHINE_RTOL, prefix=f"{g}/", quanta=quanta if g == "measured" else None)
    return found


def trial_differences(path: str | os.PathLike, trial: Any | TrialArrays) -> list[Difference]:
    """Compare a trial file with a trial computed now, channel by channel, under the tolerance policy.

    Parameters
    ----------
    path : path-like
        An intact trial file.
    trial : xarray.DataTree or TrialArrays
        The trial as the rig returns it (:func:`campaign.rig.simulate`,
        :func:`campaign.rig.simulate_arrays`).

    Returns
    -------
    list of campaign.core.tolerance.Difference
        One per channel (``group/name``) and group attribute, within
        :data:`campaign.core.tolerance.CROSS_MACHINE_RTOL` of its scale when the two hold
        the same trial (:func:`campaign.core.tolerance.worst` names the worst); a single
        ``root attributes`` difference when they describe different scenes or trials.
    """
    root, groups = plan_trial(trial)
    return plan_differences(Path(path), root, groups)
