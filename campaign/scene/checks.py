"""The values a campaign is made of, checked before any work: seeds, counts, rig overrides, speeds.

Each check raises :class:`campaign.core.errors.InputError` with one line that names the key or
option, the bad value and what is allowed. The CLI turns it into ``campaign <cmd>: error:
...`` and exit status 2; the workflow's start-up calls them through
:func:`campaign.pipeline.config.check_workflow_config`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from typing import Any

from ..core.errors import InputError, allowed_names
from ..core.vocabulary import SPEED_DECIMALS
from .description import SEED_MAX, hammer_reach, load_rig

__all__ = ["check_seed", "check_rig_params", "pendulum_reach", "check_speeds", "check_positive_int"]


def check_seed(seed: Any, *, key: str = "seed") -> int:
    """A seed: an integer in [0, 2**63 - 1] (what a trial file's int64 attribute holds)."""

    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_MAX:
        raise InputError(f"{key} = {seed!r} is not an integer in [0, 2**63 - 1]")
    return seed


def check_positive_int(value: Any, *, key: str) -> int:
    """An integer >= 1 (a budget, a count)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InputError(f"{key} = {value!r} must be an integer >= 1")
    return value


def check_rig_params(params: Mapping[str, Any] | None, *, rig: str | os.PathLike | None = None,
                     key: str = "rig_params") -> dict[str, Any]:
    """Every key of ``params`` is a parameter of the rig file; the scene checks the values.

    Returns the rig file's values with ``params`` applied (dotted keys)."""

    values, _ = load_rig(rig)
    for name in params or {}:
        if name not in values:
            raise InputError(f"{key}: unknown rig parameter {name!r}; {allowed_names(str(name), list(values))}")
    return {**values, **dict(params or {})}


def pendulum_reach(values: Mapping[str, Any]) -> float:
    """Largest head speed [m/s] the pendulum of the rig values ``values`` reaches (``inf``
    without gravity, where the hammer is launched at the asked speed)."""

    return hammer_reach(float(values["pendulum.head_mass"]), float(values["pendulum.rod_mass"]),
                        float(values["pendulum.radius"]), float(values["gravity"]),
                        float(values["pendulum.max_release_deg"]))


def check_speeds(speeds: Iterable[Any], *, key: str = "speeds", reach: float = math.inf) -> list[float]:
    """Impact speeds: finite, > 0, within the pendulum's ``reach``, distinct in their paths."""
    out: list[float] = []
    seen: dict[str, float] = {}
    for s in speeds:
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not math.isfinite(s) or s <= 0:
            raise InputError(f"{key}: speed {s!r} must be a finite number > 0 m/s")
        if s > reach:
            raise InputError(f"{key}: speed {s} m/s is beyond what the pendulum can reach (max {reach:.3f} m/s "
                             f"at its release limit, pendulum.max_release_deg)")
        label = f"{float(s):.{SPEED_DECIMALS}f}"
        if float(label) == 0:
            raise InputError(f"{key}: speed {s} m/s would be stored as v{label}, the path of no speed "
                             f"(paths keep {SPEED_DECIMALS} decimals)")
        if label in seen:
            raise InputError(f"{key}: speeds {seen[label]} and {s} m/s are the same trial path v{label} "
                             f"(speeds must differ in the first {SPEED_DECIMALS} decimals)")
        seen[label] = s
        out.append(float(s))
    return out
















