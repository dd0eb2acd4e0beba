"""The contact response on the VES-II's emulated base, tick by tick like the rig.

The VES-II does not couple the arm to the structure directly: at each emulator tick it
samples the wrench the arm puts on the platform (F/T sensor, static load removed), advances
the emulated structure ``M_s x'' + B_s x' + K_s x = w`` with that wrench held over the
tick, and sends the structure's pose to the platform ``latency`` later as a set-point
ramping between ticks, which the platform follows as a second-order Butterworth servo of
``bandwidth`` (:class:`campaign.rig.ves.VesLoop`). On the stiff mast that loop moves m* by
up to a fifth against the ideal coupling; this module runs the same loop with the arm
linearised as in :mod:`campaign.joints.response`:

* within a tick the arm and the platform ``X = [dq, q', p, p']`` are one linear system, the
  set-point ramping (exact first-order hold) and the contact's torque held at its mean
  over the tick: ``H_m q'' = tau - H_bm^T p'' - D q' - K dq - G_mb p``;
* at each tick the wrench ``w = J_b^T n F - M_a p'' - H_bm q'' - dG_b [p, dq]`` (the arm's
  share of the base inertia ``M_a``, its gravity's change) drives the structure;
* Coulomb friction acts on the joints at the end of each tick (the platform is held by its
  servo), and its torque enters the next wrench.

The touch falls half way into a tick (the rig's contact instant is drawn at random). After
the contact the structure is followed through the loop up to one first-mode period after
the touch when that is at most :data:`LOOP_WINDOW_TICKS` ticks; a slower structure
continues ideally coupled (the caller's ``continue_ideal``), where the loop's ~10 ms delay
is a few degrees of its period.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError
from .cases import Cases, ContactPulse, foh, mass_of, object_impulse, pulse_of, second_order, zoh
from .friction import StickSlip

__all__ = ["Loop", "LoopArm", "respond_loop", "LOOP_WINDOW_TICKS", "MIN_LOOP_TICKS", "TOUCH_PHASE"]

#: the longest window (emulator ticks) followed through the VES loop; longer ones continue ideally coupled
LOOP_WINDOW_TICKS = 400
#: fewest emulator ticks a contact must span (the loop model holds the contact force per tick)
MIN_LOOP_TICKS = 16
#: where the touch falls within a tick (the rig draws it at random: half way on average)
TOUCH_PHASE = 0.5


@dataclasses.dataclass(frozen=True)
class Loop:
    """The VES-II emulation loop: ``rate`` [Hz], ``latency`` [s] (whole ticks), platform ``bandwidth`` [Hz]."""

    rate: float
    latency: float
    bandwidth: float

    def __post_init__(self):
        for name in ("rate", "bandwidth"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"VES loop {name} must be > 0, got {getattr(self, name)!r}")
        if not (math.isfinite(float(self.latency)) and float(self.latency) >= 0):
            raise InputError(f"VES loop latency must be >= 0 s, got {self.latency!r}")

    @property
    def tick(self) -> float:
        return 1.0 / float(self.rate)

    @property
    def latency_ticks(self) -> int:
        return int(round(float(self.latency) * float(self.rate)))

    @classmethod
    def from_values(cls, values) -> Loop:
        """The loop of flat rig values (``ves.rate``, ``ves.latency``, ``ves.bandwidth``)."""
        return cls(float(values["ves.rate"]), float(values["ves.latency"]), float(values["ves.bandwidth"]))


class LoopArm:
    """The tick's linear maps of C cases: arm and platform, wrench, structure."""

    def __init__(self, cases: Cases, loop: Loop):
        b, nv = cases.terms.base, cases.nv
        self.cases, self.h, self.NL = cases, loop.tick, loop.latency_ticks
        Hm = b.M[:, 6:, 6:]
        Hmi = np.linalg.inv(Hm)
        HbT = np.swapaxes(b.M[:, :6, 6:], 1, 2)                            # (C, nv, 6)
        dG = cases.gravity * b.gravity_stiffness
        Gmb, Gbb, Gbm = dG[:, 6:, :6], dG[:, :6, :6], dG[:, :6, 6:]
        Ka = dG[:, 6:, 6:] + np.einsum("ci,ij->cij", cases.kp, np.eye(nv))
        Dm = np.einsum("ci,ij->cij", cases.damping, np.eye(nv))
        wb = 2.0 * math.pi * float(loop.bandwidth)
        z2 = math.sqrt(2.0) * wb
        self.fric = StickSlip(Hm)
        self.Hm = Hm
        self.JbT = np.ascontiguousarray(np.swapaxes(np.einsum("cdi,cij->cdj", cases.n, b.J[:, :, :6]), 1, 2))
        # the wrench: w = J_b^T n F + W_tau (tau + tau_f) + W_x X + W_u u0, with the platform's
        # acceleration p'' = -wb^2 p - z2 p' + wb^2 u0 and q'' from the arm's equation
        HbHi = np.swapaxes(HbT, 1, 2) @ Hmi                                # H_bm H_m^-1 (C, 6, nv)
        Meff = HbHi @ HbT - b.arm_base_inertia                            # multiplies p''
        self.W_tau = -HbHi
        self.W_x = np.concatenate([HbHi @ Ka - Gbm, HbHi @ Dm, -wb * wb * Meff + HbHi @ Gmb - Gbb, -z2 * Meff], axis=2)
        self.W_u = wb * wb * Meff
        n = 2 * nv + 12
        A = np.zeros((Hm.shape[0], n, n))
        B = np.zeros((Hm.shape[0], n, 6 + nv))
        A[:, :nv, nv:2 * nv] = np.eye(nv)
        A[:, nv:2 * nv, :nv] = -Hmi @ Ka
        A[:, nv:2 * nv, nv:2 * nv] = -Hmi @ Dm
        A[:, nv:2 * nv, 2 * nv:2 * nv + 6] = -Hmi @ (-wb * wb * HbT + Gmb)
        A[:, nv:2 * nv, 2 * nv + 6:] = Hmi @ (z2 * HbT)
        B[:, nv:2 * nv, :6] = -Hmi @ (wb * wb * HbT)
        B[:, nv:2 * nv, 6:] = Hmi
        A[:, 2 * nv:2 * nv + 6, 2 * nv + 6:] = np.eye(6)
        A[:, 2 * nv + 6:, 2 * nv:2 * nv + 6] = -wb * wb * np.eye(6)
        A[:, 2 * nv + 6:, 2 * nv + 6:] = -z2 * np.eye(6)
        B[:, 2 * nv + 6:, :6] = wb * wb * np.eye(6)
        Phi, G0, G1 = foh(A, B, self.h)
        self.Phi, self.G0c, self.G1c, self.Gtau = Phi, G0[:, :, :6], G1[:, :, :6], G0[:, :, 6:] + G1[:, :, 6:]
        self.n = n
        As, Bs = second_order(b.structure_mass, b.structure_damping, b.structure_stiffness)
        self.Phs, self.Gs = zoh(As, Bs, self.h)                            # (12, 12), (12, 6)

    def tip_velocity(self, X):
        """n.v of the impact point, inertial: the joints' part and the platform's (C, D)."""
        nv = self.cases.nv
        return self.cases.tip_speed(X[:, :nv], X[:, nv:2 * nv]) + np.einsum("cid,cid->cd", self.JbT, X[:, 2 * nv + 6:])

    def friction(self, X, modes):
        """A tick's Coulomb impulses on the joints; the modes and the friction torque the next
        F/T sample feels (C, nv, D)."""
        cs, nv = self.cases, self.cases.nv
        qd = np.swapaxes(X[:, nv:2 * nv], 1, 2)
        x, m = self.fric.step(qd, kappa_pos=self.h * cs.tc_pos, kappa_neg=self.h * cs.tc_neg, modes=modes)
        lam = np.einsum("cij,cdj->cid", self.Hm, qd - x)
        X[:, nv:2 * nv] = np.swapaxes(x, 1, 2)
        return m, -lam / self.h


def _start(arm: LoopArm):
    C, D = arm.cases.shape
    nv = arm.cases.nv
    return dict(X=np.zeros((C, arm.n, D)), s=np.zeros((C, 12, D)), queue=np.zeros((max(arm.NL, 1), C, 6, D)),
                tau_f=np.zeros((C, nv, D)), modes=None, k=0, prev=np.zeros((C, D, nv + 7)), top=np.zeros((C, D)))


def _ticks(arm: LoopArm, pulse: ContactPulse, T, P, state, ticks: int):
    """Advance ``ticks`` emulator ticks; returns the tip's and joints' velocities and the
    structure's twist at each variant's contact end where it falls within them."""
    cs, nv, h, NL = arm.cases, arm.cases.nv, arm.h, arm.NL
    C, D = cs.shape
    X, s, queue, tau_f, modes, prev = (state[k] for k in ("X", "s", "queue", "tau_f", "modes", "prev"))
    end = np.full((C, D, nv + 7), np.nan)
    t_end = TOUCH_PHASE * h + T
    first_end, last_end = float(np.min(t_end)), float(np.max(t_end))
    for _ in range(ticks):
        k = state["k"]
        t0 = k * h - TOUCH_PHASE * h                                        # pulse time at the tick's start
        F_now = pulse.force(t0, T, P)
        F_mean = pulse.shares(t0, t0 + h, T) * P / h
        jf = cs.joint_force(X[:, :nv])
        u0 = queue[k % NL].copy() if NL else s[:, :6]                       # x_s at tick k - NL
        w = arm.JbT * F_now[:, None] + arm.W_tau @ (jf * F_now[:, None] + tau_f) + arm.W_x @ X + arm.W_u @ u0
        s_old, s = s, arm.Phs @ s + arm.Gs @ w
        if NL:
            u1 = queue[(k + 1) % NL] if NL > 1 else s_old[:, :6]            # x_s at tick k + 1 - NL
            queue[k % NL] = s_old[:, :6]                                   # x_s[k - NL] is no longer needed
        else:
            u1 = s[:, :6]
        X = arm.Phi @ X + arm.G0c @ u0 + arm.G1c @ u1 + arm.Gtau @ (jf * F_mean[:, None])
        modes, tau_f = arm.friction(X, modes)
        if (k + 2) * h >= first_end and k * h <= last_end:      # some contact ends in this tick or the next
            now = np.concatenate([arm.tip_velocity(X)[..., None], np.swapaxes(X[:, nv:2 * nv], 1, 2),
                                  np.swapaxes(s[:, 6:], 1, 2)], axis=2)
            cross = (t_end > k * h) & (t_end <= (k + 1) * h)
            if np.any(cross):
                wgt = ((t_end - k * h) / h)[cross][:, None]
                end[cross] = prev[cross] + wgt * (now - prev)[cross]
            prev = now
        state["top"] = np.maximum(state["top"], np.sqrt(np.einsum("cid,cid->cd", s[:, :3], s[:, :3])))
        state["k"] = k + 1
    state.update(X=X, s=s, queue=queue, tau_f=tau_f, modes=modes, prev=prev)
    return end


def respond_loop(cases: Cases, contact, loop: Loop, m, *, window: bool, continue_ideal=None):
    """:func:`campaign.joints.response.respond` through the VES-II loop, the pulse sized with
    ``m``: ``(m*, impulse, duration, tip speed, joint speeds (C, D, nv), structure twist
    (C, D, 6), peak or None)``. ``continue_ideal(Z, t, peak, modes)`` follows a slow
    structure's window ideally coupled from the state ``Z = [x_b, dq, x_b', q']``."""
    arm = LoopArm(cases, loop)
    h, nv = arm.h, cases.nv
    pulse = ContactPulse(contact)
    T, P = pulse_of(cases, contact, m)
    if float(np.min(T)) < MIN_LOOP_TICKS * h:
        raise InputError(f"the contact ({1e3 * float(np.min(T)):.3g} ms) spans fewer than {MIN_LOOP_TICKS} ticks "
                         f"of the VES loop ({1e3 * h:.3g} ms), which holds the contact force per tick")
    state = _start(arm)
    end = _ticks(arm, pulse, T, P, state, int(math.ceil((TOUCH_PHASE * h + float(np.max(T))) / h)) + 1)
    peak = None
    if window:
        period = 1.0 / cases.terms.base.first_mode
        total = int(math.ceil(float(np.max(period)) / h)) + 1
        if total <= LOOP_WINDOW_TICKS or continue_ideal is None:
            _ticks(arm, pulse, T, P, state, max(total - state["k"], 0))
            peak = state["top"]
        else:
            X, s = state["X"], state["s"]
            Z = np.concatenate([s[:, :6], X[:, :nv], s[:, 6:], X[:, nv:2 * nv]], axis=1)
            peak = continue_ideal(Z, state["k"] * h, state["top"], state["modes"])
    v = end[..., 0]
    return mass_of(object_impulse(cases, pulse, m, P), v), P, T, v, end[..., 1:1 + nv], end[..., 1 + nv:], peak
