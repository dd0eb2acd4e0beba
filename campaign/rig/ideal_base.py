"""Ideal coupling: the beam's spring and damper acting on the free-flyer base.

In the ideal (exactly coupled) mode of the flexible rig, arm and structure are integrated
as one system: the Pinocchio free-flyer model of
:func:`campaign.model.robot.floating.attach_to_floating_base` with the base body of :meth:`campaign.rig.beam.Beam.base_body`
(beam share + platform, frame = beam tip frame) and, as the external force on the base
joint, the wrench of :class:`IdealBase`. It is the reference against which the VES-II
loop (:mod:`campaign.rig.ves`) is measured, so it removes the static load exactly as the
loop does:

* the loop integrates ``M_s x'' + B x' + K x = w_meas - w_static`` with a gravity-free
  structure (microgravity emulation) and ``w_static`` the arm's load measured at rest in
  the platform frame;
* here the base body is cancelled out of gravity (its weight is compensated in every
  pose) and the constant ``-w_static`` acts in the base frame, so the base obeys the same
  equation with ``w_meas`` the arm's actual wrench on the base.

The beam's generalised force on the pose coordinates ``x = (Delta p, theta)`` (initial
base frame axes, rotation vector of ``R0^T R``) is ``Q = -K x - B x'``. It is applied as
the physical wrench whose virtual work matches it exactly (``f = R_rel^T Q_u``, ``n =
J_log3(R_rel)^T Q_theta``, since ``Delta p' = R_rel v`` and ``theta' = J_log3 omega``),
so the spring stores exactly ``x^T K x / 2`` (:meth:`IdealBase.potential`) and the
damper only dissipates, whatever the rotation.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..core.errors import InputError
from ..model.robot import Robot
from .beam import Beam

__all__ = ["IdealBase", "static_arm_wrench"]


def _vec(a, n: int, what: str) -> np.ndarray:
    v = np.asarray(a, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InputError(f"{what} must be {n} finite values, got {a!r}")
    return v


def static_arm_wrench(robot: Robot, q_arm, gravity, mount: pin.SE3 | None = None,
                      base_rotation=None) -> np.ndarray:
    """Wrench of an arm at rest on its base under gravity: what the base F/T sensor reads.

    At rest the arm is in equilibrium under gravity and the base's support, so its wrench on
    the base is its own weight: ``f = m R^T g``, ``n = c x f`` with ``c`` the arm's centre of
    mass, expressed in the base frame about the base origin.

    Parameters
    ----------
    robot : Robot
        The arm (fixed-base model, its base frame at the mount).
    q_arm : array_like, shape (nq,)
        Joint angles [rad].
    gravity : array_like, shape (3,)
        Gravity in world axes [m/s^2], e.g. ``(0, 0, -9.81)``.
    mount : pinocchio.SE3, optional
        Placement of the arm's base frame in the base frame (default identity).
    base_rotation : (3, 3) array, optional
        Base orientation in the world (default identity).

    Returns
    -------
    ndarray, shape (6,)
        ``(f [N], n [N m])`` in the base frame about the base origin.
    """
    model = robot.model
    data = model.createData()
    q = robot.check_q(q_arm)
    com_arm = pin.centerOfMass(model, data, q)
    mass = float(data.mass[0])
    mount = pin.SE3.Identity() if mount is None else mount
    R = np.eye(3) if base_rotation is None else np.asarray(base_rotation, dtype=float)
    g = _vec(gravity, 3, "gravity")
    f = mass * (R.T @ g)
    c = mount.act(np.asarray(com_arm))
    return np.concatenate([f, np.cross(c, f)])


class IdealBase:
    """Spring, damper and static-load removal of the beam on the free-flyer base.

    Parameters
    ----------
    beam : Beam
        The structure (``K``, ``B``; ``M_s`` is the free-flyer's base body, from
        :meth:`Beam.base_body`).
    w_static : array_like, shape (6,), optional
        The arm's wrench on the base at rest (base frame, about the base origin; see
        :func:`static_arm_wrench`), removed from then on. Zero by default.
    gravity : array_like, shape (3,), optional
        World gravity the simulation applies [m/s^2]; the base body's own weight is
        cancelled with it (microgravity of the structure). Zero by default.
    base_pose0 : pinocchio.SE3, optional
        Initial (undeformed) pose of the base frame in the world (identity by default).

    Notes
    -----
    The returned wrench is in the base (free-flyer joint) LOCAL frame about its origin, as
    Pinocchio's ``aba``/``rnea`` expect for ``fext`` of the base joint.
    """

    def __init__(self, beam: Beam, w_static=None, gravity=None, base_pose0: pin.SE3 | None = None):
        if not isinstance(beam, Beam):
            raise InputError(f"IdealBase needs a Beam, got {type(beam).__name__}")
        self.beam = beam
        self.K = np.array(beam.stiffness)
        self.B = np.array(beam.damping)
        self.w_static = np.zeros(6) if w_static is None else _vec(w_static, 6, "static wrench").copy()
        self.gravity = np.zeros(3) if gravity is None else _vec(gravity, 3, "gravity").copy()
        self.pose0 = pin.SE3.Identity() if base_pose0 is None else base_pose0
        self._R0T = np.array(self.pose0.rotation).T
        self._p0 = np.array(self.pose0.translation)
        body = beam.spatial_inertia
        # precomputed for wrench_array: [K B] on (x, x'), and the weight of the base body
        # (m R^T g at the centre of mass c) as [m I; m [c]x] acting on R^T g
        self._KB = np.hstack([self.K, self.B])
        self._Wg = np.vstack([body.mass * np.eye(3), body.mass * pin.skew(np.array(body.lever))])
        self._identity0 = bool(np.allclose(self._R0T, np.eye(3), rtol=0, atol=0))
        self._z = np.zeros(12)

    def displacement(self, q_base) -> np.ndarray:
        """Beam tip displacement ``x = (R0^T (p - p0), log3(R0^T R))`` [m, rad] of a base
        configuration ``q_base = (p, quaternion xyzw)`` (7 values)."""
        q = np.asarray(q_base, dtype=float)
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix()
        return np.concatenate([self._R0T @ (q[:3] - self._p0), pin.log3(self._R0T @ R)])

    def potential(self, q_base) -> float:
        """Elastic energy of the beam, ``x^T K x / 2`` [J]."""
        x = self.displacement(q_base)
        return 0.5 * float(x @ self.K @ x)

    def wrench_array(self, q_base, v_base, out: np.ndarray | None = None) -> np.ndarray:
        """The wrench on the base (6,), base frame: spring + damper - static load + the base
        body's weight cancelled.

        Parameters
        ----------
        q_base : array_like, shape (7,)
            Free-flyer configuration: position [m], unit quaternion (x, y, z, w).
        v_base : array_like, shape (6,)
            Free-flyer velocity in the base frame: linear [m/s], angular [rad/s].
        out : ndarray, shape (6,), optional
            Where to write the result.

        Returns
        -------
        ndarray, shape (6,)
            Force [N] and moment about the base origin [N m], base frame.
        """
        q = np.asarray(q_base, dtype=float)
        v = np.asarray(v_base, dtype=float)
        R = pin.XYZQUATToSE3(q).rotation
        if self._identity0:
            R_rel = R
            dp = q[:3] - self._p0
        else:
            R_rel = self._R0T @ R
            dp = self._R0T @ (q[:3] - self._p0)
        Jl = pin.Jlog3(R_rel)                       # theta' = Jl omega
        z = self._z
        z[0:3] = dp
        z[3:6] = pin.log3(R_rel)
        z[6:9] = R_rel @ v[:3]
        z[9:12] = Jl @ v[3:]
        Q = self._KB @ z                            # = K x + B x'
        w = self._Wg @ (self.gravity @ R)           # weight of the base body, base frame
        w += self.w_static
        if out is None:
            out = np.empty(6)
        out[0:3] = Q[0:3] @ R_rel                   # R_rel^T Q_u
        out[3:6] = Q[3:6] @ Jl                      # Jl^T Q_theta
        np.subtract(-out, w, out=out)
        return out

    def wrench(self, q_base, v_base) -> pin.Force:
        """:meth:`wrench_array` as a :class:`pinocchio.Force` (base joint LOCAL frame)."""
        w = self.wrench_array(q_base, v_base)
        return pin.Force(w[:3], w[3:])
