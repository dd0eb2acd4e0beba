"""The arm on the flexible long-reach base: ideal coupling and the VES-II emulation loop.

Both plants reuse the fixed-base machinery (:class:`.plant.FixedBasePlant`: pendulum,
contact, stick-slip friction, servo) on the Pinocchio free-flyer model of base + arm
(:func:`campaign.model.robot.floating.attach_to_floating_base`, base body
:meth:`.beam.Beam.base_body`: platform + the beam's tip share).

:class:`IdealCouplingPlant` (``ves.mode = ideal``)
    Arm and structure integrated as one system: the free-flyer base carries the beam's
    spring and damper (:class:`.ideal_base.IdealBase`, static load removed). The base
    configuration is integrated in exponential coordinates about the initial pose,
    ``(p, r)`` with ``R = exp3(r)``, so RK4 works on a flat state: ``p' = R v`` and
    ``r' = Jlog3(R) omega`` for the free-flyer's body twist ``(v, omega)``. Two more states
    integrate the contact impulse's linear (``P``) and angular (``S = int p_c x n F dt``,
    about the world origin) parts, for the momentum balance.

:class:`VesLoopPlant` (``ves.mode = loop``)
    What the VES-II does: the arm stands on the platform, whose motion is prescribed. At
    every emulator tick the F/T wrench of the arm on the platform is sampled and handed to
    the structure model (:class:`.ves.VesLoop`: structure under the measured wrench, static
    load removed, latency, finite-bandwidth platform); within a tick the platform follows
    its exact closed-form response (:meth:`.ves.VesLoop.platform_at`). The arm's joint
    accelerations come from the free-flyer model with the base acceleration given:
    ``H_mm a_m = tau_m - rnea(q, v, [a_b, 0])_m``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..model.robot import Robot
from ..model.robot.floating import attach_to_floating_base
from .beam import Beam
from .contact import ContactLaw
from .ideal_base import IdealBase, static_arm_wrench
from .pendulum import Pendulum
from .plant import NO_HOLDING, FixedBasePlant
from .ves import VesLoop

__all__ = ["IdealCouplingPlant", "VesLoopPlant", "platform_free_flyer"]


def _quat_of_rotvec(r):
    """Unit quaternion (x, y, z, w) of a rotation vector."""
    return _quat_of_rotvec_xyz(float(r[0]), float(r[1]), float(r[2]))


def _quat_of_rotvec_xyz(rx: float, ry: float, rz: float):
    """:func:`_quat_of_rotvec` of the components (Python floats)."""
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    k = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(0.5 * angle) / angle
    return k * rx, k * ry, k * rz, math.cos(0.5 * angle)


def platform_free_flyer(pose, twist, accel):
    """Free-flyer configuration (7), body twist (6) and body acceleration (6) of a
    small-angle platform state: :func:`.ves.platform_motion` without the object churn.

    Evaluated twice per RK4 step of a flexible trial: after Pinocchio's ``exp3`` and
    ``Jexp3`` the 3-vector algebra is done in Python floats (three times cheaper than NumPy
    calls on 3-vectors), ``v = R^T v_w``, ``w = Jexp3(r) r'``, ``a = R^T a_w - w x v``,
    ``alpha = Jexp3(r) r''``; the three come out as tuples of floats, which the trial
    loop's kernel writes straight into its buffers (NumPy takes them as it takes arrays)."""
    return _free_flyer_of_rows(pose.tolist(), twist.tolist(), accel.tolist(), pose[3:])


def _free_flyer_of_rows(pose, twist, accel, r):
    """:func:`platform_free_flyer` of the platform state as lists of floats and its
    rotation vector ``r`` as an array (what ``pin.exp3`` takes)."""
    p0, p1, p2, rx, ry, rz = pose
    t0, t1, t2, t3, t4, t5 = twist
    a0, a1, a2, a3, a4, a5 = accel
    (R00, R01, R02), (R10, R11, R12), (R20, R21, R22) = pin.exp3(r).tolist()
    (J00, J01, J02), (J10, J11, J12), (J20, J21, J22) = pin.Jexp3(r).tolist()
    v0 = R00 * t0 + R10 * t1 + R20 * t2
    v1 = R01 * t0 + R11 * t1 + R21 * t2
    v2 = R02 * t0 + R12 * t1 + R22 * t2
    w0 = J00 * t3 + J01 * t4 + J02 * t5
    w1 = J10 * t3 + J11 * t4 + J12 * t5
    w2 = J20 * t3 + J21 * t4 + J22 * t5
    qx, qy, qz, qw = _quat_of_rotvec_xyz(rx, ry, rz)
    q = (p0, p1, p2, qx, qy, qz, qw)
    v = (v0, v1, v2, w0, w1, w2)
    a = (R00 * a0 + R10 * a1 + R20 * a2 - (w1 * v2 - w2 * v1),
         R01 * a0 + R11 * a1 + R21 * a2 - (w2 * v0 - w0 * v2),
         R02 * a0 + R12 * a1 + R22 * a2 - (w0 * v1 - w1 * v0),
         J00 * a3 + J01 * a4 + J02 * a5, J10 * a3 + J11 * a4 + J12 * a5, J20 * a3 + J21 * a4 + J22 * a5)
    return q, v, a


class _FloatingMixin:
    """Shared set-up of the free-flyer model of base + arm."""

    def _setup_floating(self, robot: Robot, beam: Beam, gravity: float):
        self.beam = beam
        self.frobot = attach_to_floating_base(robot, beam.base_body())
        self.fmodel = self.frobot.model
        self.fmodel.gravity.linear = np.array([0.0, 0.0, -gravity])
        self.fdata = self.fmodel.createData()
        self.ffid = self.frobot.impact_frame_id
        self.na = robot.nv
        self.arm_joint = self.fmodel.getJointId(robot.joint_names[0])  # first arm joint (F/T below it)
        self.mount_id = self.frobot.mount_frame_id
        self._fext = pin.StdVec_Force()
        for _ in range(self.fmodel.njoints):
            self._fext.append(pin.Force.Zero())
        # the F/T sample's own external forces (zero but on the impact link while it is
        # set), the impact link and the impact point in its frame, read once (indexing
        # model.frames copies a Frame)
        self._fext_ft = pin.StdVec_Force()
        for _ in range(self.fmodel.njoints):
            self._fext_ft.append(pin.Force.Zero())
        tip_frame = self.fmodel.frames[self.ffid]
        self._tip_jid = tip_frame.parentJoint
        self._tip_r = tuple(np.array(tip_frame.placement.translation).tolist())
        # live references into fdata (Pinocchio hands its elements by reference; indexing
        # data.oMi or data.f through the bindings costs ~2 us a time): the wrench below the
        # first arm joint, that joint's placement and the mount frame's
        self._f_arm = self.fdata.f[self.arm_joint]
        self._oMi_arm = self.fdata.oMi[self.arm_joint]
        self._oMf_mount = self.fdata.oMf[self.mount_id]
        g = np.array([0.0, 0.0, -gravity])
        self.w_static = static_arm_wrench(robot, self.q0_arm, g, mount=self.frobot.base.mount)
        self.gravity_vec = g

    def _mount_wrench(self, q7full, vfull, afull, F):
        """Wrench of the arm on the platform at the mount, platform axes, about the mount
        origin (what the F/T sensor reads): (force [N], moment [N m])."""
        w = self._mount_wrench6(q7full, vfull, afull, F)
        return w[:3], w[3:]

    def _mount_wrench6(self, q7full, vfull, afull, F):
        """:meth:`_mount_wrench` as one 6-vector (force [N], moment [N m])."""
        model, data = self.fmodel, self.fdata
        # RNEA leaves data.oMi as it found it (Pinocchio 4.1): the placements that turn the
        # wrench into the mount's axes come from this configuration's forward kinematics
        pin.forwardKinematics(model, data, q7full)
        if F > 0.0:
            jid = self._tip_jid
            # the moment r x f in Python floats: the same IEEE products as NumPy's scalars
            f0, f1, f2 = (data.oMi[jid].rotation.T @ (self.n * F)).tolist()
            r0, r1, r2 = self._tip_r
            fext = self._fext_ft
            fext[jid] = pin.Force(np.array([f0, f1, f2, r1 * f2 - r2 * f1, r2 * f0 - r0 * f2, r0 * f1 - r1 * f0]))
            pin.rnea(model, data, q7full, vfull, afull, fext)
            fext[jid] = pin.Force.Zero()
        else:   # no external force: plain RNEA (same forces, none of the fext set-up)
            pin.rnea(model, data, q7full, vfull, afull)
        pin.updateFramePlacement(model, data, self.mount_id)
        w_world = self._oMi_arm.act(self._f_arm)
        return np.negative(self._oMf_mount.actInv(w_world).vector)


class IdealCouplingPlant(_FloatingMixin, FixedBasePlant):
    """Arm + structure integrated as one free-flyer system (ideal coupling).

    State ``x = [p (3), r (3), q_arm, theta, v_base (6), v_arm, thetadot, P, S (3)]``.
    """

    def __init__(self, robot: Robot, q0, n, pendulum: Pendulum, contact: ContactLaw, beam: Beam, *,
                 coulomb_scale: float, viscous_scale: float, gravity: float):
        self.q0_arm = np.asarray(q0, dtype=float)
        super().__init__(robot, q0, n, pendulum, contact, coulomb_scale=coulomb_scale,
                         viscous_scale=viscous_scale, gravity=gravity)
        self._setup_floating(robot, beam, gravity)
        self.ibase = IdealBase(beam, self.w_static, self.gravity_vec)
        na = self.na
        nv = 6 + na
        self.nv = nv
        self.q0 = np.concatenate([np.zeros(6), self.q0_arm])
        z6 = np.zeros(6)
        self.viscous = np.concatenate([z6, self.viscous])
        self.tc_pos = np.concatenate([z6, self.tc_pos])
        self.tc_neg = np.concatenate([z6, self.tc_neg])
        self.sticky = (self.tc_pos > 0) | (self.tc_neg > 0)
        self.arm_q = slice(6, nv)
        self.i_th = nv
        self.arm_v = slice(nv + 1 + 6, 2 * nv + 1)
        self.i_v = slice(nv + 1, 2 * nv + 1)
        self.i_thd = 2 * nv + 1
        self.i_P = 2 * nv + 2
        self.i_S = slice(2 * nv + 3, 2 * nv + 6)
        self.size = 2 * nv + 6
        # the tip's rest position in the world, on the full model
        pin.framesForwardKinematics(self.fmodel, self.fdata, self.q7(self.q0))
        self.p_tip0 = np.array(self.fdata.oMf[self.ffid].translation)
        self._s0 = float(self.n @ self.p_tip0)
        self._free_cache = {}
        self._znv = np.zeros(nv)
        H = pin.crba(self.fmodel, self.fdata, self.q7(self.q0))
        self._fcrba_full = bool(np.allclose(H, H.T))
        self.emulator_period = None

    # -- configuration ----------------------------------------------------------------
    def q7(self, q):
        """Pinocchio configuration (free-flyer quaternion) from the chart ``[p, r, q_arm]``."""
        out = np.empty(7 + self.na)
        out[0:3] = q[0:3]
        rx, ry, rz = q[3], q[4], q[5]
        angle = math.sqrt(rx * rx + ry * ry + rz * rz)
        # unit quaternion (x, y, z, w) of the rotation vector; sin(a/2)/a -> 1/2 at a -> 0
        k = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(0.5 * angle) / angle
        out[3], out[4], out[5], out[6] = k * rx, k * ry, k * rz, math.cos(0.5 * angle)
        out[7:] = q[6:]
        return out

    def servo(self, tau_arm):
        out = np.zeros(self.nv)
        out[6:] = tau_arm
        return out

    def tip(self, q):
        model, data = self.fmodel, self.fdata
        pin.computeJointJacobians(model, data, self.q7(q))
        p = pin.updateFramePlacement(model, data, self.ffid).translation
        Jn = pin.getFrameJacobian(model, data, self.ffid, pin.LOCAL_WORLD_ALIGNED)[:3].T @ self.n
        return float(self.n @ (p - self.p_tip0)), Jn

    def _fext_base(self, q7, v):
        fext = self._fext
        for i in range(len(fext)):
            fext[i] = pin.Force.Zero()
        fext[1] = self.ibase.wrench(q7[:7], v[:6])
        return fext

    def holding_torque(self, q, v, tau, stuck):
        model, data = self.fmodel, self.fdata
        q7 = self.q7(q)
        fext = self._fext_base(q7, v)
        if not len(stuck):
            return np.zeros(0), pin.aba(model, data, q7, v, tau, fext)
        H = pin.crba(model, data, q7)
        if not self._fcrba_full:
            H = np.triu(H) + np.triu(H, 1).T
        b = tau - pin.rnea(model, data, q7, v, self._znv, fext)
        key = tuple(stuck)
        free = self._free_cache.get(key)
        if free is None:
            free = self._free_cache[key] = np.setdiff1d(np.arange(self.nv), stuck)
        a = np.zeros(self.nv)
        a[free] = np.linalg.solve(H[free][:, free], b[free])
        lam = H[stuck] @ a - b[stuck]
        return lam, a

    #: the base dofs never stick; the general constrained solve serves (see :meth:`constrained`)
    _locks_stuck_joints = False

    def constrained(self, q, v, tau, fs):
        return self.holding_torque(q, v, tau, fs.stuck)

    def evaluate(self, x, tau_servo, fs, contact_v0, caught, t=0.0):
        """:meth:`FixedBasePlant.evaluate` composed from :meth:`rhs` and :meth:`holding`
        (the ideal coupling is the reference mode, not the fast path)."""
        xd = self.rhs(x, tau_servo, fs, contact_v0, caught, t)
        lam = NO_HOLDING if fs.none_stuck else self.holding(x, tau_servo, fs, contact_v0, t)[0]
        gap = self.gap(x)[:2] if (contact_v0 is not None or not caught) else None
        return xd, lam, gap

    def rhs(self, x, tau_servo, fs, contact_v0, caught, t=0.0):
        nv = self.nv
        q = x[:nv]
        v = x[self.i_v]
        th, thd = x[nv], x[self.i_thd]
        tau = tau_servo - self.viscous * v - fs.coulomb
        stuck = fs.stuck
        F = 0.0
        xd = np.zeros(self.size)
        if contact_v0 is not None:
            delta, ddelta, Jn = self.gap(x)
            F = self.contact_force(delta, ddelta, contact_v0)
            tau = tau + Jn * F
            p_c = self.fdata.oMf[self.ffid].translation
            xd[self.i_S] = np.cross(p_c, self.n) * F
        thdd = 0.0 if caught else (-self._mgl * math.sin(th) - F * self._r * math.cos(th)) / self._Ip
        _, a = self.holding_torque(q, v, tau, stuck)
        R = pin.exp3(q[3:6])
        xd[0:3] = R @ v[0:3]
        xd[3:6] = pin.Jlog3(R) @ v[3:6]
        xd[6:nv] = v[6:]
        xd[nv] = thd
        xd[self.i_v] = a
        xd[self.i_thd] = thdd
        xd[self.i_P] = F
        return xd

    # -- diagnostics ------------------------------------------------------------------
    def momentum(self, x):
        """Linear momentum [N s] and angular momentum about the world origin [N m s] of
        arm + base (world axes)."""
        q7 = self.q7(x[:self.nv])
        h = pin.computeCentroidalMomentum(self.fmodel, self.fdata, q7, x[self.i_v])
        c = np.array(self.fdata.com[0])
        lin = np.array(h.linear)
        return lin, np.array(h.angular) + np.cross(c, lin)

    def energy(self, x, contact_v0=None):
        nv = self.nv
        q7 = self.q7(x[:nv])
        v = x[self.i_v]
        th, thd = x[nv], x[self.i_thd]
        H = pin.crba(self.fmodel, self.fdata, q7)
        H = np.triu(H) + np.triu(H, 1).T
        ke = 0.5 * float(v @ H @ v) + 0.5 * self._Ip * thd**2
        pe = float(pin.computePotentialEnergy(self.fmodel, self.fdata, q7)) + self._mgl * (1.0 - math.cos(th))
        pe += self.ibase.potential(q7[:7])
        delta = self._r * math.sin(th) - self.tip(x[:nv])[0]
        return ke + pe + float(self.contact.energy(delta))

    def base_state(self, X):
        """Base displacement, rotation vector, world linear and angular velocity per row."""
        out = np.zeros((X.shape[0], 12))
        iv0 = self.i_v.start
        for k in range(X.shape[0]):
            R = pin.exp3(X[k, 3:6])
            out[k, 0:6] = X[k, 0:6]
            out[k, 6:9] = R @ X[k, iv0:iv0 + 3]
            out[k, 9:12] = R @ X[k, iv0 + 3:iv0 + 6]
        return out

    def rest_wrench(self):
        z = np.zeros(self.nv)
        return self._mount_wrench(self.q7(self.q0), z, z, 0.0)

    def mount_wrench(self, x, xd, F, t=None):
        q7 = self.q7(x[:self.nv])
        return self._mount_wrench(q7, x[self.i_v], xd[self.i_v], F)


#: columns of a VES loop step's output (:meth:`.ves.VesLoop.advance`) that a tick's record
#: keeps, in the record's order: structure pose, platform pose, set-point, platform twist
_TICK_RECORD = np.r_[0:6, 12:18, 30:36, 18:24]


class VesLoopPlant(_FloatingMixin, FixedBasePlant):
    """The arm on the VES-II platform, whose motion the emulator prescribes.

    State ``x = [q_arm, theta, v_arm, thetadot, P]``; the platform's pose, twist and
    acceleration at any instant come from the emulator (:class:`.ves.VesLoop`).
    """

    def __init__(self, robot: Robot, q0, n, pendulum: Pendulum, contact: ContactLaw, beam: Beam, *,
                 coulomb_scale: float, viscous_scale: float, gravity: float, rate: float, latency: float,
                 bandwidth: float, duration: float):
        self.q0_arm = np.asarray(q0, dtype=float)
        super().__init__(robot, q0, n, pendulum, contact, coulomb_scale=coulomb_scale,
                         viscous_scale=viscous_scale, gravity=gravity)
        self._setup_floating(robot, beam, gravity)
        self.arm_v = self.i_v
        self.loop = VesLoop(beam, rate, latency, bandwidth, duration=duration)
        self.emulator_period = 1.0 / rate
        self._na0 = np.zeros(self.na)
        self._qf = np.zeros(7 + self.na)
        # the arm alone without gravity: its mass matrix is the free-flyer's H_mm (gravity and
        # the platform's motion are in the bias), and reduced copies lock stuck joints
        m0 = self.model.copy()
        m0.gravity.linear = np.zeros(3)
        self._arm0 = (m0, m0.createData())
        self._lock_model = m0
        self._t = 0.0
        self._vf = np.zeros(6 + self.na)
        self._z6 = np.zeros(6)
        self._af = np.zeros(6 + self.na)
        self._vf_ft = np.zeros(6 + self.na)
        self._af_ft = np.zeros(6 + self.na)
        H = pin.crba(self.fmodel, self.fdata, np.concatenate([pin.SE3ToXYZQUAT(pin.SE3.Identity()), self.q0_arm]))
        self._fcrba_full = bool(np.allclose(H, H.T))
        self.reset_loop(0.0)
        pin.framesForwardKinematics(self.fmodel, self.fdata, self._qfull(self.q0_arm, 0.0)[0])
        self.p_tip0 = np.array(self.fdata.oMf[self.ffid].translation)
        self._s0 = float(self.n @ self.p_tip0)
        self._M_ftip = self.fdata.oMf[self.ffid]     # live reference (see FixedBasePlant.tip)
        #: propagate a frozen arm's ticks in closed form (:mod:`.linear_phase`; the scene's
        #: ``flexible.linear_phases``), and the closed-form loops built so far, per arm pose
        self.linear_phases = False
        self._frozen = {}

    # -- the emulator ------------------------------------------------------------------
    def reset_loop(self, t_last: float):
        """Start the emulator at rest with its last tick at ``t_last`` [s]."""
        self.loop.reset(self.w_static)
        self.t_last = t_last
        self.t_first = t_last
        self.history = []      # (t, record row) per emulator tick
        self._cache = {}
        self._bias_last = None

    def _platform(self, t):
        # the RK4 stages, event checks and servo tick of one emulator tick ask for a few
        # instants repeatedly; the cache lives until the emulator's next tick
        hit = self._cache.get(t)
        if hit is not None:
            return hit
        frac = (t - self.t_last) * self.loop.rate
        frac = 0.0 if frac < 0.0 else (1.0 if frac > 1.0 else frac)
        rows = self.loop.platform_at(frac)        # (3, 6): pose, twist, acceleration
        hit = self._cache[t] = _free_flyer_of_rows(*rows.tolist(), rows[0, 3:])
        return hit

    def _qfull(self, q_arm, t):
        """Free-flyer configuration of platform + arm, platform twist and acceleration at t.
        The configuration is a buffer reused by the next call (callers hand it straight to
        Pinocchio)."""
        qb, vb, ab = self._platform(t)
        qf = self._qf
        qf[:7] = qb
        qf[7:] = q_arm
        return qf, vb, ab

    def on_emulator_tick(self, t, x, xd):
        """Sample the F/T wrench at ``t`` and advance the emulator one tick."""
        na = self.na
        qf, vb, ab = self._qfull(x[:na], t)
        vf, af = self._vf_ft, self._af_ft    # buffers: Pinocchio reads them before they change
        vf[:6] = vb
        vf[6:] = x[self.i_v]
        af[:6] = ab
        af[6:] = xd[self.i_v]
        self.emulator_step(t, self._mount_wrench6(qf, vf, af, xd[self.i_P]))

    def emulator_step(self, t, w):
        """Advance the emulator one tick on the F/T wrench ``w`` sampled at ``t``
        (:meth:`on_emulator_tick` after its sample; the trial loop's kernel samples it from
        its own buffers)."""
        # the record holds the platform as it was at this tick (before the step), then the
        # step's outputs at the next tick are recorded there (:meth:`ticks` picks the columns)
        self.history.append((t, w, self.loop.advance(w)))
        self.t_last = t
        # the platform at this tick is the end of the tick just stepped and the start of the
        # next one (continuous to rounding): keep it, drop the rest
        kept = self._cache.get(t)
        self._cache = {} if kept is None else {t: kept}

    # -- dynamics ----------------------------------------------------------------------
    def tip(self, q, t=None):
        model, data = self.fmodel, self.fdata
        qf, vb, _ = self._qfull(q, self._t if t is None else t)
        # one call gives the frame's world-aligned Jacobian and updates its placement
        J = pin.computeFrameJacobian(model, data, qf, self.ffid, pin.LOCAL_WORLD_ALIGNED)
        p = self._M_ftip.translation
        if self._axis is not None:       # n = sign e_i: the same numbers as the products below
            i, sign = self._axis
            J, s = (-J[i], -float(p[i])) if sign < 0 else (J[i], float(p[i]))
        else:
            n = self.n
            J, s = n @ J[:3], float(n @ p)
        self._tip_base_speed = float(J[:6] @ np.asarray(vb))
        return s - self._s0, J[6:]

    def gap(self, x):
        na = self.na
        s, Jn = self.tip(x[:na])
        th, thd = x[na], x[self.i_thd]
        delta = self._r * math.sin(th) - s
        ddelta = self._r * math.cos(th) * thd - float(Jn @ x[self.i_v]) - self._tip_base_speed
        return delta, ddelta, Jn

    def tip_speed(self, x):
        _, Jn = self.tip(x[:self.na])
        return float(Jn @ x[self.i_v]) + self._tip_base_speed

    def holding_torque(self, q, v, tau, stuck):
        """The reference solve of :meth:`constrained` (kept for the tests): the free-flyer's
        CRBA block ``H_mm`` and an explicit small solve."""
        b = tau - self._bias(q, v)
        H = pin.crba(self.fmodel, self.fdata, self._qfull(q, self._t)[0])
        Hm = H[6:, 6:] if self._fcrba_full else (np.triu(H) + np.triu(H, 1).T)[6:, 6:]
        return self._constrained(Hm, b, stuck)

    def _bias(self, q, v):
        """``rnea(q, v, [a_b, 0])_m`` on the free-flyer model with the platform's motion at
        ``self._t``: gravity, Coriolis and the base acceleration felt by the arm joints."""
        # the step-end evaluation and the servo tick's consistency check after a new torque
        # ask for the same state and instant: the last result is kept, keyed by the
        # platform motion object (the same object means the same motion, see _platform)
        plat = self._platform(self._t)
        key = (q.tobytes(), v.tobytes())
        last = self._bias_last
        if last is not None and last[0] is plat and last[1] == key:
            return last[2]
        qb, vb, ab = plat
        qf = self._qf
        qf[:7] = qb
        qf[7:] = q
        vf = self._vf
        vf[:6] = vb
        vf[6:] = v
        af = self._af
        af[:6] = ab
        bias = pin.rnea(self.fmodel, self.fdata, qf, vf, af)[6:]
        self._bias_last = (plat, key, bias)
        return bias

    def constrained(self, q, v, tau, fs):
        """``(lam, a)`` of the arm on the prescribed platform: ``H_mm a = u + S^T lam`` with
        ``u = tau - bias`` (:meth:`_bias`) and ``a_S = 0``. ``H_mm`` depends on the arm's
        angles only (the same matrix as the fixed-base arm's), so the free joints'
        accelerations are ABA at rest without gravity on the arm model with the stuck joints
        locked (``H_FF^-1 u_F`` in one call), and ``lam = (H_mm a)_S - u_S`` is its RNEA."""
        u = tau - self._bias(q, v)
        if fs.all_stuck:
            return -u, self._na0
        a = self._free_accel(q, u, fs)
        if fs.none_stuck:
            return NO_HOLDING, a
        m0, d0 = self._arm0
        stuck = fs.stuck
        return pin.rnea(m0, d0, q, self._na0, a)[stuck] - u[stuck], a

    def _free_accel(self, q, u, fs):
        """``a`` with ``a_S = 0`` and ``H_FF a_F = u_F`` (ABA at rest, no gravity)."""
        if fs.none_stuck:
            m0, d0 = self._arm0
            return pin.aba(m0, d0, q, self._na0, u)
        a = np.zeros(self.na)
        rm, rd = fs.reduced
        free = fs.free
        a[free] = pin.aba(rm, rd, q[free], self._na0[:free.size], u[free])
        return a

    def _accel(self, q, v, tau, fs):
        if fs.all_stuck:
            return self._na0          # every arm joint held by friction
        return self._free_accel(q, tau - self._bias(q, v), fs)

    def ticks(self):
        """The emulator's record: tick times (n,), sampled wrenches (n, 6) and the states it
        reached one tick later (n, 24: structure pose, platform pose, command, twist)."""
        if not self.history:
            return np.zeros(0), np.zeros((0, 6)), np.zeros((0, 24))
        t = np.array([h[0] for h in self.history])
        return t, np.array([h[1] for h in self.history]), np.array([h[2] for h in self.history])[:, _TICK_RECORD]

    def platform_history(self, times):
        """Platform pose and twist (n, 6) each at ``times``, interpolated linearly between
        emulator ticks (at rest before the first tick)."""
        t, _, rec = self.ticks()
        tt = np.concatenate([[self.t_first], t + self.emulator_period])
        pose = np.vstack([np.zeros(6), rec[:, 6:12]])
        twist = np.vstack([np.zeros(6), rec[:, 18:24]])
        P = np.column_stack([np.interp(times, tt, pose[:, i]) for i in range(6)])
        V = np.column_stack([np.interp(times, tt, twist[:, i]) for i in range(6)])
        return P, V

    def arm_at(self, q_arm, v_arm, pose, twist):
        """Tip speed along n [m/s] with the platform at ``pose``/``twist`` (6 each). One state
        at a time: the recording uses the batched :func:`.sensors.truth_terms`, and this is
        its per-sample reference in the tests."""
        qb, vb, _ = platform_free_flyer(pose, twist, self._z6)
        qf = np.concatenate([qb, q_arm])
        vf = np.concatenate([vb, v_arm])
        pin.computeJointJacobians(self.fmodel, self.fdata, qf)
        J = pin.getFrameJacobian(self.fmodel, self.fdata, self.ffid, pin.LOCAL_WORLD_ALIGNED)[:3].T @ self.n
        return float(J @ vf)

    def rest_wrench(self):
        """F/T reading with the arm at rest on the platform at rest."""
        qf = np.concatenate([pin.SE3ToXYZQUAT(pin.SE3.Identity()), self.q0_arm])
        z = np.zeros(6 + self.na)
        return self._mount_wrench(qf, z, z, 0.0)

    def energy_at(self, x, pose, twist):
        """Arm + pendulum + contact energy in the world with the platform at ``pose``/``twist``
        (the platform is driven by the emulator: this energy is not conserved). Per-sample
        reference of the batched :func:`.sensors.truth_terms` (tests)."""
        na = self.na
        qb, vb, _ = platform_free_flyer(pose, twist, self._z6)
        qf = np.concatenate([qb, x[:na]])
        vf = np.concatenate([vb, x[self.i_v]])
        H = pin.crba(self.fmodel, self.fdata, qf)
        H = np.triu(H) + np.triu(H, 1).T
        th, thd = x[na], x[self.i_thd]
        ke = 0.5 * float(vf @ H @ vf) - 0.5 * float(vf[:6] @ H[:6, :6] @ vf[:6]) + 0.5 * self._Ip * thd**2
        pe = float(pin.computePotentialEnergy(self.fmodel, self.fdata, qf)) + self._mgl * (1.0 - math.cos(th))
        pin.framesForwardKinematics(self.fmodel, self.fdata, qf)
        s_tip = float(self.n @ (self.fdata.oMf[self.ffid].translation - self.p_tip0))
        delta = self._r * math.sin(th) - s_tip
        return ke + pe + float(self.contact.energy(delta))
