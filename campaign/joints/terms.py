"""What the contact response needs of each pose: one Pinocchio pass per pose.

On the fixed base (:func:`arm_terms`): the joint-space inertia ``H`` (reflected rotor
inertia included), the impact point's linear Jacobian ``J``, its second derivative
``d^2 p / dq_i dq_j`` (the pose moves during a 70 ms contact, and where ``n^T J`` is a small
difference of large joint terms a few milliradians change it by per cents) and the
gradient of the gravity torques ``dG/dq`` (a joint stiffness). On the flexible base
(:func:`base_terms`) also the arm on its free base body (the structure's tip body, Pinocchio's
free-flyer: ``M`` and ``J`` over base and joints), the arm's own share of the base block and
its gravity gradient (what the VES-II's F/T sensor feels), the structure's ``M_s``, ``K_s``,
``B_s`` and its first mode with the arm locked on top.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import scipy.linalg as sla

from ..core.errors import InputError
from ..model.robot import Robot
from ..model.robot.floating import BaseBody, attach_to_floating_base

__all__ = ["ArmTerms", "BaseTerms", "arm_terms", "base_terms", "HESSIAN_STEP"]

#: joint step of the central differences of the impact point's Jacobian [rad]
HESSIAN_STEP = 1e-5
#: the arm-only free-flyer's base body: small enough to leave the arm's gravity alone
_TINY = 1e-9


@dataclasses.dataclass(frozen=True)
class BaseTerms:
    """The arm on the flexible structure's tip body (shapes lead with N poses; ``nx = 6 + nv``).

    Attributes
    ----------
    M : (N, nx, nx) free-flyer inertia of base body and arm (base twist first) [kg, kg m, kg m^2].
    J : (N, 3, nx) the impact point's linear Jacobian over base twist and joints.
    arm_base_inertia : (N, 6, 6) the arm's share of ``M``'s base block (``M_bb - M_s``).
    gravity_stiffness : (N, nx, nx) ``dG/dx`` of the arm alone (no base body) per unit gravity.
    gravity_stiffness_full : (N, nx, nx) the same with the base body (the ideal coupling's).
    structure_mass, structure_stiffness, structure_damping : (6, 6) ``M_s``, ``K_s``, ``B_s``.
    first_mode : (N,) first natural frequency of the structure with the arm locked on top [Hz].
    """

    M: np.ndarray
    J: np.ndarray
    arm_base_inertia: np.ndarray
    gravity_stiffness: np.ndarray
    gravity_stiffness_full: np.ndarray
    structure_mass: np.ndarray
    structure_stiffness: np.ndarray
    structure_damping: np.ndarray
    first_mode: np.ndarray


@dataclasses.dataclass(frozen=True)
class ArmTerms:
    """What the contact response needs of N poses.

    Attributes
    ----------
    q : (N, nv) DH joint angles [rad].
    H : (N, nv, nv) joint-space inertia with the reflected rotor inertia [kg m^2].
    J : (N, 3, nv) linear rows of the impact point's Jacobian [m].
    hessian : (N, 3, nv, nv) ``d^2 p / dq_i dq_j`` of the impact point [m].
    gravity_stiffness : (N, nv, nv) ``dG/dq`` per unit gravity [N m/rad per m/s^2].
    base : BaseTerms or None (fixed base).
    """

    q: np.ndarray
    H: np.ndarray
    J: np.ndarray
    hessian: np.ndarray
    gravity_stiffness: np.ndarray
    base: BaseTerms | None = None

    @property
    def nv(self) -> int:
        return int(self.H.shape[-1])

    def take(self, index) -> ArmTerms:
        """The terms of the poses ``index`` (an index array into the N poses)."""
        idx = np.asarray(index, int)
        base = None if self.base is None else dataclasses.replace(
            self.base, **{f: getattr(self.base, f)[idx] for f in ("M", "J", "arm_base_inertia", "gravity_stiffness",
                                                                   "gravity_stiffness_full", "first_mode")})
        return ArmTerms(q=self.q[idx], H=self.H[idx], J=self.J[idx], hessian=self.hessian[idx],
                        gravity_stiffness=self.gravity_stiffness[idx], base=base)


def _symmetric(H: np.ndarray) -> np.ndarray:
    return np.triu(H) + np.swapaxes(np.triu(H, 1), -1, -2)


def _gravity_model(model: pin.Model) -> tuple[pin.Model, pin.Data]:
    """A copy of ``model`` under unit gravity along -z (its gradient scales with g)."""
    g = pin.Model(model)
    g.gravity.linear = np.array([0.0, 0.0, -1.0])
    return g, g.createData()


def _poses(robot: Robot, Q) -> np.ndarray:
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    if Q.ndim != 2 or Q.shape[1] != robot.nv or not np.all(np.isfinite(Q)):
        raise InputError(f"poses must be finite with shape (N, {robot.nv}) [rad], got shape {Q.shape}")
    return Q


def arm_terms(robot: Robot, Q, *, beam=None) -> ArmTerms:
    """:class:`ArmTerms` of the DH poses ``Q`` (N, nv) [rad]; with ``beam``
    (:class:`campaign.rig.beam.Beam`) the flexible base's :class:`BaseTerms` too."""
    Q = _poses(robot, Q)
    model, fid = robot.model, robot.impact_frame_id
    data = model.createData()
    gmodel, gdata = _gravity_model(model)
    N, nv = Q.shape
    H = np.empty((N, nv, nv))
    J = np.empty((N, 3, nv))
    hess = np.empty((N, 3, nv, nv))
    dG = np.empty((N, nv, nv))
    lwa = pin.LOCAL_WORLD_ALIGNED
    step = np.eye(nv) * HESSIAN_STEP
    for i, q in enumerate(Q):
        H[i] = pin.crba(model, data, q)
        J[i] = pin.computeFrameJacobian(model, data, q, fid, lwa)[:3]
        for k in range(nv):
            up = pin.computeFrameJacobian(model, data, q + step[k], fid, lwa)[:3]
            down = pin.computeFrameJacobian(model, data, q - step[k], fid, lwa)[:3]
            hess[i, :, :, k] = (up - down) / (2.0 * HESSIAN_STEP)
        dG[i] = pin.computeGeneralizedGravityDerivatives(gmodel, gdata, q)
    hess = 0.5 * (hess + np.swapaxes(hess, 2, 3))       # second derivatives commute
    base = None if beam is None else base_terms(robot, Q, beam)
    return ArmTerms(q=Q, H=_symmetric(H), J=J, hessian=hess, gravity_stiffness=dG, base=base)


def base_terms(robot: Robot, Q, beam) -> BaseTerms:
    """:class:`BaseTerms` of the arm at the DH poses ``Q`` on ``beam``'s tip body."""
    Q = _poses(robot, Q)
    body = beam.base_body()
    full = attach_to_floating_base(robot, body)
    # the same arm on a weightless base: the arm's own gravity gradient, which is what the
    # VES-II's F/T sensor passes to the emulated structure (the tip body's weight is not on it)
    alone = attach_to_floating_base(robot, BaseBody(mass=_TINY, inertia=_TINY * np.eye(3), mount=body.mount))
    model, fid = full.model, full.impact_frame_id
    data = model.createData()
    g_full, gd_full = _gravity_model(model)
    g_arm, gd_arm = _gravity_model(alone.model)
    N, nv = Q.shape
    nx = 6 + nv
    M = np.empty((N, nx, nx))
    J = np.empty((N, 3, nx))
    dG = np.empty((N, nx, nx))
    dG_full = np.empty((N, nx, nx))
    for i, q in enumerate(Q):
        qf = full.q_full(q)
        M[i] = pin.crba(model, data, qf)
        J[i] = pin.computeFrameJacobian(model, data, qf, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        dG_full[i] = pin.computeGeneralizedGravityDerivatives(g_full, gd_full, qf)
        dG[i] = pin.computeGeneralizedGravityDerivatives(g_arm, gd_arm, alone.q_full(q))
    M = _symmetric(M)
    Ms = np.asarray(beam.mass_matrix, float)
    Ks = np.asarray(beam.stiffness, float)
    first = np.array([math.sqrt(max(float(sla.eigh(Ks, Mb, eigvals_only=True)[0]), 0.0)) / (2.0 * math.pi)
                      for Mb in M[:, :6, :6]])
    return BaseTerms(M=M, J=J, arm_base_inertia=M[:, :6, :6] - Ms, gravity_stiffness=dG, gravity_stiffness_full=dG_full,
                     structure_mass=Ms, structure_stiffness=Ks, structure_damping=np.asarray(beam.damping, float),
                     first_mode=first)
