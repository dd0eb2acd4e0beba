"""The stress suite: extreme scenes, physical invariants, and the refusals with their causes."""

from __future__ import annotations

import dataclasses
import math
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import archive
from ..core.errors import InputError, SimulationError
from ..core.vocabulary import FIXED, FLEXIBLE, HIGH, LOW, STIFF_MAST, ZERO
from ..model import exiit
from ..model.paper import load_paper, paper_offset_deg
from ..model.robot import load_robot
from ..rig import build, simulate
from ..scene.description import load_rig, make_scene
from .closed_form import singular_pose
from .common import md_table, relative_error
from .work_precision import identify_tree

# ---------------------------------------------------------------------------------------
# stress suite
# ---------------------------------------------------------------------------------------
#: invariant tolerances (see check_invariants)
ENERGY_RTOL = 1e-6        # energy rise allowed after the touch, relative to the hammer's kinetic energy
POST_SAMPLES = 3          # joint-encoder samples needed after the contact end (identification's minimum)
GROWTH_TOL = 1.2          # flexible base: the last quarter's peak base motion / the first quarter's
MEFF_LOWER = 0.9          # identified m* >= this x Ex-IIT m* (lambda = 0): joint resistance only adds
E_UPPER = 1.05            # identified e <= this (noise margin above the physical bound 1)
LIMIT_TOL = math.radians(0.05)

PAPER_HIGH = (500000.0, 4000.0, 1500.0)


@dataclasses.dataclass(frozen=True)
class StressCase:
    """One corner of the input space: ``make_scene`` keywords (+ integration overrides)."""

    axis: str
    label: str
    kwargs: dict
    integration: dict | None = None
    #: ``hammer_x_meff``: set ``pendulum.head_mass`` so that m_b = this x Ex-IIT m* of the pose
    hammer_x_meff: float | None = None

    def make(self):
        kw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in self.kwargs.items()}
        if self.hammer_x_meff is not None:
            m0 = _m0(kw)
            params = kw.setdefault("params", {})
            rod = params.get("pendulum.rod_mass", _rig_value("pendulum.rod_mass"))
            params["pendulum.head_mass"] = self.hammer_x_meff * m0 - rod / 3.0
        return make_scene(**kw)


def _rig_value(key: str):
    return load_rig()[0][key]


def _m0(kw: dict) -> float:
    """Ex-IIT m* (eq 11, lambda = 0, fixed base) of the pose of ``make_scene`` keywords."""
    paper = load_paper()
    q = kw.get("q_paper_deg") or paper["configurations"][int(kw.get("config", 1))]
    q = np.radians(np.asarray(q, float) + paper_offset_deg())
    return float(exiit.effective_mass(load_robot(), q))


@dataclasses.dataclass
class StressResult:
    case: StressCase
    status: str          # passed | refused | blow-up | failed
    reason: str
    seconds: float
    info: dict


def _x(gains, k):
    return tuple(float(g) * k for g in gains)


def stress_cases(*, reduced: bool = False, flexible: bool = True) -> list[StressCase]:
    """The corners of the input space: poses at and near the stretched singularity
    and at the joint limits; gains 0 to 1000x High; contact stiffness 0.01x to 1000x; speeds
    0.01 to 10 m/s; hammer mass 0.01x to 100x m*; servo 100 Hz to 10 kHz; soft and stiff
    beams; coarse integration overrides; and some crossings of those corners."""
    k0 = float(_rig_value("contact.stiffness"))
    ei0 = float(_rig_value("flexible.beam_EI"))
    full = [*_pose_cases(), *_gain_cases(), *_contact_cases(k0), *_speed_cases(), *_hammer_cases(),
            *_servo_cases(), *_crossing_cases(k0), *_integration_cases(k0)]
    if flexible:
        full += _beam_cases(ei0)
        # the beam corners (EI multiples, the loop's rate, bandwidth and latency limits) are
        # set around the stiff mast's ~4.4 Hz first mode: each runs on that named structure
        full = [dataclasses.replace(c, kwargs=dict(c.kwargs, params={"flexible.structure": STIFF_MAST,
                                                                        **c.kwargs.get("params", {})}))
                if c.axis == "beam" else c for c in full]
    if not reduced:
        return full
    return [c for c in full if c.label in _REDUCED_LABELS]


#: the labels of the reduced suite's cases (``stress_cases(reduced=True)``)
_REDUCED_LABELS = frozenset({
    "stretched (0, 172, 0.0), zero", "stretched (0, 172, 0.5), high", "q3 at -135 deg limit",
    "q3 0.01 deg beyond +135 limit", "paper configuration 3, high",
    "10x High", "1000x High", "stiffness 0.01x, zero", "stiffness 1000x, high", "0.01 m/s, zero",
    "10 m/s, zero", "m_b = 0.01x m*, configuration 1", "m_b = 100x m*, configuration 2", "100 Hz, high",
    "3000 Hz, high", "ideal contact, substeps_contact=1", "ideal scene, configuration 2, 2.5 m/s",
    "no friction, no gravity, Zero gains", "EI 100x, ideal", "EI 10000x, loop", "VES bandwidth 300 Hz",
    "flexible ideal coupling, configuration 2, High", "exact singularity (q1*, q2*, q3*): n leaves the range, zero",
})


def _pose(q, gain=ZERO, speed=1.5) -> dict:
    """``make_scene`` keywords of an arbitrary pose ``q`` [deg, paper angles]."""
    return dict(config=0, q_paper_deg=tuple(float(x) for x in q), gain=gain, speed=speed)


def _pose_cases() -> list[StressCase]:
    """The paper's configurations, the stretched arm towards its singularity, the joint limits."""
    C, pose = StressCase, _pose
    qs = tuple(round(x, 9) for x in singular_pose())
    return [
        *[C("pose", f"paper configuration {c}, {g}", dict(config=c, gain=g, speed=1.5))
          for c in (1, 2, 3) for g in (ZERO, HIGH)],
        *[C("pose", f"stretched (0, 172, {q3}), {g}", pose((0.0, 172.0, q3), g))
          for q3 in (10.0, 2.0, 0.5, 0.1, 0.0) for g in (ZERO, HIGH)],
        C("pose", "stretched (0, 172, 0.5), High, 2.5 m/s", pose((0.0, 172.0, 0.5), HIGH, 2.5)),
        C("pose", "stretched (0, 180, 0) horizontal, zero", pose((0.0, 180.0, 0.0))),
        C("pose", "exact singularity (q1*, q2*, q3*): n leaves the range, zero", pose(qs)),
        C("pose", "exact singularity (q1*, q2*, q3*), High", pose(qs, HIGH)),
        C("pose", "singularity + 0.1 deg on q3, zero", pose((qs[0], qs[1], qs[2] + 0.1))),
        C("pose", "q1 at +160 deg limit", pose((160.0, 150.0, 90.0))),
        C("pose", "q1 at -160 deg limit", pose((-160.0, 150.0, 90.0))),
        C("pose", "q2 at +225 deg limit", pose((0.0, 225.0, 90.0))),
        C("pose", "q2 at -45 deg limit", pose((0.0, -45.0, 90.0))),
        C("pose", "q3 at -135 deg limit", pose((0.0, 150.0, -135.0))),
        C("pose", "q3 0.01 deg beyond +135 limit", pose((0.0, 135.0, 135.01))),
    ]


def _gain_cases() -> list[StressCase]:
    """Low, 0.1x to 1000x High, P or D alone."""
    C = StressCase
    h = dict(config=1, gain=HIGH, speed=1.5)
    return [
        C("gains", "Low", dict(config=1, gain=LOW, speed=1.5)),
        *[C("gains", f"{k:g}x High", dict(h, gains_counts=_x(PAPER_HIGH, k))) for k in (0.1, 3, 10, 100, 1000)],
        C("gains", "1000x High, configuration 2", dict(config=2, gain=HIGH, speed=1.5,
                                                        gains_counts=_x(PAPER_HIGH, 1000))),
        C("gains", "P only 10x High", dict(h, gains_counts=(PAPER_HIGH[0] * 10, 0.0, 0.0))),
        C("gains", "D only 100x High", dict(h, gains_counts=(0.0, PAPER_HIGH[1] * 100, 0.0))),
    ]


def _contact_cases(k0: float) -> list[StressCase]:
    """Contact stiffness 0.01x to 1000x the rig's ``k0``, a linear contact, restitution's ends."""
    C = StressCase
    z = dict(config=1, gain=ZERO, speed=1.5)
    return [
        *[C("contact", f"stiffness {m:g}x, {g}", dict(config=1, gain=g, speed=1.5,
                                                       params={"contact.stiffness": k0 * m}))
          for m in (0.01, 0.1, 10, 100, 1000) for g in (ZERO, HIGH)],
        C("contact", "stiffness 1000x, linear, 2.5 m/s", dict(config=1, gain=ZERO, speed=2.5, params={
            "contact.stiffness": k0 * 1000, "contact.exponent": 1.0})),
        C("contact", "restitution 0.05", dict(z, params={"contact.restitution": 0.05})),
        C("contact", "restitution 1.0 (elastic)", dict(z, params={"contact.restitution": 1.0})),
    ]


def _speed_cases() -> list[StressCase]:
    """Hammer speeds 0.01 to 10 m/s."""
    return [StressCase("speed", f"{v:g} m/s, {g}", dict(config=1, gain=g, speed=v))
            for v in (0.01, 0.1, 0.5, 2.5, 3.0, 5.0, 10.0) for g in (ZERO, HIGH)]


def _hammer_cases() -> list[StressCase]:
    """Hammer masses 0.01x to 100x the pose's m*."""
    C = StressCase
    return [
        *[C("hammer", f"m_b = {m:g}x m*, configuration {c}", dict(config=c, gain=ZERO, speed=1.5),
            hammer_x_meff=m) for m in (0.01, 0.1, 1.0, 10.0, 100.0) for c in (1, 2)],
        C("hammer", "m_b = 100x m*, 2.5 m/s, High", dict(config=1, gain=HIGH, speed=2.5), hammer_x_meff=100.0),
    ]


def _servo_cases() -> list[StressCase]:
    """Servo rates 100 Hz to 10 kHz."""
    C = StressCase
    z = dict(config=1, gain=ZERO, speed=1.5)
    h = dict(config=1, gain=HIGH, speed=1.5)
    return [
        *[C("servo", f"{r:g} Hz, {g}", dict(config=1, gain=g, speed=1.5, params={"controller.servo_rate": r}))
          for r in (100.0, 300.0, 3000.0, 10000.0) for g in (LOW, HIGH)],
        C("servo", "100 Hz, zero", dict(z, params={"controller.servo_rate": 100.0})),
        C("servo", "10 kHz, 10x High", dict(h, gains_counts=_x(PAPER_HIGH, 10),
                                            params={"controller.servo_rate": 10000.0})),
    ]


def _crossing_cases(k0: float) -> list[StressCase]:
    """Crossings of the corners: soft or stiff contacts with slow or heavy hammers, the ideal
    scene, no gravity, no friction."""
    C = StressCase
    z = dict(config=1, gain=ZERO, speed=1.5)
    return [
        C("cross", "stiffness 0.01x at 0.01 m/s", dict(config=1, gain=ZERO, speed=0.01,
                                                        params={"contact.stiffness": k0 * 0.01})),
        C("cross", "stiffness 1000x, High, 2.5 m/s", dict(config=1, gain=HIGH, speed=2.5,
                                                           params={"contact.stiffness": k0 * 1000})),
        C("cross", "m_b = 0.01x m* at 0.01 m/s", dict(config=1, gain=ZERO, speed=0.01), hammer_x_meff=0.01),
        C("cross", "stretched (0, 172, 0.1), 1000x stiffness", _pose((0.0, 172.0, 0.1)) | {
            "params": {"contact.stiffness": k0 * 1000}}),
        C("cross", "ideal scene, stiffness 1000x", dict(config=1, scene="ideal", speed=1.5, params={
            "contact.stiffness": 4.0e9})),
        C("cross", "ideal scene, configuration 2, 2.5 m/s", dict(config=2, scene="ideal", speed=2.5)),
        C("cross", "zero gravity, Zero gains (passive)", dict(z, params={"gravity": 0.0})),
        C("cross", "no friction, no gravity, Zero gains", dict(z, params={
            "gravity": 0.0, "arm.coulomb_scale": 0.0, "arm.viscous_scale": 0.0})),
    ]


def _integration_cases(k0: float) -> list[StressCase]:
    """Coarse integration overrides."""
    C = StressCase
    return [
        *[C("integration", f"ideal contact, substeps_contact={s}", dict(config=1, scene="ideal", speed=1.5),
            integration={"substeps_contact": s}) for s in (1, 2, 4, 8)],
        C("integration", "default contact, substeps_free=1, substeps_contact=1, 2.5 m/s, 100x stiffness",
          dict(config=1, gain=ZERO, speed=2.5, params={"contact.stiffness": k0 * 100}),
          integration={"substeps_contact": 1}),
    ]


def _beam_cases(ei0: float) -> list[StressCase]:
    """Flexible bases: the loop and the ideal coupling, soft and stiff beams (EI 1e-4x to
    1e4x the rig's ``ei0``, 2 m to 200 m), no damping, the VES loop's rate, bandwidth and
    latency, a stretched pose."""
    C = StressCase
    fl = dict(base=FLEXIBLE, config=2, gain=HIGH, speed=1.5)
    return [
        C("beam", "flexible loop, configuration 2, High", dict(fl)),
        C("beam", "flexible ideal coupling, configuration 2, High", dict(fl, params={"ves.mode": "ideal"})),
        *[C("beam", f"EI {m:g}x, {mode}", dict(fl, params={"flexible.beam_EI": ei0 * m, "ves.mode": mode}))
          for m in (1e-4, 1e-2, 1e2, 1e4) for mode in ("loop", "ideal")],
        C("beam", "beam length 2 m (stiff), loop", dict(fl, params={"flexible.beam_length": 2.0})),
        C("beam", "beam length 200 m (soft), loop", dict(fl, params={"flexible.beam_length": 200.0})),
        C("beam", "damping ratio 0, ideal coupling", dict(fl, params={"flexible.damping_ratio": 0.0,
                                                                       "ves.mode": "ideal"})),
        C("beam", "VES rate 100 Hz", dict(fl, params={"ves.rate": 100.0})),
        C("beam", "VES bandwidth 100 Hz", dict(fl, params={"ves.bandwidth": 100.0})),
        C("beam", "VES bandwidth 300 Hz", dict(fl, params={"ves.bandwidth": 300.0})),
        C("beam", "VES latency 1 s", dict(fl, params={"ves.latency": 1.0})),
        C("beam", "VES latency 0", dict(fl, params={"ves.latency": 0.0})),
        C("beam", "flexible ideal scene, zero gravity (passive)", dict(
            base=FLEXIBLE, config=2, scene="ideal", speed=1.5, params={"ves.mode": "ideal"})),
        C("beam", "flexible, stretched (0, 172, 0.5), High", dict(
            base=FLEXIBLE, config=0, q_paper_deg=(0.0, 172.0, 0.5), gain=HIGH, speed=1.5)),
    ]


def _passive(scene, tree) -> bool:
    """No active element feeds energy: Zero gains (constant gravity compensation at most) and,
    on a flexible base, the ideal coupling without gravity (the VES loop is an active device)."""
    if any(scene.gains_counts):
        return False
    if scene.base == FLEXIBLE:
        return scene.p("ves.mode") == "ideal" and float(scene.p("gravity")) == 0.0
    return True


def _momentum_bound(scene, tr, c0: float, c1: float, P: float, m_b: float, vb1: float) -> float:
    """Largest |P - m_b (v_b - v'_b)| the pendulum's tangential momentum balance allows.

    About the pivot ``I_p theta'' = -mgl sin(theta) - F r cos(theta)``, so along the path
    ``m_b r dtheta' = -(mgl / r) sin(theta) dt - F cos(theta) dt``, while the stored hammer
    velocity is the component along n, ``v_b = r theta' cos(theta)``. Over a contact in which
    the pendulum swings at most ``theta_m`` from the bottom the two sides of
    ``P = m_b (v_b - v'_b)`` differ by at most the gravity impulse
    ``(mgl / r) sin(theta_m) (t1 - t0)`` plus ``(P + m_b |v'_b|) (1 - cos theta_m) / cos theta_m``.
    ``theta_m`` is taken from the truth samples in the contact (10 % margin)."""
    t = tr.t_truth.values
    th = np.abs(np.asarray(tr.theta.values, float))
    inside = (t >= c0) & (t <= c1)
    theta_m = 1.1 * float(max(np.max(th[inside]) if inside.any() else 0.0, abs(float(tr.theta.interp(
        t_truth=c1))) if c1 <= t[-1] else 0.0))
    theta_m = min(theta_m, 1.5)
    g = float(scene.p("gravity"))
    mgl_r = (float(scene.p("pendulum.head_mass")) + 0.5 * float(scene.p("pendulum.rod_mass"))) * g
    return (mgl_r * math.sin(theta_m) * (c1 - c0)
            + (abs(P) + m_b * abs(vb1)) * (1.0 - math.cos(theta_m)) / math.cos(theta_m) + 1e-6 * abs(P))


def check_invariants(scene, tree, ident) -> tuple[list[str], dict]:
    """Invariants of a finished trial; returns (violations, info).

    - every float in ``/measured`` and ``/truth`` is finite;
    - the trial's outputs are recorded: one contact, inside the record, followed by at least
      ``POST_RECORD`` of recording (what identification's post-contact windows need);
    - the never-tensile contact slowed the hammer (``v'_b < v_b``);
    - momentum: the hammer's momentum change equals the contact impulse within the bound of
      its tangential momentum balance (:func:`_momentum_bound`: gravity impulse and path
      curvature during the contact; about 1e-4 of the impulse for the default scenes);
    - passive scenes (:func:`_passive`): the energy ``E - tau_gc . (q - q0)`` (mechanical
      energy plus the potential of the constant gravity-compensation torque) never rises
      after the touch by more than ``ENERGY_RTOL`` x the hammer's kinetic energy, and the
      true restitution ``(v'_a - v'_b) / (v_b - v_a)`` is at most 1;
    - identification: either excluded with a reason, or m* finite and >= ``MEFF_LOWER`` x
      Ex-IIT m* (lambda = 0, fixed base), e finite in [0, ``E_UPPER``].
    """
    info: dict[str, Any] = {}
    viol = _non_finite(tree)
    if viol:
        return viol, info
    tr, me = tree["truth"], tree["measured"]
    c0, c1 = float(tr.contact_start), float(tr.contact_end)
    va, va1, vb, vb1 = (float(tr[k]) for k in ("v_a_pre", "v_a_post", "v_b_pre", "v_b_post"))
    m_b = float(me.hammer_mass_eff)
    P = float(tr.impulse)
    t_end = float(tr.t_truth[-1])
    info.update(contact_ms=(c1 - c0) * 1e3, peak_N=float(tr.peak_force), n_contacts=int(tr.attrs.get("n_contacts", 1)),
                record_after_s=t_end - c1)
    need = POST_SAMPLES / float(scene.p("sensors.joint_encoder_rate"))
    if not (c0 < c1 and t_end - c1 >= need):
        viol.append(f"contact [{c0:.4g}, {c1:.4g}] s is followed by {max(t_end - c1, 0.0):.3g} s of recording, less "
                    f"than {POST_SAMPLES} joint-encoder samples ({need:.3g} s): the trial's outputs are not recorded")
    if not vb1 < vb:
        viol.append(f"the contact did not slow the hammer (v_b {vb:.4g} -> {vb1:.4g} m/s)")
    e_true = (va1 - vb1) / (vb - va) if vb != va else math.nan
    m_true = m_b * (vb - vb1) / (va1 - va) if va1 != va else math.inf
    info.update(e_true=e_true, m_true=m_true)
    gap = abs(P - m_b * (vb - vb1))
    bound = _momentum_bound(scene, tr, c0, c1, P, m_b, vb1)
    info.update(momentum=gap / abs(P) if P else math.inf, momentum_bound=bound / abs(P) if P else math.inf)
    if not gap <= bound:
        viol.append(f"hammer momentum change {m_b * (vb - vb1):.6g} N s vs contact impulse {P:.6g} N s: "
                    f"{gap:.3g} N s apart, the pendulum's momentum balance allows {bound:.3g}")
    if _passive(scene, tree):
        viol += _passive_violations(tr, me, c0, m_b, vb, e_true, info)
    viol += _base_growth_violations(tr, c1, info)
    # joint limits (the rig has no end stops): reported, not an invariant (see the README)
    robot = load_robot(scene.p("robot"))
    q = np.asarray(tr.q.values, float)
    na = q.shape[1]
    over = np.maximum(q - robot.q_upper[None, :na], robot.q_lower[None, :na] - q)
    info["beyond_limit_deg"] = max(0.0, math.degrees(float(np.max(over))))
    viol += _identification_violations(scene, ident, m_true, info)
    return viol, info


def _non_finite(tree) -> list[str]:
    """The channels of ``/measured`` and ``/truth`` with a non-finite float."""
    viol = []
    for g in ("measured", "truth"):
        ds = tree[g].to_dataset()
        for name, var in ds.variables.items():
            if var.dtype.kind == "f" and not np.all(np.isfinite(var.values)):
                viol.append(f"/{g}/{name} has non-finite values")
    return viol


def _passive_violations(tr, me, c0: float, m_b: float, vb: float, e_true: float, info: dict) -> list[str]:
    """A passive scene's invariants (:func:`check_invariants`): a constant servo torque, the
    energy not rising after the touch, the true restitution at most 1; notes the energy
    rise in ``info``."""
    viol = []
    t = tr.t_truth.values
    E = np.asarray(tr.energy.values, float)
    q = np.asarray(tr.q.values, float)
    q0 = np.asarray(me.q_cmd.values, float)
    tau = np.asarray(me.tau_cmd.values, float)
    tau_gc = tau[0] if tau.ndim == 2 and tau.shape[0] else np.zeros(q0.size)
    if tau.ndim == 2 and not np.array_equal(tau, np.broadcast_to(tau_gc, tau.shape)):
        viol.append("Zero-gain servo torque is not constant")
    Ep = E - (q - q0[None, :]) @ tau_gc
    Ea = Ep[t >= c0]
    ke = 0.5 * m_b * vb * vb
    rise = float(np.max(Ea - np.minimum.accumulate(Ea))) if Ea.size else 0.0
    info["energy_rise"] = rise / ke
    if rise > ENERGY_RTOL * ke:
        viol.append(f"energy rises by {rise:.3g} J after the touch in a passive scene "
                    f"({rise / ke:.2g} of the hammer's kinetic energy; tolerance {ENERGY_RTOL:g})")
    if not e_true <= 1.0 + 1e-9:
        viol.append(f"true restitution {e_true:.6g} > 1 in a passive scene")
    return viol


def _base_growth_violations(tr, c1: float, info: dict) -> list[str]:
    """Flexible base: the structure is damped (and the emulation loop must be stable), so its
    motion after the impact must not grow; notes the growth in ``info``."""
    if "base_position" not in tr.variables:
        return []
    t = tr.t_truth.values
    after = t > c1
    amp = np.max(np.abs(np.concatenate([np.asarray(tr.base_position.values, float),
                                        np.asarray(tr.base_rotation.values, float) * 0.5], axis=1)[after]),
                 axis=1) if after.any() else np.zeros(0)
    if amp.size < 8:
        return []
    k = amp.size // 4
    first, last = float(np.max(amp[:k])), float(np.max(amp[-k:]))
    info["base_growth"] = last / first if first > 0 else math.inf
    if last > GROWTH_TOL * first:
        return [f"base motion grows after the impact (peak {first:.3g} in the first quarter of the "
                f"record, {last:.3g} in the last): unstable emulation loop or integration"]
    return []


def _identification_violations(scene, ident, m_true: float, info: dict) -> list[str]:
    """The identification's invariants (:func:`check_invariants`); notes its values in ``info``."""
    viol = []
    info.update(excluded=bool(ident.excluded), reason=ident.reason, m_eff=ident.m_eff, e=ident.e)
    if ident.excluded:
        return viol
    if not (math.isfinite(ident.m_eff) and ident.m_eff > 0 and math.isfinite(ident.e)):
        viol.append(f"identified m* = {ident.m_eff!r}, e = {ident.e!r}: not finite and positive, and the "
                    "trial is not excluded")
        return viol
    if not (0.0 <= ident.e <= E_UPPER):
        viol.append(f"identified e = {ident.e:.4g} outside [0, {E_UPPER}]")
    if scene.base == FIXED:
        m0 = _m0({"q_paper_deg": scene.q_paper_deg})
        info["m0"] = m0
        # (at a pose where n leaves the range, m0 = inf: any finite m* > 0 is a lower value
        # only by the identification's resolution, so the bound does not apply)
        if math.isfinite(m0) and not ident.m_eff >= MEFF_LOWER * m0:
            viol.append(f"identified m* = {ident.m_eff:.4g} kg below {MEFF_LOWER} x the Ex-IIT "
                        f"m* (lambda = 0) {m0:.4g} kg")
    info["ident_vs_truth"] = relative_error(ident.m_eff, m_true)
    return viol


def run_case(case: StressCase, folder: str | os.PathLike, *, write: bool = True) -> StressResult:
    """Run one stress case through the trial pipeline (scene -> simulate -> invariants ->
    file) and classify it."""

    folder = Path(folder)
    path = folder / (f"{abs(hash(case.label)) & 0xFFFFFFFF:08x}.nc")
    t0 = time.perf_counter()

    def done(status, reason, info=None):
        if status != "passed" and path.exists():
            status, reason = "failed", f"{reason}; and a file was left behind"
        return StressResult(case, status, reason, time.perf_counter() - t0, info or {})

    try:
        scene = case.make()
    except InputError as exc:
        return done("refused", f"scene: {exc}")
    except Exception as exc:  # noqa: BLE001
        return done("failed", f"{type(exc).__name__} while making the scene: {exc}")
    try:
        try:
            build(scene, integration=case.integration)
        except TypeError:       # a rig whose build() does not take (and check) integration overrides
            build(scene)
    except InputError as exc:
        return done("refused", str(exc))
    except ValueError as exc:   # refused before simulating, but not as the rig's InputError
        return done("refused", f"[{type(exc).__name__}, not InputError] {exc}")
    except Exception as exc:  # noqa: BLE001
        return done("failed", f"{type(exc).__name__} while building the rig: {exc}")
    try:
        with np.errstate(all="ignore"):
            tree = simulate(scene, integration=case.integration)
    except InputError as exc:
        return done("failed", f"InputError after the rig was built (work started): {exc}")
    except SimulationError as exc:
        return done("blow-up", str(exc))
    except Exception as exc:  # noqa: BLE001 - anything else is a failure of the suite
        return done("failed", f"{type(exc).__name__} during simulation: {exc}")
    try:
        ident = identify_tree(tree)
    except Exception as exc:  # noqa: BLE001
        return done("failed", f"identification raised {type(exc).__name__}: {exc}")
    viol, info = check_invariants(scene, tree, ident)
    info["sim_s"] = time.perf_counter() - t0
    if viol:
        return done("failed", "; ".join(viol), info)
    if write:
        try:
            archive.write_trial(tree, path)
        except Exception as exc:  # noqa: BLE001
            return done("failed", f"write_trial raised {type(exc).__name__}: {exc}", info)
        if not path.is_file():
            return done("failed", "write_trial left no file", info)
        path.unlink()
    note = f"identification excluded the trial: {ident.reason}" if ident.excluded else ""
    return done("passed", note, info)


def run_stress(cases: Sequence[StressCase], *, write: bool = True,
               log: Callable[[str], None] | None = print) -> list[StressResult]:
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            res = run_case(case, tmp, write=write)
            out.append(res)
            if log:
                log(f"[stress] {res.status:8s} {res.seconds:6.2f} s  {case.axis}: {case.label}"
                    + (f" -- {res.reason[:160]}" if res.reason else ""))
        left = list(Path(tmp).iterdir())
        if left:  # pragma: no cover - run_case removes what it wrote
            raise AssertionError(f"stress cases left files behind: {left}")
    return out


def stress_summary(results: Sequence[StressResult]) -> dict[str, int]:
    s = {"run": len(results)}
    for k in ("passed", "refused", "blow-up", "failed"):
        s[k] = sum(r.status == k for r in results)
    s["excluded"] = sum(r.status == "passed" and bool(r.info.get("excluded")) for r in results)
    return s


def format_stress(results: Sequence[StressResult]) -> str:
    s = stress_summary(results)
    summary = md_table(["cases run", "passed", "(of which identification excluded)", "refused with reason",
                   "reported blow-up (no file)", "failed"],
                  [[s["run"], s["passed"], s["excluded"], s["refused"], s["blow-up"], s["failed"]]])
    axes: dict[str, dict[str, int]] = {}
    for r in results:
        d = axes.setdefault(r.case.axis, {"run": 0, "passed": 0, "refused": 0, "blow-up": 0, "failed": 0})
        d["run"] += 1
        d[r.status] += 1
    per_axis = md_table(["axis", "run", "passed", "refused", "blow-up", "failed"],
                   [[a, d["run"], d["passed"], d["refused"], d["blow-up"], d["failed"]] for a, d in axes.items()])
    rows = []
    for r in results:
        i = r.info
        meas = ""
        if "m_true" in i:
            meas = (f"contact {i['contact_ms']:.3g} ms, peak {i['peak_N']:.3g} N, m*_true {i['m_true']:.3g} kg, "
                    f"e_true {i['e_true']:.3f}")
            if not i.get("excluded") and math.isfinite(i.get("m_eff", math.nan)):
                meas += f"; m*_id {i['m_eff']:.3g} kg, e_id {i['e']:.3f}"
            if i.get("beyond_limit_deg", 0) > 0:
                meas += f"; beyond joint limit by {i['beyond_limit_deg']:.2f} deg"
        reason = r.reason.replace("|", "/").replace("\n", " ")
        rows.append([r.case.axis, r.case.label, f"**{r.status}**" if r.status in ("failed", "blow-up") else r.status,
                     f"{r.seconds:.2f}", reason[:220], meas])
    cases = md_table(["axis", "case", "outcome", "time [s]", "reason / note", "measured"], rows)
    return "\n\n".join([summary, per_axis, cases])
