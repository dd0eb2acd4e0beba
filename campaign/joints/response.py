"""The arm's response to the contact's force pulse: the effective mass eq 10 measures, and the structure's peak.

The joints do not resist an impact as an inertia (the Virtual Rotor Inertia of eq 5): over
the rig's 60-80 ms contact they resist as the servo's spring and damper, the joints' viscous
friction and Coulomb friction that holds a lightly loaded joint still. This module follows
the linearised arm through the contact and returns what eq 10 measures, ``m* = P / n.v_a``
at the contact's end, for arrays of cases at once:

* **The pulse** is the rig's contact law between two free bodies of reduced mass
  ``mu = m* m_b / (m* + m_b)`` meeting at the hammer's speed: its shape and duration in
  closed form (:func:`campaign.rig.contact.pulse_shape`, :meth:`~campaign.rig.contact.ContactLaw.duration`),
  its impulse ``P = (1 + e) v mu`` (eq 14, the arm at rest). ``m*`` is the response's own, so
  the pulse and the response are iterated (the duration moves as ``mu^0.58``, barely with m*).
* **The arm**, linearised about the struck pose: ``H q'' + (K_d + beta - K_p T_s / 2) q' +
  (K_p + g dG/dq) dq = (J^T n + (d^2 (n.p)/dq^2) dq) F - tau_c`` with the servo's known
  proportional and derivative gains ``K_p``, ``K_d`` (its zero-order hold delays the
  proportional term by half a servo period ``T_s``: a damping ``K_p T_s / 2`` less), the
  joints' viscous damping ``beta``, gravity's stiffness and the Coulomb friction ``tau_c``.
  The second derivative of the impact point keeps the pose's motion over the contact
  (first order), in the force's torque and in the tip's velocity along n.
* **Coulomb friction with sticking**: after each step a joint loses at most the impulse its
  Coulomb level gives over the step, and stays still if its motion needs less
  (:func:`campaign.joints.friction.stick_slip`); a joint at rest breaks away only when its
  load beats the static level.
* **The flexible base** (:class:`campaign.joints.terms.BaseTerms`): the arm on the
  structure's tip body with the structure's stiffness and damping. Ideally coupled, arm and
  base are one linear system (``coupling="ideal"``). Through the VES-II loop
  (``coupling="loop"``, :class:`Loop`, :mod:`campaign.joints.emulated_base`) the model runs at the
  emulator's tick like the rig: the F/T
  wrench sampled at each tick drives the structure (held over the tick), whose pose reaches
  the platform ``latency`` later through the platform's second-order servo following a
  ramped set-point; the arm rides the platform. ``m*`` then uses the tip's inertial velocity,
  and the base's peak displacement is the structure's over one first-mode period after the
  touch (followed ideally coupled after the contact when that period spans more than
  :data:`LOOP_WINDOW_TICKS` ticks: the loop's ~10 ms delay is then a few degrees of it).

Without servo, damping, friction and gravity and with a short pulse the response is eq 11
with ``lambda = 0`` (eq 7); with a rigid structure it is the fixed base; with a free base
body and a short pulse it is eq 8 with ``lambda = 0``. The method and its measured
accuracy: user guide, *The response model* (``docs/response_model.rst``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED
from .cases import (
    Cases,
    ContactPulse,
    check_directions,
    mass_of,
    object_impulse,
    pulse_of,
    second_order,
    start_mass,
    zoh,
)
from .emulated_base import Loop, respond_loop
from .friction import StickSlip
from .terms import ArmTerms

__all__ = ["Response", "respond", "STEPS_PER_CONTACT", "GUESS_STEPS", "WINDOW_SAMPLES"]

#: steps over the shortest contact of a batch (fixed base, ideal coupling)
STEPS_PER_CONTACT = 48
#: steps of the coarse first round that sizes the pulse
GUESS_STEPS = 6
#: steps per first-mode period after the contact, where the structure's peak is sought (the
#: slowest case's; the peak of a sampled sinusoid is then within 1 - cos(pi/24) = 0.9 % of it)
WINDOW_SAMPLES = 24


@dataclasses.dataclass(frozen=True)
class Response:
    """The response of C cases x D variants (shapes lead with (C, D)).

    Attributes
    ----------
    m_eff : m* = P / n.v_a at the contact's end [kg] (eq 10); ``inf`` where the tip stays still.
    impulse : P, eq 14 at the reduced mass of m* [N s].
    duration : the contact law's pulse duration at that reduced mass [s].
    tip_velocity : n.v_a at the contact's end [m/s] (inertial on the flexible base).
    dq : (C, D, nv) joint velocities at the contact's end [rad/s].
    base_velocity : (C, D, 6) the structure's tip twist at the contact's end, or None.
    base_peak : the structure's peak translation over the window [m], or None.
    """

    m_eff: np.ndarray
    impulse: np.ndarray
    duration: np.ndarray
    tip_velocity: np.ndarray
    dq: np.ndarray
    base_velocity: np.ndarray | None = None
    base_peak: np.ndarray | None = None


class LinearArm:
    """``M x'' + C x' + K x = f`` per case, the arm's joints last in ``x``: the fixed base
    (``x = dq``) or the arm ideally coupled to the structure (``x = [x_b, dq]``)."""

    def __init__(self, cases: Cases, *, flexible: bool):
        t, nv = cases.terms, cases.nv
        self.cases, self.flexible = cases, flexible
        if flexible:
            b = t.base
            M = b.M
            K = cases.gravity * b.gravity_stiffness_full
            K[:, :6, :6] += b.structure_stiffness
            D = np.zeros_like(M)
            D[:, :6, :6] = b.structure_damping
            self.JbT = np.ascontiguousarray(np.swapaxes(np.einsum("cdi,cij->cdj", cases.n, b.J[:, :, :6]), 1, 2))
        else:
            M = t.H
            K = cases.gravity * t.gravity_stiffness
            D = np.zeros_like(M)
            self.JbT = None
        j = np.arange(nv) + (6 if flexible else 0)
        K[:, j, j] += cases.kp
        D[:, j, j] += cases.damping
        self.nx = M.shape[-1]
        self.jq = j
        Mi = np.linalg.inv(M)
        # a friction impulse on the joints moves them (and the base) by M^-1 [0; -lambda]: the
        # joints' velocity-level inertia is the Schur complement H* (eq 8's), or H itself
        A_f = np.linalg.inv(Mi[:, j][:, :, j])
        self.fric = StickSlip(0.5 * (A_f + np.swapaxes(A_f, 1, 2)))
        self.R_f = Mi[:, :, j]                             # (C, nx, nv)
        self.A, self.B = second_order(M, D, K)
        self._step = None

    def propagator(self, h: float, *, doublings: int = 0):
        """``(Phi, Gamma)``: the state after a step ``h 2^doublings`` and its response to a
        generalised impulse spread evenly over the step. One matrix exponential per case for
        ``h``; a longer step doubles it (``Phi_2h = Phi_h^2``, ``Gamma_2h = (Phi_h Gamma_h +
        Gamma_h) / 2``), exactly."""
        if self._step is None or self._step[0] != h:
            Phi, G = zoh(self.A, self.B, h)
            self._step = (h, Phi, G / h)
        _, Phi, Gam = self._step
        for _ in range(int(doublings)):
            Gam = 0.5 * (Phi @ Gam + Gam)
            Phi = Phi @ Phi
        return Phi, Gam

    def force(self, Z):
        """The contact force's generalised force per newton (C, nx, D)."""
        joint = self.cases.joint_force(Z[:, self.jq, :])
        return joint if not self.flexible else np.concatenate([self.JbT, joint], axis=1)

    def tip_velocity(self, Z):
        """n.v of the impact point, inertial (C, D)."""
        return np.einsum("cid,cid->cd", self.force(Z), Z[:, self.nx:, :])

    def friction(self, Z, step, modes):
        """Apply the Coulomb friction impulses of a step of ``step`` seconds (scalar or (C,)) at
        its end; returns the stick/slip modes."""
        cs, nx = self.cases, self.nx
        qd = np.swapaxes(Z[:, nx + self.jq, :], 1, 2)                      # (C, D, nv)
        k = np.reshape(np.asarray(step, float), (-1, 1, 1))
        x, m = self.fric.step(qd, kappa_pos=k * cs.tc_pos, kappa_neg=k * cs.tc_neg, modes=modes)
        lam = np.einsum("cij,cdj->cid", self.fric.A, qd - x)               # the friction impulse (C, nv, D)
        Z[:, nx:, :] -= self.R_f @ lam
        return m

    def base_displacement(self, Z):
        """|x_b| of the structure's tip translation (C, D)."""
        return np.sqrt(np.einsum("cid,cid->cd", Z[:, :3, :], Z[:, :3, :]))


def _contact(sys: LinearArm, pulse: ContactPulse, T, P, *, h: float, doublings: int, peak: bool):
    """The contact on the step grid ``h 2^doublings``: the tip's and joints' velocities and the
    base's twist at each variant's contact end (interpolated between steps), the state after
    the longest contact, the time reached, the structure's peak so far and the stick/slip modes."""
    cs, nv, nx = sys.cases, sys.cases.nv, sys.nx
    C, D = cs.shape
    Phi, Gam = sys.propagator(h, doublings=doublings)
    h = h * 2 ** int(doublings)
    Z = np.zeros((C, 2 * nx, D))
    prev = np.zeros((C, D, nv + 7))                   # [tip speed, joint speeds, base twist] after the last step
    end = np.full((C, D, nv + 7), np.nan)
    top = np.zeros((C, D))
    modes = None
    steps = int(math.ceil(float(np.max(T)) / h)) + 1
    first_end = float(np.min(T))
    for k in range(steps):
        share = pulse.shares(k * h, (k + 1) * h, T)                        # (C, D)
        Z = Phi @ Z + Gam @ (sys.force(Z) * (P * share)[:, None, :])
        modes = sys.friction(Z, h, modes)
        if (k + 2) * h >= first_end:                                       # some contact ends in this step or the next
            now = np.concatenate([sys.tip_velocity(Z)[..., None], np.swapaxes(Z[:, nx + sys.jq, :], 1, 2),
                                  np.swapaxes(Z[:, nx:nx + 6, :], 1, 2) if sys.flexible else np.zeros((C, D, 6))],
                                 axis=2)
            cross = (T > k * h) & (T <= (k + 1) * h)                       # the contact ends in this step
            if np.any(cross):
                w = ((T - k * h) / h)[cross][:, None]
                end[cross] = prev[cross] + w * (now - prev)[cross]
            prev = now
        if peak:
            top = np.maximum(top, sys.base_displacement(Z))
    return end, Z, steps * h, top, modes


def _window(sys: LinearArm, Z, t_now: float, period, top, modes, *, h: float, samples: int):
    """The structure's peak translation up to one first-mode period (per case) after the
    touch, followed from the contact's end in steps of ``h`` doubled up to the longest period
    over ``samples``."""
    doublings = max(int(math.floor(math.log2(max(float(np.max(period)) / samples / h, 1.0)))), 0)
    Phi, _ = sys.propagator(h, doublings=doublings)
    h = h * 2 ** doublings
    for k in range(max(int(math.ceil((float(np.max(period)) - t_now) / h)), 0)):
        Z = Phi @ Z
        modes = sys.friction(Z, h, modes)
        live = (t_now + (k + 1) * h <= period * (1 + 1e-9))[:, None]
        top = np.where(live, np.maximum(top, sys.base_displacement(Z)), top)
    return top


def linear_response(sys: LinearArm, contact, m, *, h: float, doublings: int, window: bool, samples: int):
    """The contact (and the structure's window) of the fixed base or the ideal coupling on the
    step grid ``h 2^doublings``, the pulse sized with ``m``."""
    cases, flexible = sys.cases, sys.flexible
    pulse = ContactPulse(contact)
    T, P = pulse_of(cases, contact, m)
    end, Z, t_now, top, modes = _contact(sys, pulse, T, P, h=h, doublings=doublings, peak=flexible and window)
    nv = cases.nv
    peak = None
    if flexible and window:
        peak = _window(sys, Z, t_now, 1.0 / cases.terms.base.first_mode, top, modes, h=h, samples=samples)
    v = end[..., 0]
    return Response(m_eff=mass_of(object_impulse(cases, pulse, m, P), v), impulse=P, duration=T, tip_velocity=v,
                    dq=end[..., 1:1 + nv],
                    base_velocity=end[..., 1 + nv:] if flexible else None, base_peak=peak)


def _checked(terms, kp, kd, damping, coulomb_pos, coulomb_neg, coupling, loop):
    nv = terms.nv
    C = terms.q.shape[0]
    kp = np.broadcast_to(np.asarray(kp, float), (C, nv))
    kd = np.broadcast_to(np.asarray(kd, float), (C, nv))
    out = {}
    for name, v in (("damping", damping), ("coulomb_pos", coulomb_pos), ("coulomb_neg", coulomb_neg)):
        a = np.asarray(v, float)
        if a.shape != (nv,) or not np.all(np.isfinite(a) & (a >= 0)):
            raise InputError(f"joint {name} must be {nv} finite values >= 0, got {np.asarray(v).tolist()}")
        out[name] = a
    if not (np.all(np.isfinite(kp) & (kp >= 0)) and np.all(np.isfinite(kd) & (kd >= 0))):
        raise InputError("servo gains must be finite and >= 0")
    if coupling is None:
        coupling = FIXED if terms.base is None else "loop"
    if coupling not in (FIXED, "ideal", "loop"):
        raise InputError(f"coupling {coupling!r} is not one of fixed, ideal, loop")
    if (coupling == FIXED) != (terms.base is None):
        raise InputError(f"coupling {coupling!r} does not fit terms {'without' if terms.base is None else 'with'} "
                         "a flexible base")
    if coupling == "loop" and loop is None:
        raise InputError("the VES loop's coupling needs its rate, latency and bandwidth (Loop)")
    return kp, kd, out, coupling


def respond(terms: ArmTerms, *, kp, kd, damping, coulomb_pos, coulomb_neg, directions, speed, mass, restitution,
            contact, gravity: float, servo_period: float, coupling: str | None = None, loop: Loop | None = None,
            window: bool = True, steps: int = STEPS_PER_CONTACT, samples: int = WINDOW_SAMPLES,
            object_stiffness=0.0) -> Response:
    """The response of C cases (one pose each) x D variants (direction, speed, object) to the contact.

    Parameters
    ----------
    terms : ArmTerms
        One pose per case (:func:`campaign.joints.terms.arm_terms`; with its base on the
        flexible base).
    kp, kd : array_like, shape (C, nv) or (nv,)
        The servo's proportional [N m/rad] and derivative [N m s/rad] gains per case.
    damping : array_like, shape (nv,)
        The joints' viscous damping ``beta`` [N m s/rad].
    coulomb_pos, coulomb_neg : array_like, shape (nv,)
        The joints' Coulomb (and static) friction against positive and negative motion [N m].
    directions : array_like, shape (C, D, 3) or (D, 3)
        Impact directions n (the force on the arm), base frame.
    speed, mass, restitution : array_like, shape (C, D) or scalar
        The object's speed [m/s], mass ``m_b`` [kg] and the restitution of eq 14.
    contact : campaign.rig.contact.ContactLaw
    gravity : float
        [m/s^2]
    servo_period : float
        The digital servo's period [s] (its hold delays the proportional term by half of it).
    coupling : {"fixed", "ideal", "loop"}, optional
        Default: ``fixed`` without a base, ``loop`` with one.
    loop : Loop, optional
        The VES-II loop (``coupling="loop"``).
    window : bool
        Follow the structure after the contact for its peak (flexible base).
    steps, samples : int
        Steps over the shortest contact (fixed base, ideal coupling); per first-mode period
        after it.
    object_stiffness : array_like, shape (C, D) or scalar
        The object's own restoring stiffness along n [N/m]: the rig's pendulum hammer under
        gravity (``m g l_c / r^2``), whose impulse over the contact eq 10 counts; 0 for a
        free object.

    Notes
    -----
    A coarse round (:data:`GUESS_STEPS` steps, ideally coupled on the flexible base) gives the
    m* that sizes the pulse of the final round: the pulse's duration goes as ``mu^0.58`` and
    ``mu`` moves by about 2 % of m*'s change, so that m* needs no more accuracy than that.
    """
    kp, kd, vals, coupling = _checked(terms, kp, kd, damping, coulomb_pos, coulomb_neg, coupling, loop)
    C = terms.q.shape[0]
    n = check_directions(directions, C)
    D = n.shape[1]
    sp, mb, e = (np.broadcast_to(np.asarray(x, float), (C, D)) for x in (speed, mass, restitution))
    if not (np.all(np.isfinite(sp) & (sp > 0)) and np.all(np.isfinite(mb) & (mb > 0))):
        raise InputError("object speed and mass must be finite and > 0")
    damping_total = np.maximum(kd + vals["damping"] - 0.5 * float(servo_period) * kp, 0.0)
    ko = np.broadcast_to(np.asarray(object_stiffness, float), (C, D))
    cases = Cases(terms=terms, kp=kp, damping=damping_total, tc_pos=vals["coulomb_pos"], tc_neg=vals["coulomb_neg"],
                  n=n, speed=sp, mass=mb, restitution=e, gravity=float(gravity), object_stiffness=ko)
    sys = LinearArm(cases, flexible=coupling != FIXED)
    m0 = start_mass(cases)
    h = float(np.min(pulse_of(cases, contact, m0)[0])) / int(steps)
    coarse = max(int(round(math.log2(int(steps) / GUESS_STEPS))), 0)
    guess = linear_response(sys, contact, m0, h=h, doublings=coarse, window=False, samples=samples).m_eff
    if coupling == "loop":
        def continue_ideal(Z, t_now, top, modes):
            return _window(sys, Z, t_now, 1.0 / terms.base.first_mode, top, modes, h=h, samples=samples)
        m, P, T, v, dq, bv, peak = respond_loop(cases, contact, loop, guess, window=window,
                                                continue_ideal=continue_ideal)
        return Response(m_eff=m, impulse=P, duration=T, tip_velocity=v, dq=dq, base_velocity=bv, base_peak=peak)
    return linear_response(sys, contact, guess, h=h, doublings=0, window=window, samples=samples)
