"""Eq 7 and eq 8 on a simulated trial, eq 8's base velocity after an impulsive contact, and
eq 11's impulsive-limit m* from a trial's truth: the closed forms the studies set beside the
rig, which the calibration report and the benchmarks use too (this module imports only the
model, not identification's fitting libraries).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from ..model import exiit
from ..model.paper import impact_direction
from ..model.robot.floating import attach_to_floating_base, base_body_of

__all__ = ["eq7", "eq8", "impulsive_base_speed", "impulsive_base_velocity", "truth_m_impulse"]


# ----------------------------------------------------------------------------------------
def eq7(robot, record: Mapping, lam) -> float:
    """Eq 7's m* (fixed base) at the trial's commanded pose and impact direction [kg]."""
    return float(exiit.effective_mass(robot, np.asarray(record["q_cmd"], float), record["impact_direction"], lam))


def eq8(robot, record: Mapping, lam) -> float:
    """Eq 8's m* on the trial's emulated base (a free body during the contact) [kg]."""
    frobot = attach_to_floating_base(robot, base_body_of(record))
    G = exiit.exiit_floating(frobot, np.asarray(record["q_cmd"], float), lam)
    return float(exiit.effective_mass_from_G(G, record.get("impact_direction") or impact_direction()))


def impulsive_base_speed(robot, q_arm, base, lam, m_b: float, n) -> float:
    """Eq 8's base velocity along ``n`` right after an impulsive contact, per unit hammer
    momentum ``(1 + e) m_b v_b`` [m/s per N s].

    The arm (``lam`` added to its joint inertia) stands on the free base ``base`` (a
    :class:`~campaign.model.robot.floating.BaseBody`); the impulse on the tip is ``P n`` with
    ``P = m*/(m* + m_b)`` per unit hammer momentum (eq 14, m* from eq 8), and the
    generalised velocity jump is ``(M + lambda)^-1 J^T n P``. The ratio of its Low and High
    values is the Ex-IIT's answer to Figure 9's Low-vs-High reduction of the base motion
    (the spring and damper of the structure transmit no impulse).
    """
    frobot = attach_to_floating_base(robot, base)
    model = frobot.model
    data = model.createData()
    q_arm = np.asarray(q_arm, float)
    q = frobot.q_full(q_arm)
    M = exiit.inertia(model, data, q)
    M[6:, 6:] += exiit.lambda_matrix(lam, frobot.nv_arm)
    J = exiit.impact_jacobian(model, data, q, frobot.impact_frame_id)
    n = exiit.unit_direction(n)
    jump = np.linalg.solve(M, J[:3].T @ n)
    m8 = exiit.effective_mass_from_G(exiit.exiit_floating(frobot, q_arm, lam, data=data), n)
    return float(n @ jump[:3]) * m8 / (m8 + m_b)


def impulsive_base_velocity(robot, record: Mapping, lam, m_b: float) -> float:
    """:func:`impulsive_base_speed` on a trial's emulated base, pose and impact direction."""
    return impulsive_base_speed(robot, record["q_cmd"], base_body_of(record), lam, m_b, record["impact_direction"])



def truth_m_impulse(measured, truth, robot) -> float:
    """Eq 11's impulsive-limit m* of a trial from its truth: the true contact impulse over
    the true tip velocity change through the Jacobian at the contact start,
    ``P / n.J(q_s) (qd(t_e) - qd(t_s))``: what identification with
    ``m_eff_estimator="impulse"`` is scored against (synthetic or rig trials).

    ``n.J(q_s) qd(t_s)`` is the true ``v_a_pre``, and ``n.J(q_s) qd(t_e)`` the true
    ``v_a_post`` less ``n.(J(q_e) - J(q_s)) qd(t_e)``; only that correction (< 1 % of the
    velocity change) takes ``q`` and ``qd`` interpolated from the truth samples, so their
    spacing (1 ms) hardly enters. On the impulsive synthetic trials (``decay="none"``, fixed
    base) it is eq 11 with the trial's lambda.
    """
    t = np.asarray(truth["t_truth"].values, float)
    q, v = np.asarray(truth["q"].values, float), np.asarray(truth["v"].values, float)
    t_s, t_e = float(truth["contact_start"]), float(truth["contact_end"])
    n = exiit.unit_direction(np.asarray(measured["impact_direction"].values, float))

    def at(x, tq):
        return np.array([np.interp(tq, t, x[:, k]) for k in range(x.shape[1])])

    def jn(qq):
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, qq)
        return n @ exiit.impact_jacobian(robot.model, data, qq, robot.impact_frame_id)[:3]

    qd_e = at(v, t_e)
    dv = float(truth["v_a_post"]) - float(truth["v_a_pre"]) - float((jn(at(q, t_e)) - jn(at(q, t_s))) @ qd_e)
    return float(truth["impulse"]) / dv
