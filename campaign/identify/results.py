"""One trial's identification result, :class:`TrialIdentification`, and which results fits and tables use."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["TrialIdentification", "is_usable"]

@dataclasses.dataclass(frozen=True)
class TrialIdentification:
    """Identification result of one trial (SI units; ``nan`` where not computable).

    Attributes
    ----------
    m_eff : float
        Effective mass m* [kg]: eq 10, or the impulse estimator (``m_eff_estimator``).
    e : float
        Restitution coefficient, eq 12.
    v_a, v_a_post : float
        Arm tip velocity along n at the contact start / end [m/s].
    v_b, v_b_post : float
        Hammer velocity along n at the contact start / end [m/s].
    impulse : float
        Piezo impulse, trapezoid integral of the force over the contact [N s].
    impulse_momentum : float
        The numerator of ``m_eff`` [N s]: ``m_b (v_b - v'_b)``, the hammer's momentum change
        (eq 10), or with ``m_eff_estimator="impulse"`` the contact impulse from it (gravity's
        impulse over the contact removed); a cross-check of the piezo ``impulse`` either way.
    contact_start, contact_end : float
        Contact interval from the piezo force [s].
    peak_force : float
        Peak piezo force above the baseline [N].
    excluded : bool
        The trial must not enter fits or tables.
    reason : str
        Why it is excluded ("" if not).
    theta_contact : float
        Pendulum angle at the contact start [rad].
    n_joint_pre, n_joint_contact, n_joint_post : int
        Joint samples in the pre window, inside the contact, and in the post window.
    path, robot, base, config, gain, speed, repeat
        The trial's file and scene identity (from the root attributes; "" / -1 / nan when
        unknown).
    q_cmd : tuple of float
        Commanded joint angles, DH [rad].
    hammer_mass : float
        m_b [kg].
    impact_direction : tuple of float
        Unit n, base frame.
    base_mass : float
        Emulated base mass [kg] (flexible base; nan otherwise).
    base_inertia : tuple of float
        Emulated base inertia, 9 values row-major [kg m^2] (flexible base; empty otherwise).
    base_com, base_mount : tuple of float
        Base centre of mass and the arm's mounting point in the base frame [m] (flexible
        base; see :func:`base_geometry`).
    arm_velocity : str
        Tip-velocity method used: "ft", "encoders" or "combined".
    arm_velocity_note : str
        Why the F/T method was not used when it was asked for ("" otherwise).
    m_eff_estimator : str
        The estimator of ``m_eff``: "eq10" or "impulse" (:class:`IdentifyOptions`).
    """

    m_eff: float
    e: float
    v_a: float
    v_a_post: float
    v_b: float
    v_b_post: float
    impulse: float
    impulse_momentum: float
    contact_start: float
    contact_end: float
    peak_force: float
    excluded: bool
    reason: str
    theta_contact: float = float("nan")
    n_joint_pre: int = 0
    n_joint_contact: int = 0
    n_joint_post: int = 0
    path: str = ""
    robot: str = ""
    base: str = ""
    config: int = -1
    gain: str = ""
    speed: float = float("nan")
    repeat: int = -1
    q_cmd: tuple = ()
    hammer_mass: float = float("nan")
    impact_direction: tuple = ()
    base_mass: float = float("nan")
    base_inertia: tuple = ()
    base_com: tuple = ()
    base_mount: tuple = ()
    arm_velocity: str = ""
    arm_velocity_note: str = ""
    m_eff_estimator: str = "eq10"

    def to_dict(self) -> dict:
        """A JSON-safe dict: non-finite numbers become ``None``, tuples lists."""
        out = {}
        for f in dataclasses.fields(self):
            out[f.name] = _json_safe(getattr(self, f.name))
        return out


def is_usable(record) -> bool:
    """Whether a trial's identification record may enter fits and tables: not excluded, and
    its m* finite and > 0.

    ``record`` is a mapping with ``excluded`` and ``m_eff``, as
    :meth:`TrialIdentification.to_dict` or :func:`campaign.identify.table.read_identification`
    give it (an ``m_eff`` of ``None`` or NaN is not usable).
    """
    if record.get("excluded"):
        return False
    m_eff = record.get("m_eff")
    return m_eff is not None and math.isfinite(float(m_eff)) and float(m_eff) > 0


def _json_safe(v):
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    if isinstance(v, (tuple, list, np.ndarray)):
        return [_json_safe(x) for x in v]
    return v
