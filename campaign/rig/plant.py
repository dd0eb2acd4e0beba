"""The plant: PUMA 560 arm (Pinocchio) + joint friction with stick-slip + pendulum + contact.

State ``x = [q (nv), theta, v (nv), thetadot, P]``: joint angles and velocities, pendulum
angle and rate, and the running contact impulse ``P = int F dt`` (integrated with the
state, so the true impulse is exact to the integrator's accuracy).

Arm dynamics (Pinocchio ABA/CRBA, armature = reflected rotor inertia, gravity on):

    H(q) a + c(q, v) + g(q) = tau_servo + tau_friction + J_n^T F

with ``J_n = n^T J_lin`` the impact-point Jacobian projected on n.

Joint friction is Coulomb + viscous with a true stick phase (no regularisation): each
joint is in mode ``+1``/``-1`` (slipping, friction ``-(b v +- Tc)``) or ``0`` (stuck,
``a_j = 0``; the friction is whatever holds it, found from the constrained dynamics
``a = H^-1 (tau + S^T lambda)``, ``a_S = 0``). The integrator switches modes at located
events: a slipping joint sticks where its velocity crosses zero and the holding torque is
within the static limit; a stuck joint breaks away where the holding torque reaches it.

Contact (see :mod:`.contact`): penetration ``delta = r sin(theta) - n.(p_tip - p_tip0)``;
the force ``F`` pushes the tip along ``+n`` and the hammer along ``-n``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..robot import Robot
from .contact import Contact
from .pendulum import Pendulum

__all__ = ["FixedBasePlant"]


class FixedBasePlant:
    """Arm on a ground-fixed base, pendulum and contact: the right-hand side and helpers.

    Parameters
    ----------
    robot : Robot
    q0 : ndarray
        Pose at the first touch [rad] (the arm rests there before the impact).
    n : ndarray
        Unit impact direction, base frame.
    pendulum : Pendulum
    contact : Contact
    coulomb_scale, viscous_scale : float
        Multiply the drive file's joint-side Coulomb and viscous friction.
    gravity : float
        [m/s^2]; along -z of the base frame.
    """

    def __init__(self, robot: Robot, q0, n, pendulum: Pendulum, contact: Contact, *,
                 coulomb_scale: float, viscous_scale: float, gravity: float):
        self.robot = robot
        self.model = robot.model.copy()
        self.model.gravity.linear = np.array([0.0, 0.0, -gravity])
        self.data = self.model.createData()
        self.nv = self.model.nv
        self.fid = robot.impact_frame_id
        self.n = np.asarray(n, dtype=float)
        self.q0 = np.asarray(q0, dtype=float)
        self.pend = pendulum
        self.contact = contact
        self.viscous = viscous_scale * robot.viscous
        self.tc_pos = coulomb_scale * robot.coulomb_pos
        self.tc_neg = coulomb_scale * robot.coulomb_neg
        self.has_friction = bool(np.any(self.viscous > 0) or np.any(self.tc_pos > 0) or np.any(self.tc_neg > 0))
        self.gravity = gravity
        pin.framesForwardKinematics(self.model, self.data, self.q0)
        self.p_tip0 = np.array(self.data.oMf[self.fid].translation)
        # pendulum constants as plain floats (hot path)
        self._r = pendulum.radius
        self._Ip = pendulum.inertia
        self._mgl = pendulum.mgl
        self._k = contact.stiffness
        self._p = contact.exponent
        self._d = contact.damping
        nv = self.nv
        self.i_th = nv
        self.i_v = slice(nv + 1, 2 * nv + 1)
        self.i_thd = 2 * nv + 1
        self.i_P = 2 * nv + 2
        self.size = 2 * nv + 3
        # the integrator's view: which dofs can stick, which are the servo's, no emulator
        self.sticky = (self.tc_pos > 0) | (self.tc_neg > 0)
        self.arm_q = slice(0, nv)
        self.arm_v = self.i_v
        self.emulator_period = None
        # does this Pinocchio fill both triangles of the CRBA matrix? (checked once)
        H = pin.crba(self.model, self.data, self.q0)
        self._crba_full = bool(np.allclose(H, H.T))
        # free joints of each stuck set, precomputed (tuple(stuck) -> list of free indices)
        import itertools
        self._free_of = {k: {c: [i for i in range(nv) if i not in c] for c in itertools.combinations(range(nv), k)}
                         for k in range(nv + 1)}

    # -- kinematics ---------------------------------------------------------------------
    def tip(self, q):
        """(s, J_n): tip displacement along n from the first-touch pose [m] and ``n^T J_lin``."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        p = pin.updateFramePlacement(model, data, self.fid).translation
        Jn = pin.getFrameJacobian(model, data, self.fid, pin.LOCAL_WORLD_ALIGNED)[:3].T @ self.n
        s = float(self.n @ (p - self.p_tip0))
        return s, Jn

    def gap(self, x):
        """Penetration ``delta`` [m] (> 0 in contact) and its rate [m/s]."""
        nv = self.nv
        s, Jn = self.tip(x[:nv])
        th, thd = x[nv], x[self.i_thd]
        delta = self._r * math.sin(th) - s
        ddelta = self._r * math.cos(th) * thd - float(Jn @ x[self.i_v])
        return delta, ddelta, Jn

    def contact_force(self, delta, ddelta, v0):
        if delta <= 0.0:
            return 0.0
        f = self._k * delta**self._p * (1.0 + self._d * ddelta / v0)
        return f if f > 0.0 else 0.0

    def gravity_torque(self, q):
        """``g(q)`` [N m] (RNEA at rest)."""
        return np.array(pin.computeGeneralizedGravity(self.model, self.data, q))

    # -- dynamics -----------------------------------------------------------------------
    def coulomb(self, modes):
        """Coulomb torque vector of a mode assignment (+Tc_pos, -Tc_neg, 0 when stuck) [N m];
        the friction on slipping joints is ``-(b v + coulomb)``."""
        return np.where(modes > 0, self.tc_pos, np.where(modes < 0, -self.tc_neg, 0.0))

    def friction_slip(self, v, modes):
        """Friction torque of slipping joints (zero on stuck ones) [N m]."""
        return -(self.viscous * v) - self.coulomb(modes)

    def holding_torque(self, q, v, tau, stuck):
        """Friction torque ``lam`` that keeps the ``stuck`` joints still, and the constrained
        accelerations: ``H a + c + g = tau + S^T lam`` with ``a_S = 0``, so
        ``a_F = H_FF^-1 (tau - c - g)_F`` and ``lam = H_SF a_F - (tau - c - g)_S``.
        The free block is solved explicitly (1 or 2 joints) because NumPy's small-matrix
        calls cost more than the dynamics here."""
        model, data = self.model, self.data
        if not len(stuck):
            return np.zeros(0), pin.aba(model, data, q, v, tau)
        H = pin.crba(model, data, q)
        if not self._crba_full:
            H = np.triu(H) + np.triu(H, 1).T
        b = tau - pin.nonLinearEffects(model, data, q, v)
        return self._constrained(H, b, stuck)

    def _constrained(self, H, b, stuck):
        """Solve ``H a = b + S^T lam`` with ``a_S = 0`` for (lam, a)."""
        free = self._free_of[len(stuck)][tuple(stuck)]
        a = np.zeros(self.nv)
        if len(free) == 1:
            i = free[0]
            a[i] = b[i] / H[i, i]
        elif len(free) == 2:
            i, j = free
            det = H[i, i] * H[j, j] - H[i, j] * H[j, i]
            a[i] = (H[j, j] * b[i] - H[i, j] * b[j]) / det
            a[j] = (H[i, i] * b[j] - H[j, i] * b[i]) / det
        elif len(free) > 2:
            a[free] = np.linalg.solve(H[np.ix_(free, free)], b[free])
        lam = H[stuck] @ a - b[stuck]
        return lam, a

    def tip_speed(self, x):
        """Velocity of the impact point along n [m/s]."""
        _, Jn = self.tip(x[:self.nv])
        return float(Jn @ x[self.i_v])

    def rest_wrench(self):
        """F/T reading with the arm at rest on its commanded pose."""
        from .sensors import base_wrench
        z = np.zeros(self.nv)
        return base_wrench(self, self.q0, z, z, 0.0)

    def mount_wrench(self, x, xd, F, t=None):
        """Wrench of the arm on its mounting (base F/T sensor): (force [N], moment [N m])."""
        from .sensors import base_wrench
        nv = self.nv
        return base_wrench(self, x[:nv], x[self.i_v], xd[self.i_v], F)

    def servo(self, tau_arm):
        """Generalised servo torque from the arm's joint torques (identity for a fixed base)."""
        return tau_arm

    def rhs(self, x, tau_servo, coulomb, stuck, contact_v0, caught, t=0.0):
        """State derivative.

        Parameters
        ----------
        x : ndarray
        tau_servo : ndarray
            Held servo torque incl. gravity compensation [N m].
        coulomb : ndarray
            Coulomb torque of the current friction modes (:meth:`coulomb`).
        stuck : ndarray of int
            Indices of stuck joints (precomputed from ``modes``).
        contact_v0 : float or None
            Approach speed at first touch while in contact, else None.
        caught : bool
            The hammer has been caught after its rebound (held still).
        t : float
            Time [s] (unused on a fixed base; a prescribed base motion needs it).
        """
        nv = self.nv
        q = x[:nv]
        v = x[self.i_v]
        th = x[nv]
        thd = x[self.i_thd]
        tau = tau_servo - self.viscous * v - coulomb if self.has_friction else tau_servo.copy()
        F = 0.0
        if contact_v0 is not None:
            delta, ddelta, Jn = self.gap(x)
            F = self.contact_force(delta, ddelta, contact_v0)
            tau = tau + Jn * F
        if caught:
            thdd = 0.0
        else:
            thdd = (-self._mgl * math.sin(th) - F * self._r * math.cos(th)) / self._Ip
        if len(stuck) == nv:
            a = np.zeros(nv)   # every joint held by friction
        elif len(stuck):
            _, a = self.holding_torque(q, v, tau, stuck)
        else:
            a = pin.aba(self.model, self.data, q, v, tau)
        xd = np.empty(self.size)
        xd[:nv] = v
        xd[nv] = thd
        xd[self.i_v] = a
        xd[self.i_thd] = thdd
        xd[self.i_P] = F
        return xd

    # -- diagnostics --------------------------------------------------------------------
    def energy(self, x, contact_v0=None):
        """Mechanical energy of arm, pendulum and contact spring [J] (gravity included)."""
        nv = self.nv
        q, v = x[:nv], x[self.i_v]
        th, thd = x[nv], x[self.i_thd]
        H = pin.crba(self.model, self.data, q)
        ke = 0.5 * float(v @ H @ v) + 0.5 * self._Ip * thd**2
        pe = float(pin.computePotentialEnergy(self.model, self.data, q)) + self._mgl * (1.0 - math.cos(th))
        delta = self._r * math.sin(th) - self.tip(q)[0]
        return ke + pe + float(self.contact.energy(delta))
