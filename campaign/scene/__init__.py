"""One trial's validated description (:class:`~campaign.scene.description.Scene`), its rig
parameters, the checks of a campaign's values and the channels a trial records.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`). The
modules: :mod:`~campaign.scene.description`, :mod:`~campaign.scene.checks`,
:mod:`~campaign.scene.schema`.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "Scene", "make_scene", "derive_seed", "load_rig", "rig_values", "load_structures", "structure_of",
    "check_rig_params", "check_speeds", "pendulum_reach", "SCHEMA_VERSION", "MEASURED", "TRUTH", "CLOCKS", "COORDS",
    "ChannelArray", "GroupArrays", "TrialArrays",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "description": ("Scene", "make_scene", "derive_seed", "load_rig", "rig_values", "load_structures", "structure_of"),
    "checks": ("check_rig_params", "check_speeds", "pendulum_reach"),
    "schema": ("SCHEMA_VERSION", "MEASURED", "TRUTH", "CLOCKS", "COORDS", "ChannelArray", "GroupArrays", "TrialArrays"),
})
