"""The paper's conventions and published values, read from ``config/paper.yaml``.

Configurations and the impact direction live in the config folder, the mapping of the
paper's angles to the model's with the paper's robot (its drive file's
``angle_offset_deg``, :mod:`.conventions`), not in code; this module only reads and
checks them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError
from ..core.yamlfile import config_dir, read_yaml
from .conventions import angle_offset_deg, configurations

__all__ = ["load_paper", "paper_robot", "paper_offset_deg", "paper_q", "configuration_q", "impact_direction",
           "gain_counts"]


def load_paper() -> dict:
    """The parsed ``paper.yaml`` (cached while the file is unchanged; treat as read-only)."""
    return read_yaml(config_dir() / "paper.yaml", copy=False)


def paper_robot() -> str:
    """Name of the robot the paper's experiments used (a folder of :mod:`campaign.model.robot`)."""
    return str(load_paper()["robot"])


def paper_offset_deg() -> np.ndarray:
    """Offset [deg] from the paper's joint angles to the model's DH angles: the paper's
    robot's ``angle_offset_deg`` (the PUMA 560's 0, 0, -90 deg)."""
    return np.asarray(angle_offset_deg(paper_robot()), dtype=float)


def paper_q(q_paper_deg) -> np.ndarray:
    """Map the paper's joint angles [deg] to the model's DH angles [rad]: one pose, shape
    (n,), or a pose per row, shape (N, n)."""
    q = np.asarray(q_paper_deg, dtype=float)
    off = paper_offset_deg()
    if q.ndim not in (1, 2) or q.shape[-1:] != off.shape:
        raise ValueError(f"expected {off.size} paper angles, got {q.tolist()}")
    return np.radians(q + off)


def configuration_q(config) -> np.ndarray:
    """DH angles [rad] of the paper's configuration ``config`` (1, 2 or 3)."""
    table = configurations(paper_robot())
    try:
        key = int(config)
    except (TypeError, ValueError):
        key = None
    if key not in table:
        raise ValueError(f"unknown configuration {config!r}; known: {sorted(table)}")
    return paper_q(table[key])


def impact_direction() -> np.ndarray:
    """Unit impact direction n of the paper, base frame."""
    n = np.asarray(load_paper()["impact_direction"], dtype=float)
    return n / np.linalg.norm(n)


def gain_counts(gain: str, overrides: Mapping[str, Mapping[str, float]] | None = None) -> tuple[float, float, float]:
    """(P, D, I) controller counts of a gain set: the paper's Table 1 row with ``overrides``.

    Parameters
    ----------
    gain : str
        A gain set of Table 1 (``zero``, ``low``, ``high``).
    overrides : mapping, optional
        ``{gain: {"P": ..., "D": ..., "I": ...}}``; any key may be left out.
    """
    table = load_paper()["gains"]
    if gain not in table:
        raise InputError(f"unknown gain set {gain!r}; expected one of {sorted(table)}")
    row = {k: float(table[gain][k]) for k in ("P", "D", "I")}
    for key, value in dict((overrides or {}).get(gain) or {}).items():
        if key not in row:
            raise InputError(f"gain_counts.{gain}.{key}: unknown gain term (expected P, D or I)")
        value = float(value)
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"gain_counts.{gain}.{key} = {value!r} must be a finite count >= 0")
        row[key] = value
    return row["P"], row["D"], row["I"]
