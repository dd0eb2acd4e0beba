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

Contact (see :mod:`campaign.rig.contact`): penetration ``delta = r sin(theta) - n.(p_tip - p_tip0)``;
the force ``F`` pushes the tip along ``+n`` and the hammer along ``-n``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin

from ..model.robot import Robot
from .contact import ContactLaw
from .pendulum import Pendulum

__all__ = ["FixedBasePlant", "FrictionState", "base_wrench", "NO_HOLDING"]

#: the holding torques of a step where no joint is stuck (none)
NO_HOLDING = np.zeros(0)
_LWA = pin.LOCAL_WORLD_ALIGNED
#: ABA's world-frame convention: the one the campaign's trials are integrated with (the
#: local convention differs from it in the last digits; the trial loop's kernel,
#: :mod:`.kernels`, uses it too)
_WORLD = pin.Convention.WORLD


def unit_axis(n) -> tuple[int, float] | None:
    """``(i, sign)`` when the unit vector ``n`` is ``sign * e_i`` (the paper's impact
    direction is ``-x``), else None. Projections on such an ``n`` are one signed component:
    ``n @ p = sign * p[i]`` exactly (the other products are exact zeros), at a tenth of the
    cost of a NumPy product on the integrator's hot path."""
    nz = np.flatnonzero(np.asarray(n, dtype=float))
    if nz.size == 1 and abs(float(n[nz[0]])) == 1.0:
        return int(nz[0]), float(n[nz[0]])
    return None


class FrictionState:
    """A stick/slip mode assignment and what the right-hand side needs of it, computed once
    per mode change instead of at every evaluation.

    Attributes
    ----------
    modes : ndarray of int
        Per dof: ``+1``/``-1`` slipping (friction ``-(b v +- Tc)``), ``0`` stuck.
    stuck, free : ndarray of int
        Indices of the stuck and of the moving dofs.
    coulomb : ndarray
        Coulomb torque of the slipping dofs (:meth:`FixedBasePlant.coulomb`) [N m].
    all_stuck, none_stuck : bool
    stuck_mask : ndarray of bool
        ``modes == 0``.
    reduced : tuple or None
        ``(model, data)`` of the arm with the stuck joints locked at their angles (Pinocchio
        ``buildReducedModel``), for a partly stuck arm: its ABA gives the free joints'
        accelerations of the constrained dynamics directly.
    """

    __slots__ = ("modes", "stuck", "free", "coulomb", "all_stuck", "none_stuck", "reduced", "iv_free", "key",
                 "stuck_limits", "slipping", "stuck_mask", "stuck_l", "free_l", "coulomb_f")

    def __init__(self, modes, coulomb, iv0: int, tc_pos=None, tc_neg=None, sticky=None):
        self.modes = np.asarray(modes, dtype=int)
        self.stuck_mask = self.modes == 0
        self.stuck = np.flatnonzero(self.stuck_mask)
        self.free = np.flatnonzero(self.modes != 0)
        self.coulomb = coulomb
        self.all_stuck = self.free.size == 0
        self.none_stuck = self.stuck.size == 0
        self.reduced = None
        self.iv_free = iv0 + self.free
        self.key = tuple(self.modes.tolist())
        # the same as Python lists, for the trial loop's float kernels (:mod:`.kernels`)
        self.stuck_l, self.free_l = self.stuck.tolist(), self.free.tolist()
        self.coulomb_f = np.asarray(coulomb, dtype=float).tolist()
        # plain-float views for the integrator's per-step checks (3-6 dofs: Python floats
        # are cheaper than NumPy calls): static limits (pushing +, pushing -) of each stuck
        # dof, and (dof, mode, state index of its velocity) of each slipping sticky dof
        if tc_pos is not None:
            self.stuck_limits = [(float(tc_pos[j]), float(tc_neg[j])) for j in self.stuck.tolist()]
            self.slipping = [(j, int(self.modes[j]), iv0 + j) for j in self.free.tolist() if sticky[j]]
        else:
            self.stuck_limits, self.slipping = [], []

    def violations(self, lam) -> list:
        """Per stuck dof, ``|lam| - limit`` (> 0 where the holding torque ``lam`` exceeds the
        static friction it pushes against)."""
        values = lam.tolist() if isinstance(lam, np.ndarray) else lam
        return [(-x - tp) if x < 0 else (x - tn) for x, (tp, tn) in zip(values, self.stuck_limits, strict=True)]


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
    contact : ContactLaw
    coulomb_scale, viscous_scale : float
        Multiply the drive file's joint-side Coulomb and viscous friction.
    gravity : float
        [m/s^2]; along -z of the base frame.
    """

    def __init__(self, robot: Robot, q0, n, pendulum: Pendulum, contact: ContactLaw, *,
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
        self.gravity = gravity
        pin.framesForwardKinematics(self.model, self.data, self.q0)
        self.p_tip0 = np.array(self.data.oMf[self.fid].translation)
        self._s0 = float(self.n @ self.p_tip0)
        # live reference: Pinocchio hands data.oMf's elements by reference, and the frame
        # Jacobian call in tip() updates it
        self._M_tip = self.data.oMf[self.fid]
        self._axis = unit_axis(self.n)
        # (tau_servo, friction state, tau_servo - Coulomb): the part of the joint torque that
        # is constant between servo ticks and mode changes, kept for the RK4 stages
        self._tau0 = (None, None, None)
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
        self._free_of = {k: {c: [i for i in range(nv) if i not in c] for c in itertools.combinations(range(nv), k)}
                         for k in range(nv + 1)}
        # Pinocchio joint id of each dof, for locking stuck joints (buildReducedModel)
        self._jid_of_dof = {self.model.joints[j].idx_v: j for j in range(1, self.model.njoints)}
        self._reduced_cache = {}
        self._lock_model = self.model    # reduced models lock stuck joints of this model

    # -- kinematics ---------------------------------------------------------------------
    def tip(self, q):
        """(s, J_n): tip displacement along n from the first-touch pose [m] and ``n^T J_lin``."""
        # one call gives the frame's world-aligned Jacobian and updates its placement
        J = pin.computeFrameJacobian(self.model, self.data, q, self.fid, _LWA)
        p = self._M_tip.translation
        if self._axis is not None:       # n = sign e_i: the same numbers as the products below
            i, sign = self._axis
            return (-float(p[i]) if sign < 0 else float(p[i])) - self._s0, (-J[i] if sign < 0 else J[i])
        n = self.n
        return float(n @ p) - self._s0, n @ J[:3]

    def gap(self, x):
        """Penetration ``delta`` [m] (> 0 in contact), its rate [m/s] and ``J_n``."""
        nv = self.nv
        s, Jn = self.tip(x[:nv])
        th, thd = x[nv], x[self.i_thd]
        return (self._r * math.sin(th) - s, self._r * math.cos(th) * thd - float(Jn @ x[self.i_v]), Jn)

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

    def friction_state(self, modes, q) -> FrictionState:
        """The :class:`FrictionState` of mode assignment ``modes`` with the arm at ``q``.

        On a partly stuck fixed-base arm the stuck joints are locked at their current angles
        in a reduced Pinocchio model (cached: a stuck joint does not move, so the same model
        serves until the modes change)."""
        fs = FrictionState(modes, self.coulomb(np.asarray(modes)), self.i_v.start, self.tc_pos, self.tc_neg,
                           self.sticky)
        if self._locks_stuck_joints and not (fs.all_stuck or fs.none_stuck):
            key = (fs.key, np.asarray(q, dtype=float)[fs.stuck].tobytes())
            red = self._reduced_cache.get(key)
            if red is None:
                rm = pin.buildReducedModel(self._lock_model, [self._jid_of_dof[int(j)] for j in fs.stuck],
                                           np.asarray(q, dtype=float))
                red = (rm, rm.createData())
                if len(self._reduced_cache) >= 64:
                    self._reduced_cache.clear()
                self._reduced_cache[key] = red
            fs.reduced = red
        return fs

    #: a fixed-base arm's constrained dynamics use reduced models (see :meth:`constrained`)
    _locks_stuck_joints = True

    def constrained(self, q, v, tau, fs: FrictionState):
        """Friction ``lam`` holding the stuck joints and the accelerations ``a`` of the
        constrained dynamics (``H a + c + g = tau + S^T lam``, ``a_S = 0``) for the modes
        ``fs``: the free joints from ABA on the model with the stuck ones locked, then
        ``lam = rnea(q, v, a)_S - tau_S``. Same solution as :meth:`holding_torque`, with
        two Pinocchio calls instead of a CRBA, the bias terms and a small solve."""
        model, data = self.model, self.data
        if fs.none_stuck:
            return NO_HOLDING, pin.aba(model, data, q, v, tau, _WORLD)
        a = np.zeros(self.nv)
        if not fs.all_stuck:
            rm, rd = fs.reduced
            free = fs.free
            a[free] = pin.aba(rm, rd, q[free], v[free], tau[free])
        stuck = fs.stuck
        return pin.rnea(model, data, q, v, a)[stuck] - tau[stuck], a

    def _loads(self, x, tau_servo, fs: FrictionState, contact_v0, with_gap: bool):
        """Generalised torque on the arm (held servo torque, friction of the slipping joints,
        contact force through ``J_n``), the contact force ``F`` and, if asked or in contact,
        the gap ``(delta, ddelta)`` (else None)."""
        c = self._tau0
        if c[0] is not tau_servo or c[1] is not fs:
            c = self._tau0 = (tau_servo, fs, tau_servo - fs.coulomb)
        tau = c[2] - self.viscous * x[self.i_v]
        if contact_v0 is None and not with_gap:
            return tau, 0.0, None
        delta, ddelta, Jn = self.gap(x)
        F = 0.0 if contact_v0 is None else self.contact_force(delta, ddelta, contact_v0)
        if F > 0.0:
            tau += Jn * F
        return tau, F, (delta, ddelta)

    def _derivative(self, x, a, F: float, caught: bool):
        """State derivative from the arm's accelerations ``a`` and the contact force ``F``."""
        nv = self.nv
        xd = np.empty(self.size)
        xd[:nv + 1] = x[nv + 1:2 * nv + 2]      # q' = v, theta' = thetadot
        xd[nv + 1:2 * nv + 1] = a
        if caught:
            xd[self.i_thd] = 0.0
        else:
            th = x[nv]
            xd[self.i_thd] = (-self._mgl * math.sin(th) - F * self._r * math.cos(th)) / self._Ip
        xd[self.i_P] = F
        return xd

    def holding(self, x, tau_servo, fs: FrictionState, contact_v0, t=0.0):
        """``(lam, a)`` of :meth:`constrained` at state ``x`` with the held servo torque, the
        friction of the slipping joints and the contact force (for the stick-slip events)."""
        self._t = t
        tau, _, _ = self._loads(x, tau_servo, fs, contact_v0, False)
        return self.constrained(x[:self.nv], x[self.i_v], tau, fs)

    def evaluate(self, x, tau_servo, fs: FrictionState, contact_v0, caught, t=0.0):
        """Everything the integrator needs at one state, from one dynamics solve: the state
        derivative (:meth:`rhs`), the stuck joints' holding torques ``lam``
        (:meth:`holding`) and the contact gap ``(delta, ddelta)`` (None once the hammer is
        caught and out of contact). At a step's end these serve the event checks, the
        emulator's F/T sample and, when nothing changes at the tick, the next step's first
        RK4 stage."""
        self._t = t
        tau, F, gap = self._loads(x, tau_servo, fs, contact_v0, not caught)
        lam, a = self.constrained(x[:self.nv], x[self.i_v], tau, fs)
        return self._derivative(x, a, F, caught), lam, gap

    def rhs(self, x, tau_servo, fs: FrictionState, contact_v0, caught, t=0.0):
        """State derivative (the RK4 stages: :meth:`evaluate` without the holding torques).

        Parameters
        ----------
        x : ndarray
        tau_servo : ndarray
            Held servo torque incl. gravity compensation [N m].
        fs : FrictionState
            Current stick/slip modes (:meth:`friction_state`).
        contact_v0 : float or None
            Approach speed at first touch while in contact, else None.
        caught : bool
            The hammer has been caught after its rebound (held still).
        t : float
            Time [s] (a prescribed base motion needs it).
        """
        # the RK4 stages' call (~2000 per trial): _loads and _derivative inlined, the same
        # operations in the same order (a Python call costs ~0.3 us, a fifth of this body)
        self._t = t
        c = self._tau0
        if c[0] is not tau_servo or c[1] is not fs:
            c = self._tau0 = (tau_servo, fs, tau_servo - fs.coulomb)
        nv = self.nv
        v = x[nv + 1:2 * nv + 1]
        tau = c[2] - self.viscous * v
        F = 0.0
        if contact_v0 is not None:
            delta, ddelta, Jn = self.gap(x)
            F = self.contact_force(delta, ddelta, contact_v0)
            if F > 0.0:
                tau += Jn * F
        a = self._accel(x[:nv], v, tau, fs)
        xd = np.empty(self.size)
        xd[:nv + 1] = x[nv + 1:2 * nv + 2]      # q' = v, theta' = thetadot
        xd[nv + 1:2 * nv + 1] = a
        if caught:
            xd[self.i_thd] = 0.0
        else:
            th = x[nv]
            xd[self.i_thd] = (-self._mgl * math.sin(th) - F * self._r * math.cos(th)) / self._Ip
        xd[self.i_P] = F
        return xd

    def _accel(self, q, v, tau, fs: FrictionState):
        """Accelerations of the constrained dynamics (:meth:`constrained` without ``lam``):
        ABA on the full model, on the model with the stuck joints locked, or zero."""
        if fs.none_stuck:
            return pin.aba(self.model, self.data, q, v, tau, _WORLD)
        a = np.zeros(self.nv)
        if not fs.all_stuck:
            rm, rd = fs.reduced
            free = fs.free
            a[free] = pin.aba(rm, rd, q[free], v[free], tau[free])
        return a

    def holding_torque(self, q, v, tau, stuck):
        """Friction torque ``lam`` that keeps the ``stuck`` joints still, and the constrained
        accelerations: ``H a + c + g = tau + S^T lam`` with ``a_S = 0``, so
        ``a_F = H_FF^-1 (tau - c - g)_F`` and ``lam = H_SF a_F - (tau - c - g)_S``.
        The integrator uses :meth:`constrained` (reduced-model ABA); this CRBA block solve is
        its independent reference in the tests."""
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
        elif len(free) == 3 and self.nv == 3:
            # the whole (3 x 3, symmetric positive definite) system by cofactors: NumPy's
            # solve costs ~10 us of call overhead on a matrix this small
            (h00, h01, h02), (h10, h11, h12), (h20, h21, h22) = H.tolist()
            b0, b1, b2 = b.tolist()
            c00 = h11 * h22 - h12 * h21
            c01 = h12 * h20 - h10 * h22
            c02 = h10 * h21 - h11 * h20
            det = h00 * c00 + h01 * c01 + h02 * c02
            a[0] = (b0 * c00 + b1 * (h02 * h21 - h01 * h22) + b2 * (h01 * h12 - h02 * h11)) / det
            a[1] = (b0 * c01 + b1 * (h00 * h22 - h02 * h20) + b2 * (h02 * h10 - h00 * h12)) / det
            a[2] = (b0 * c02 + b1 * (h01 * h20 - h00 * h21) + b2 * (h00 * h11 - h01 * h10)) / det
            return NO_HOLDING, a
        elif len(free) > 2:
            a[free] = np.linalg.solve(H[np.ix_(free, free)], b[free])
        if not len(stuck):
            return NO_HOLDING, a
        lam = H[stuck] @ a - b[stuck]
        return lam, a

    def tip_speed(self, x):
        """Velocity of the impact point along n [m/s]."""
        _, Jn = self.tip(x[:self.nv])
        return float(Jn @ x[self.i_v])

    def rest_wrench(self):
        """F/T reading with the arm at rest on its commanded pose."""
        z = np.zeros(self.nv)
        return base_wrench(self, self.q0, z, z, 0.0)

    def mount_wrench(self, x, xd, F, t=None):
        """Wrench of the arm on its mounting (base F/T sensor): (force [N], moment [N m])."""
        nv = self.nv
        return base_wrench(self, x[:nv], x[self.i_v], xd[self.i_v], F)

    def servo(self, tau_arm):
        """Generalised servo torque from the arm's joint torques (identity for a fixed base)."""
        return tau_arm

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


def base_wrench(plant: FixedBasePlant, q, v, a, F):
    """Wrench of the arm on its mounting, base frame, about the base origin: (force [N],
    moment [N m]). Newton-Euler (RNEA) with the contact force as an external force on the
    link that carries the impact point; the arm's weight is included (the sensor reads it)."""
    model, data = plant.model, plant.data
    jid = model.frames[plant.fid].parentJoint
    placement = model.frames[plant.fid].placement
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    pin.forwardKinematics(model, data, q)
    R = data.oMi[jid].rotation
    f_local = R.T @ (plant.n * F)
    r = placement.translation
    torque = np.array([r[1] * f_local[2] - r[2] * f_local[1], r[2] * f_local[0] - r[0] * f_local[2],
                       r[0] * f_local[1] - r[1] * f_local[0]])
    fext[jid] = pin.Force(f_local, torque)
    pin.rnea(model, data, q, v, a, fext)
    w = data.oMi[1].act(data.f[1])
    return -np.array(w.linear), -np.array(w.angular)
