"""Synthetic impact trials with a known Virtual Rotor Inertia, for testing identification.

A stand-in for the simulated VES-II (``campaign.rig``) that is cheap, seeded and exactly
controlled: it writes the same ``measured`` channels as a rig trial (schema 1.0) and a
``truth`` group with the true contact interval and edge velocities, so identification can
be scored against truth before (and beside) the rig.

The physics, along the impact direction ``n`` (paper section 2):

* The arm rests at ``q_cmd``; the hammer arrives along ``n`` at ``v_b``. A smooth force
  pulse ``f(t)`` (half-sine of ``contact_duration``, optionally skewed) of impulse ``P`` acts
  on the tip. ``P`` follows eq 14 from the chosen ``e`` and the arm's effective mass.
* During the contact the joint velocities follow the accumulated impulse
  ``I(t) = int f``: ``dq(t) = w I(t)`` with ``w = (H + lambda)^-1 J^T n`` (eq 5, fixed base)
  or the arm block of ``(M_full + lambda)^-1 J_full^T n`` of the free-flyer model (flexible
  base, the base twist taking the rest, eq 8).
* The joint motion after the contact decays (``decay``):

  ``none``         no resistance: constant velocity after the contact (lambda as armature);
  ``exponential``  ``dq = dq(t_e) exp(-(t - t_e)/tau)`` after the contact (resistance only
                   after the contact: the tip velocity at the contact end is exactly eq 11
                   with ``lambda``, so lambda recovery can be scored);
  ``viscous``      first-order resistance ``ddq = w f - dq/tau`` acting from the contact start;
  ``coulomb``      constant resistance from the contact start, sized to stop the joint
                   ``tau`` after the contact, then sticking (stick-slip, Lindley recursion);
  ``servo``        a PD-like restoring law ``ddq = w f - 2 zeta omega dq - omega^2 (q - q_cmd)``
                   from the contact start (``servo_freq``, ``servo_zeta``).

  For the modes acting from the contact start, ``P`` is re-solved (fixed point) so the
  velocities at the contact edges still satisfy eq 12 with ``e``.
* Flexible base: the base twist follows ``I(t)`` through the free-flyer model and rings as a
  damped oscillator (``base_freq``, ``base_zeta``) from the contact start.
* The pendulum (pivot at rest, angle ``theta``, 0 at the bottom, positive along ``n``) obeys
  ``theta'' = -omega0^2 sin(theta) - f cos(theta) / (m_b r)`` (``m_b = I_pivot / r^2``), reaching
  the bottom at the contact start; the hammer velocity along n is ``r theta' cos(theta)``.
* Sensors: joint encoders at ``joint_rate`` (noise in counts, quantised to the robot's
  encoder resolution), pendulum encoder at ``pendulum_rate`` (``2 pi / pendulum_counts``),
  piezo at ``piezo_rate`` (Gaussian noise, ADC step, clipped at ``piezo_full_scale``). The
  contact instant is drawn uniformly in ``[pre_contact, pre_contact + jitter)``, so it falls
  anywhere between encoder samples.

Everything is integrated on a 50 kHz grid (trapezoid), the pendulum by ``solve_ivp``.
"""

from __future__ import annotations

import dataclasses
import functools
import json

import numpy as np
import pinocchio as pin
import xarray as xr
from scipy.integrate import solve_ivp
from scipy.signal import cont2discrete, lfilter

from campaign.bench import truth_m_impulse as _truth_m_impulse
from campaign.model.exiit import impact_jacobian, inertia, lambda_matrix, unit_direction
from campaign.model.paper import configuration_q
from campaign.model.robot import load_robot
from campaign.model.robot.floating import BaseBody, attach_to_floating_base
from campaign.scene.schema import SCHEMA_VERSION

__all__ = ["DECAYS", "Spec", "SyntheticTrial", "cached_trial", "make_trial", "truth_m_e", "truth_m_impulse",
           "write_trial"]

DECAYS = ("none", "exponential", "viscous", "coulomb", "servo")
_FINE_DT = 2e-5  # s, integration grid (50 kHz)


@dataclasses.dataclass(frozen=True)
class Spec:
    """Parameters of one synthetic trial (SI units)."""

    q_cmd: tuple | None = None          # DH rad; None -> configuration `config` of the paper
    config: int = 1
    robot: str = "puma560"
    lam: tuple = (0.0, 0.0, 0.0)        # Virtual Rotor Inertia [kg m^2] (diagonal)
    e: float = 0.55
    speed: float = 2.0                  # hammer speed along n at the contact [m/s]
    m_b: float = 0.45                   # hammer effective mass [kg]
    radius: float = 0.5                 # pendulum radius [m]
    n: tuple = (-1.0, 0.0, 0.0)
    contact_duration: float = 0.04      # [s]
    pulse_skew: float = 0.0             # f ~ sin(pi x) exp(-skew x), x in [0, 1]
    decay: str = "exponential"
    tau: float | tuple = 0.08           # [s] decay time (per joint if a tuple)
    servo_freq: float = 6.0             # [Hz]
    servo_zeta: float = 0.7
    gravity: float = 9.81               # pendulum only [m/s^2]
    joint_rate: float = 50.0
    pendulum_rate: float = 1000.0
    piezo_rate: float = 10000.0
    base_rate: float = 1000.0
    pre_contact: float = 0.2
    jitter: float = 0.02
    post_contact: float = 0.25
    encoder_noise_counts: float = 0.3
    quantize: bool = True
    pendulum_counts: int = 65536
    piezo_noise: float = 0.05
    piezo_resolution: float = 0.01
    piezo_full_scale: float = 500.0
    rebound: float = 0.0                # amplitude of a second pulse relative to the first
    rebound_delay: float = 0.03         # [s] from the end of the first contact
    base: str = "fixed"
    base_mass: float = 100.0
    base_inertia: tuple = (20.0, 20.0, 20.0)
    base_freq: float = 5.0
    base_zeta: float = 0.02
    gain: str = "zero"
    repeat: int = 0
    seed: int = 0


@dataclasses.dataclass(frozen=True)
class SyntheticTrial:
    tree: xr.DataTree
    truth: dict

    @property
    def measured(self) -> xr.Dataset:
        return self.tree["measured"].to_dataset()


def _pulse(spec: Spec, t_s: float, P: float):
    """Force [N] of the main pulse (and the optional rebound pulse) as a function of time."""
    xs = np.linspace(0, 1, 20001)
    area1 = np.trapezoid(np.sin(np.pi * xs) * np.exp(-spec.pulse_skew * xs), xs)
    pulses = [(t_s, spec.contact_duration, P)]
    if spec.rebound > 0:
        t_r = t_s + spec.contact_duration + spec.rebound_delay
        pulses.append((t_r, 0.7 * spec.contact_duration, spec.rebound * 0.7 * P))

    def force(t):
        t = np.asarray(t, dtype=float)
        out = np.zeros_like(t)
        for t0, T, imp in pulses:
            x = (t - t0) / T
            inside = (x >= 0) & (x <= 1)
            out = out + np.where(inside, imp / (area1 * T) * np.sin(np.pi * x) * np.exp(-spec.pulse_skew * x), 0.0)
        return out

    return force


@functools.lru_cache(maxsize=64)
def _discrete(num: tuple, den: tuple, dt: float):
    b, a, _ = cont2discrete((list(num), list(den)), dt, method="zoh")
    return np.ravel(b), np.asarray(a)


def _filter(num, den, u, dt):
    """Response of a continuous transfer function to the sampled input ``u`` (ZOH)."""
    b, a = _discrete(tuple(float(x) for x in num), tuple(float(x) for x in den), float(dt))
    return lfilter(b, a, u)


def _joint_velocity(spec, w, t, f, I, t_e, q_dev_gain):
    """Joint velocities (len(t), nv) for the decay law of ``spec``."""
    nv = w.size
    tau = np.broadcast_to(np.asarray(spec.tau, float), (nv,))
    dt = t[1] - t[0]
    dq = np.empty((t.size, nv))
    ie = np.searchsorted(t, t_e)
    for j in range(nv):
        acc = w[j] * f
        if spec.decay == "none":
            dq[:, j] = w[j] * I
        elif spec.decay == "exponential":
            v = w[j] * I
            after = t > t_e
            v_e = w[j] * I[ie]
            v[after] = v_e * np.exp(-(t[after] - t_e) / tau[j]) + w[j] * (I[after] - I[ie])
            dq[:, j] = v
        elif spec.decay == "viscous":
            dq[:, j] = _filter([1.0], [1.0, 1.0 / tau[j]], acc, dt)
        elif spec.decay == "coulomb":
            P = I[ie]
            c = abs(w[j]) * P / (tau[j] + 0.5 * spec.contact_duration)
            x = abs(w[j]) * f * dt - c * dt
            S = np.cumsum(x)
            z = S - np.minimum(np.minimum.accumulate(S), 0.0)
            dq[:, j] = np.sign(w[j]) * z
        elif spec.decay == "servo":
            om = 2 * np.pi * spec.servo_freq
            dq[:, j] = _filter([1.0, 0.0], [1.0, 2 * spec.servo_zeta * om, om**2], acc, dt)
        else:
            raise ValueError(f"decay {spec.decay!r} not in {DECAYS}")
    return dq


def _cumtrapz(y, dt):
    out = np.zeros_like(y)
    out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1]) * dt, axis=0)
    return out


def _rotvec_to_R(r):
    return pin.exp3(np.asarray(r, float))


@functools.lru_cache(maxsize=32)
def _robot(name: str):
    return load_robot(name)


@functools.lru_cache(maxsize=32)
def _scene(base: str, config: int, gain: str):
    from campaign.scene.description import make_scene

    return make_scene(base=base, config=config, gain=gain)


def make_trial(spec: Spec | None = None, **kw) -> SyntheticTrial:
    """Simulate one synthetic trial; keyword arguments override fields of ``spec``."""
    spec = dataclasses.replace(spec or Spec(), **kw)
    rng = np.random.default_rng(spec.seed)
    robot = _robot(spec.robot)
    nv = robot.nv
    q0 = np.asarray(spec.q_cmd if spec.q_cmd is not None else configuration_q(spec.config), float)
    n = unit_direction(spec.n)
    lam_m = lambda_matrix(np.asarray(spec.lam, float), nv)

    t_s = spec.pre_contact + rng.uniform(0.0, spec.jitter)
    T = spec.contact_duration
    t_e = t_s + T
    t_end = t_e + spec.post_contact
    t = np.arange(0.0, t_end + _FINE_DT / 2, _FINE_DT)
    dt = _FINE_DT

    # --- impulse response of arm (and base) per unit impulse along n ---------------
    flexible = spec.base == "flexible"
    if flexible:
        body = BaseBody(mass=spec.base_mass, inertia=np.diag(spec.base_inertia))
        frobot = attach_to_floating_base(robot, body)
        fdata = frobot.model.createData()
        qf = frobot.q_full(q0)
        M = inertia(frobot.model, fdata, qf)
        M[6:, 6:] += lam_m
        Jf = impact_jacobian(frobot.model, fdata, qf, frobot.impact_frame_id)
        wf = np.linalg.solve(M, Jf[:3].T @ n)
        w_base, w = wf[:6], wf[6:]
        m_eq11 = 1.0 / float(n @ Jf[:3] @ wf)
    else:
        data = robot.model.createData()
        H = inertia(robot.model, data, q0) + lam_m
        J = impact_jacobian(robot.model, data, q0, robot.impact_frame_id)
        w = np.linalg.solve(H, J[:3].T @ n)
        w_base = np.zeros(6)
        m_eq11 = 1.0 / float(n @ J[:3] @ w)

    data = robot.model.createData()

    def tip_state(idx, dq, V, pose_p, pose_r):
        """World tip velocity along n at grid index idx."""
        q = q0 + qdev[idx]
        pin.framesForwardKinematics(robot.model, data, q)
        Jr = impact_jacobian(robot.model, data, q, robot.impact_frame_id)[:3]
        R = _rotvec_to_R(pose_r[idx])
        r = R @ data.oMf[robot.impact_frame_id].translation
        v = V[idx, :3] + np.cross(V[idx, 3:], r) + R @ (Jr @ dq[idx])
        return float(n @ v)

    # --- solve P so that the edge velocities satisfy eq 12 ----------------------------
    v_b = spec.speed
    m_guess = m_eq11
    for _ in range(6):
        P = (1 + spec.e) * m_guess * spec.m_b * v_b / (m_guess + spec.m_b)
        force = _pulse(spec, t_s, P)
        f = force(t)
        I = _cumtrapz(f, dt)
        dq = _joint_velocity(spec, w, t, f, I, t_e, None)
        qdev = _cumtrapz(dq, dt)
        if flexible:
            om_b = 2 * np.pi * spec.base_freq
            V = np.column_stack([
                _filter([1.0, 0.0], [1.0, 2 * spec.base_zeta * om_b, om_b**2], w_base[k] * f, dt) for k in range(6)
            ])
        else:
            V = np.zeros((t.size, 6))
        pose = _cumtrapz(V, dt)
        ie = min(np.searchsorted(t, t_e), t.size - 1)
        va_post = tip_state(ie, dq, V, pose[:, :3], pose[:, 3:])
        if spec.decay in ("none", "exponential") and not flexible:
            break
        m_new = P / va_post
        if abs(m_new - m_guess) < 1e-9 * m_guess:
            break
        m_guess = m_new

    # --- pendulum --------------------------------------------------------------------
    r = spec.radius
    om0sq = spec.gravity / r

    def rhs(tt, y):
        ff = float(force(tt))
        return [y[1], -om0sq * np.sin(y[0]) - ff * np.cos(y[0]) / (spec.m_b * r)]

    y_s = [0.0, v_b / r]
    t_f_end = t_e + (spec.rebound_delay + 0.7 * T if spec.rebound > 0 else 0.0)
    t_f_end = min(t_f_end, t_end)
    kw_ode = dict(method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True)
    back = solve_ivp(rhs, (t_s, 0.0), y_s, **kw_ode)
    mid = solve_ivp(rhs, (t_s, t_f_end), y_s, max_step=T / 100, **kw_ode)
    post = solve_ivp(rhs, (t_f_end, t_end), mid.y[:, -1], **kw_ode)

    def pend(tt):
        tt = np.atleast_1d(tt)
        out = np.empty((2, tt.size))
        for seg, sel in ((back, tt < t_s), (mid, (tt >= t_s) & (tt <= t_f_end)), (post, tt > t_f_end)):
            if sel.any():
                out[:, sel] = seg.sol(tt[sel])
        return out

    def hammer_v(tt):
        th, thd = pend(tt)
        return float(r * thd[0] * np.cos(th[0]))

    vb_pre, vb_post = hammer_v(t_s), hammer_v(t_e)
    is_ = np.searchsorted(t, t_s)
    va_pre = tip_state(is_, dq, V, pose[:, :3], pose[:, 3:])
    truth = {
        "contact_start": t_s, "contact_end": t_e,
        "v_a_pre": va_pre, "v_a_post": va_post, "v_b_pre": vb_pre, "v_b_post": vb_post,
        "impulse": P, "peak_force": float(f[(t >= t_s) & (t <= t_e)].max()),
        "e_contact": spec.e,
        "m_eff_eq11": m_eq11,
        "m_eff": spec.m_b * (vb_pre - vb_post) / (va_post - va_pre),
        "e": (va_post - vb_post) / (vb_pre - va_pre),
        "w": w.copy(),
    }

    # --- sensors -----------------------------------------------------------------------
    def clock(rate):
        return np.arange(0.0, t_end, 1.0 / rate)

    tj = clock(spec.joint_rate)
    qj = q0 + np.column_stack([np.interp(tj, t, qdev[:, j]) for j in range(nv)])
    res = robot.encoder_resolution
    qj = qj + rng.normal(0.0, 1.0, qj.shape) * spec.encoder_noise_counts * res
    if spec.quantize:
        qj = np.round(qj / res) * res

    tp = clock(spec.pendulum_rate)
    th = pend(tp)[0]
    if spec.quantize:
        step = 2 * np.pi / spec.pendulum_counts
        th = np.round(th / step) * step

    tf = clock(spec.piezo_rate)
    fm = np.interp(tf, t, f) + rng.normal(0.0, spec.piezo_noise, tf.size)
    if spec.quantize and spec.piezo_resolution > 0:
        fm = np.round(fm / spec.piezo_resolution) * spec.piezo_resolution
    fm = np.clip(fm, -spec.piezo_full_scale, spec.piezo_full_scale)

    tft = clock(1000.0)
    tsv = clock(1000.0)
    axis = ("x", "y", "z")
    joints = tuple(robot.joint_names)
    meas = xr.Dataset(
        {
            "q_enc": (("t_joint", "joint"), qj, {"units": "rad"}),
            "theta_pend": (("t_pend",), th, {"units": "rad"}),
            "f_piezo": (("t_force",), fm, {"units": "N"}),
            "ft_force": (("t_ft", "axis"), np.zeros((tft.size, 3)), {"units": "N"}),
            "ft_torque": (("t_ft", "axis"), np.zeros((tft.size, 3)), {"units": "N m"}),
            "tau_cmd": (("t_servo", "joint"), np.zeros((tsv.size, nv)), {"units": "N m"}),
            "q_cmd": (("joint",), q0, {"units": "rad"}),
            "hammer_mass_eff": ((), spec.m_b, {"units": "kg"}),
            "pendulum_radius": ((), spec.radius, {"units": "m"}),
            "impact_direction": (("axis",), n, {"units": "1"}),
            "piezo_full_scale": ((), spec.piezo_full_scale, {"units": "N"}),
        },
        coords={"t_joint": tj, "t_pend": tp, "t_force": tf, "t_ft": tft, "t_servo": tsv,
                "joint": list(joints), "axis": list(axis)},
    )
    if flexible:
        tb = clock(spec.base_rate)
        bp = np.column_stack([np.interp(tb, t, pose[:, k]) for k in range(3)])
        br = np.column_stack([np.interp(tb, t, pose[:, 3 + k]) for k in range(3)])
        for name, val in (("base_position", bp), ("base_rotation", br),
                          ("platform_cmd_position", bp), ("platform_cmd_rotation", br),
                          ("platform_position", bp), ("platform_rotation", br)):
            meas[name] = (("t_base", "axis"), val, {"units": "m" if "position" in name else "rad"})
        meas = meas.assign_coords(t_base=tb, axis2=list(axis))
        meas["base_mass"] = ((), spec.base_mass, {"units": "kg"})
        meas["base_inertia"] = (("axis", "axis2"), np.diag(spec.base_inertia), {"units": "kg m2"})
        meas["base_com"] = (("axis",), np.zeros(3), {"units": "m"})      # BaseBody above: COM at the base origin
        meas["base_mount"] = (("axis",), np.zeros(3), {"units": "m"})

    tt = np.arange(0.0, t_end, 1e-3)
    ph = pend(tt)
    dq_t = np.column_stack([np.interp(tt, t, dq[:, j]) for j in range(nv)])
    truth_vars = {
        "q": (("t_truth", "joint"), q0 + np.column_stack([np.interp(tt, t, qdev[:, j]) for j in range(nv)])),
        "v": (("t_truth", "joint"), dq_t),
        "theta": (("t_truth",), ph[0]),
        "theta_dot": (("t_truth",), ph[1]),
        "f_contact": (("t_truth",), np.interp(tt, t, f)),
        "tip_velocity_n": (("t_truth",), np.full(tt.size, np.nan)),
        "energy": (("t_truth",), np.full(tt.size, np.nan)),
        **{k: ((), float(truth[k])) for k in ("contact_start", "contact_end", "v_a_pre", "v_a_post", "v_b_pre",
                                             "v_b_post", "impulse", "peak_force", "e_contact")},
    }
    if flexible:
        for name, cols in (("base_position", pose[:, :3]), ("base_rotation", pose[:, 3:]),
                           ("base_velocity", V[:, :3]), ("base_omega", V[:, 3:])):
            truth_vars[name] = (("t_truth", "axis"), np.column_stack([np.interp(tt, t, cols[:, k]) for k in range(3)]))
    truth_ds = xr.Dataset(truth_vars, coords={"t_truth": tt, "joint": list(joints),
                                              **({"axis": list(axis)} if flexible else {})})
    scene = _scene(spec.base, spec.config if spec.q_cmd is None else 1, spec.gain).replace(
        speed=float(spec.speed), repeat=int(spec.repeat), seed=int(spec.seed))
    attrs = {
        "scene_json": scene.to_json(), "scene_sha256": scene.sha256,
        "seed": int(scene.seed), "base": scene.base, "config": int(scene.config), "gain": scene.gain,
        "speed": float(scene.speed), "repeat": int(scene.repeat), "robot": robot.name,
        "schema_version": SCHEMA_VERSION,
        "synthetic_spec": json.dumps(dataclasses.asdict(spec), default=str),
    }
    tree = xr.DataTree.from_dict({"/": xr.Dataset(attrs=attrs), "/measured": meas, "/truth": truth_ds})
    return SyntheticTrial(tree=tree, truth=truth)


@functools.lru_cache(maxsize=512)
def _cached(spec: Spec) -> SyntheticTrial:
    return make_trial(spec)


def cached_trial(**kw) -> SyntheticTrial:
    """:func:`make_trial` memoised on its parameters (shared by the test modules of one
    session); treat the result as read-only (``.copy()`` before changing it)."""
    return _cached(dataclasses.replace(Spec(), **kw))


def write_trial(trial: SyntheticTrial, path):
    """Write a synthetic trial through the archive (``campaign.archive.write_trial``)."""
    from campaign.archive import write_trial as archive_write

    return archive_write(trial.tree, path)


def truth_m_e(measured, truth) -> tuple[float, float]:
    """m* (eq 10) and e (eq 12) from a trial's true edge velocities (its ``truth`` group) and
    its hammer mass: what identification is scored against (synthetic or rig trials)."""
    va, vap = float(truth["v_a_pre"]), float(truth["v_a_post"])
    vb, vbp = float(truth["v_b_pre"]), float(truth["v_b_post"])
    return float(measured["hammer_mass_eff"]) * (vb - vbp) / (vap - va), (vap - vbp) / (vb - va)


def truth_m_impulse(measured, truth, robot) -> float:
    """Eq 11's impulsive-limit m* of a trial from its truth
    (:func:`campaign.bench.truth_m_impulse`); ``robot`` may be a robot name."""
    return _truth_m_impulse(measured, truth, _robot(robot) if isinstance(robot, str) else robot)
