"""The trial driver: :func:`identify_trial` runs contact detection, the hammer and the arm methods on one trial.

Each step of identification is a function here; :func:`identify_trial` calls them in turn.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError
from ..core.lazy import LazyModule
from ..core.vocabulary import FIXED, FLEXIBLE
from ..model.robot import Robot, load_robot
from ..scene.schema import GroupArrays
from .channels import (
    base_geometry,
    check_channels,
    finite_constant,
    float_or_nan,
    int_or,
    servo_channel,
    time_coordinate,
)
from .contact import ContactInput, ContactWindow, detect_contact
from .ft_momentum import ft_tip_velocity
from .hammer import contact_impulse, hammer_fit
from .joint_dynamics import joint_dynamics_fit
from .options import (
    BASE_POSE_CHANNELS,
    FLEXIBLE_CONSTANTS,
    REQUIRED_CHANNELS,
    IdentifyOptions,
)
from .results import TrialIdentification
from .tip_lti import (
    arm_fit,
    rotate,
    start_jacobian_series,
    tip_displacement,
    tip_positions,
)

#: imported on first use: the campaign's identification jobs read trials as plain arrays
#: (``load_trial(path, arrays=True)``) and so never pay ~0.6 s for xarray and pandas
xr = LazyModule("xarray")

_NAN = float("nan")


# ----------------------------------------------------------------------------------------
# what the steps hand on
# ----------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Channels:
    """The checked channels and constants of one trial (SI units, base frame)."""

    tj: np.ndarray              # joint encoder clock [s]
    tp: np.ndarray              # pendulum encoder clock [s]
    tf: np.ndarray              # piezo clock [s]
    Q: np.ndarray               # joint encoder angles (N, nv), DH [rad]
    theta: np.ndarray           # pendulum angle [rad]
    f: np.ndarray               # piezo force [N]
    m_b: float                  # hammer mass [kg]
    radius: float               # pendulum radius [m]
    full_scale: float           # piezo full scale [N]
    n: np.ndarray               # unit impact direction
    q_cmd: np.ndarray           # commanded joint angles, DH [rad]
    flexible: bool              # the arm stands on the flexible base
    pose_names: tuple | None    # the flexible base's pose channels (position, rotation)
    base_mass: float            # the flexible base's constants (nan, () on a fixed base)
    base_inertia: tuple
    base_com: tuple
    base_mount: tuple


@dataclasses.dataclass(frozen=True)
class _Hammer:
    """The hammer's velocities along n at the contact edges (eq 10's ``v_b``, ``v'_b``) [m/s],
    the pendulum angles there [rad], the fits' sample counts and their ``(w^2, variance)``."""

    v_b: float
    v_b_post: float
    theta_start: float
    theta_end: float
    n_pre: int
    n_post: int
    w2_pre: tuple
    w2_post: tuple
    reasons: list


@dataclasses.dataclass(frozen=True)
class _ArmWindow:
    """The joint samples the arm methods read: ``t``, ``Q`` over ``[t_s - joint_pre_window,
    t_e + post_window]``, the contact's force shape ``cin``, and the servo channel ``(ts, tau)``
    when the joint-space model serves (``joint_model``)."""

    t: np.ndarray
    Q: np.ndarray
    post_window: float
    cin: ContactInput
    servo: tuple | None
    joint_model: bool


@dataclasses.dataclass(frozen=True)
class _TipSeries:
    """The arm tip's position along n over the window [m] (the arm's part; on a flexible base
    in the inertial frame, the base's rotation applied), the base point's velocities along n
    at the contact edges [m/s] (0 on a fixed base), and on a flexible base the base rotation
    vectors at the window's samples ``R_base`` and the tip at ``q_cmd`` ``tip0``."""

    s: np.ndarray
    v_base_pre: float
    v_base_post: float
    R_base: np.ndarray | None
    tip0: np.ndarray | None


@dataclasses.dataclass(frozen=True)
class _FTVelocities:
    """The F/T method's tip velocities along n (nan when not run), the method it leaves
    (``arm_velocity`` when it served, else "encoders"), the note why not, and its ``info``."""

    v_a: float
    v_a_post: float
    method: str
    note: str
    info: dict


@dataclasses.dataclass(frozen=True)
class _EncoderVelocities:
    """The encoder methods' tip velocities along n relative to the base [m/s], the impulsive
    limit's ``n . J(q_s)(qd' - qd)`` (``delta_lin``), the window's sample counts, the reason
    the windows do not serve ("" if they do), and the fit's ``info``."""

    v_a: float
    v_a_post: float
    delta_lin: float
    n_pre: int
    n_contact: int
    n_post: int
    why: str
    info: dict


@dataclasses.dataclass(frozen=True)
class _ArmVelocities:
    """The arm tip's velocities along n at the contact edges relative to the base [m/s], the
    base point's, ``delta_lin`` (eq 11's impulsive limit), the method used and its note,
    the joint sample counts, the contact's force shape and the reasons to exclude."""

    v_a: float
    v_a_post: float
    v_base_pre: float
    v_base_post: float
    delta_lin: float
    method: str
    note: str
    n_pre: int
    n_contact: int
    n_post: int
    cin: ContactInput
    reasons: list


@dataclasses.dataclass(frozen=True)
class _Estimate:
    """Eq 10 (or the impulse estimator) and eq 12 of one trial: the tip velocities along n
    [m/s], the numerator of m* [N s], the velocity change it is divided by, m* [kg] and e."""

    v_a: float
    v_a_post: float
    dv_a: float
    dv_m: float
    impulse_momentum: float
    m_eff: float
    e: float


# ----------------------------------------------------------------------------------------
# the driver
# ----------------------------------------------------------------------------------------
def identify_trial(measured: xr.Dataset, *, robot=None, meta: Mapping | None = None,
                   options: IdentifyOptions | None = None, where: str = "trial") -> TrialIdentification:
    """Identify m* (eq 10, or eq 11's impulsive limit: ``options.m_eff_estimator``) and e
    (eq 12) of one trial from its measured channels.

    Parameters
    ----------
    measured : xarray.Dataset or campaign.scene.schema.GroupArrays
        The trial's ``measured`` group (schema 1.0); as plain arrays from
        ``load_trial(path, arrays=True)`` the result is the same.
    robot : campaign.model.robot.Robot or str, optional
        The arm; by default ``meta["robot"]`` (the trial's root attribute), else
        ``measured.attrs["robot"]``.
    meta : mapping, optional
        The trial's root attributes (``robot``, ``base``, ``config``, ``gain``, ``speed``,
        ``repeat``) and optionally ``path``; copied into the result.
    options : IdentifyOptions, optional
    where : str
        Name of the trial in error messages (the file path).

    Returns
    -------
    TrialIdentification
        ``excluded=True`` with a reason when the trial cannot give a trustworthy m*.

    Raises
    ------
    InputError
        A required channel or constant is missing, has the wrong dims, or a bad value.
    """
    opt = options or IdentifyOptions()
    meta = dict(meta or {})
    base_kind, flexible, pose_names = _check_measured(measured, meta, where)
    robot = _resolve_robot(robot, meta, measured, where)
    ch = _read_channels(measured, meta, flexible, pose_names, where)
    ident = _identity(meta, robot, base_kind, ch, opt)

    c = detect_contact(ch.tf, ch.f, ch.full_scale, opt)
    if c.n_contacts == 0:
        return _no_contact(c, ident)
    reasons = _contact_reasons(c, ch.full_scale)
    hammer = _hammer_velocities(ch, c, opt)
    reasons += hammer.reasons
    arm = _arm_velocities(measured, robot, ch, c, opt, where)
    reasons += arm.reasons
    impulse_estimator = opt.m_eff_estimator == "impulse"
    est = _m_eff_and_e(ch, hammer, arm, impulse_estimator=impulse_estimator)
    if not reasons:
        reasons = _estimate_reasons(est, hammer, impulse_estimator=impulse_estimator)
    return _result(c, hammer, arm, est, reasons, ident)


# ----------------------------------------------------------------------------------------
# 0. channels
# ----------------------------------------------------------------------------------------
def _check_measured(measured, meta: Mapping, where: str) -> tuple[str, bool, tuple | None]:
    """The base kind the trial states ("" when it does not), whether the base is flexible
    (stated, or by the ``base_mass`` constant), and its base pose channels; raises
    :class:`InputError` for a missing or malformed channel."""
    if not isinstance(measured, GroupArrays) and not isinstance(measured, xr.Dataset):
        raise InputError(f"{where}: expected the measured group as an xarray.Dataset (or "
                         f"campaign.scene.schema.GroupArrays), got {type(measured).__name__}")
    check_channels(measured, REQUIRED_CHANNELS, where)
    base_kind = str(meta.get("base", "") or "")
    flexible = base_kind == FLEXIBLE or (not base_kind and "base_mass" in measured.variables)
    pose_names = None
    if flexible:
        check_channels(measured, FLEXIBLE_CONSTANTS, where)
        pose_names = next((pair for pair in BASE_POSE_CHANNELS if all(p in measured.variables for p in pair)), None)
        if pose_names is None:
            raise InputError(f"{where}: flexible-base trial has no base pose channels "
                             f"(platform_position/platform_rotation or base_position/base_rotation)")
        check_channels(measured, {p: ("t_base", "axis") for p in pose_names}, where)
    return base_kind, flexible, pose_names


def _resolve_robot(robot, meta: Mapping, measured, where: str) -> Robot:
    """The arm: ``robot``, else the trial's ``robot`` attribute; its joints must be the
    encoders' ``joint`` dimension."""
    if robot is None:
        robot = meta.get("robot") or measured.attrs.get("robot")
        if not robot:
            raise InputError(f"{where}: no robot given and no 'robot' attribute in the trial")
    if not isinstance(robot, Robot):
        try:
            robot = load_robot(str(robot))
        except ValueError as exc:
            raise InputError(f"{where}: {exc}") from None
    if measured.sizes["joint"] != robot.nv:
        raise InputError(f"{where}: q_enc has {measured.sizes['joint']} joints, robot {robot.name} has {robot.nv}")
    return robot


def _read_channels(measured, meta: Mapping, flexible: bool, pose_names: tuple | None, where: str) -> _Channels:
    """The clocks, samples and constants identification reads, checked finite (and the
    constants > 0, the impact direction non-zero and normalised)."""
    tj = time_coordinate(measured, "t_joint", where)
    tp = time_coordinate(measured, "t_pend", where)
    tf = time_coordinate(measured, "t_force", where)
    Q = np.asarray(measured["q_enc"].values, float)
    theta = np.asarray(measured["theta_pend"].values, float)
    f = np.asarray(measured["f_piezo"].values, float)
    for name, arr in (("q_enc", Q), ("theta_pend", theta), ("f_piezo", f)):
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{where}: channel {name} has non-finite samples")
    m_b = finite_constant(measured, "hammer_mass_eff", where)
    radius = finite_constant(measured, "pendulum_radius", where)
    full_scale = finite_constant(measured, "piezo_full_scale", where)
    n = np.asarray(measured["impact_direction"].values, float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
        raise InputError(f"{where}: impact_direction = {n.tolist()} must be a non-zero 3-vector")
    n = n / np.linalg.norm(n)
    q_cmd = np.asarray(measured["q_cmd"].values, float)
    if not np.all(np.isfinite(q_cmd)):
        raise InputError(f"{where}: q_cmd = {q_cmd.tolist()} is not finite")
    base_mass, base_inertia, base_com, base_mount = _NAN, (), (), ()
    if flexible:
        base_mass = finite_constant(measured, "base_mass", where)
        base_inertia = tuple(float(x) for x in np.asarray(measured["base_inertia"].values, float).ravel())
        com, mount = base_geometry(measured, meta, where)
        base_com, base_mount = tuple(float(x) for x in com), tuple(float(x) for x in mount)
    return _Channels(tj=tj, tp=tp, tf=tf, Q=Q, theta=theta, f=f, m_b=m_b, radius=radius, full_scale=full_scale,
                     n=n, q_cmd=q_cmd, flexible=flexible, pose_names=pose_names, base_mass=base_mass,
                     base_inertia=base_inertia, base_com=base_com, base_mount=base_mount)


def _identity(meta: Mapping, robot: Robot, base_kind: str, ch: _Channels, opt: IdentifyOptions) -> dict:
    """The trial's file and scene identity and constants, as the result's fields."""
    return dict(
        path=str(meta.get("path", "")), robot=robot.name, base=base_kind or (FLEXIBLE if ch.flexible else FIXED),
        config=int_or(meta.get("config"), -1), gain=str(meta.get("gain", "") or ""),
        speed=float_or_nan(meta.get("speed")), repeat=int_or(meta.get("repeat"), -1),
        q_cmd=tuple(float(x) for x in ch.q_cmd), hammer_mass=ch.m_b, impact_direction=tuple(float(x) for x in ch.n),
        base_mass=ch.base_mass, base_inertia=ch.base_inertia, base_com=ch.base_com, base_mount=ch.base_mount,
        m_eff_estimator=opt.m_eff_estimator,
    )


# ----------------------------------------------------------------------------------------
# 1. contact
# ----------------------------------------------------------------------------------------
def _no_contact(c: ContactWindow, ident: dict) -> TrialIdentification:
    """The excluded result of a trial whose piezo force shows no contact."""
    return TrialIdentification(
        m_eff=_NAN, e=_NAN, v_a=_NAN, v_a_post=_NAN, v_b=_NAN, v_b_post=_NAN, impulse=_NAN, impulse_momentum=_NAN,
        contact_start=_NAN, contact_end=_NAN, peak_force=c.peak, excluded=True,
        reason=f"no contact in f_piezo (peak {c.peak:.3g} N above the baseline, threshold {c.threshold:.3g} N)",
        **ident)


def _contact_reasons(c: ContactWindow, full_scale: float) -> list[str]:
    """Why the contact found cannot serve: a rebound, saturation, or a cut-off record."""
    reasons = []
    if c.n_contacts > 1:
        times = ", ".join(f"{a:.4f}-{b:.4f}" for a, b in c.intervals)
        reasons.append(f"{c.n_contacts} contacts in f_piezo (rebound) at t = {times} s")
    if c.saturated:
        reasons.append(f"f_piezo saturated at its full scale {full_scale:g} N")
    if not c.complete:
        reasons.append("the contact is not fully inside the f_piezo record")
    return reasons


# ----------------------------------------------------------------------------------------
# 2. hammer
# ----------------------------------------------------------------------------------------
def _hammer_velocities(ch: _Channels, c: ContactWindow, opt: IdentifyOptions) -> _Hammer:
    """The hammer's velocities at the contact edges from the pendulum encoder, and why a
    window has too few samples."""
    v_b, th_s, nb_pre, w2_pre = hammer_fit(ch.tp, ch.theta, c.start, "pre", ch.radius, opt)
    v_b_post, th_e, nb_post, w2_post = hammer_fit(ch.tp, ch.theta, c.end, "post", ch.radius, opt)
    ode = opt.pendulum_model == "ode"
    reasons = []
    if not math.isfinite(v_b):
        w = opt.pendulum_pre_window if ode else opt.pendulum_window
        reasons.append(f"only {nb_pre} pendulum samples in the {w:g} s before the contact")
    if not math.isfinite(v_b_post):
        w = opt.pendulum_post_window if ode else opt.pendulum_window
        reasons.append(f"only {nb_post} pendulum samples in the {w:g} s after the contact (or before the brake)")
    return _Hammer(v_b=v_b, v_b_post=v_b_post, theta_start=th_s, theta_end=th_e, n_pre=nb_pre, n_post=nb_post,
                   w2_pre=w2_pre, w2_post=w2_post, reasons=reasons)


# ----------------------------------------------------------------------------------------
# 3. arm tip along n
# ----------------------------------------------------------------------------------------
def _arm_velocities(measured, robot: Robot, ch: _Channels, c: ContactWindow, opt: IdentifyOptions,
                    where: str) -> _ArmVelocities:
    """The arm tip's velocities along n at the contact edges by the method the options and
    the trial allow (F/T, encoders, or both combined), the base point's on a flexible base,
    and why they cannot serve."""
    win = _arm_window(measured, robot, ch, c, opt, where)
    tip = _tip_series(measured, robot, ch, c, win, opt, where)
    reasons = []
    if not (math.isfinite(tip.v_base_pre) and math.isfinite(tip.v_base_post)):
        reasons.append("too few base pose samples around the contact")
    ft = _ft_velocities(measured, robot, ch, c, opt, where)
    enc = _encoder_velocities(robot, ch, c, win, tip, method=ft.method, opt=opt)
    impulse_estimator = opt.m_eff_estimator == "impulse"
    v_a, v_a_post, delta_lin, method, note = _chosen_velocities(enc, ft, impulse_estimator=impulse_estimator)
    if enc.why:
        reasons.append(enc.why)
    else:
        moved, quantum = tip_displacement(robot, ch.q_cmd, ch.n, win.t, tip.s, c.start, c.end, win.post_window, opt)
        if moved < opt.min_tip_counts * quantum:
            reasons.append(f"the arm tip did not move measurably along n ({moved:.3g} m within {win.post_window:g} s "
                           f"after the contact; encoder resolution at the tip {quantum:.3g} m)")
    return _ArmVelocities(v_a=v_a, v_a_post=v_a_post, v_base_pre=tip.v_base_pre, v_base_post=tip.v_base_post,
                          delta_lin=delta_lin, method=method, note=note, n_pre=enc.n_pre, n_contact=enc.n_contact,
                          n_post=enc.n_post, cin=win.cin, reasons=reasons)


def _arm_window(measured, robot: Robot, ch: _Channels, c: ContactWindow, opt: IdentifyOptions,
                where: str) -> _ArmWindow:
    """The arm model (joint-space or tip-space), its post-contact window and the joint samples in it."""
    tj = ch.tj
    rate = 1.0 / float(np.median(np.diff(tj)))
    # the joint model propagates the nominal arm dynamics over its window: dense samples
    # (<= auto_joint_interval) keep that window short; with 20 ms samples it spans 0.1 s,
    # and on the lambda-recovery trials of tests/joints/test_fit.py it moved lambda_3 by +2.7 %
    # with a CI that missed: there the tip-space model serves. Measured since: that is not
    # the lambda the nominal model lacks (noise-free encoders, v'_a - v_a -0.33 % with
    # lambda, -0.32 % without; the per-joint impulses absorb it) but the model's gravity
    # stiffness G, which the synthetic arm (no gravity, zero tau_cmd) does not have (G = 0:
    # -0.001 %; -0.11 % over the 1 kHz window), on top of eq 10's own +0.4..+1.1 % over
    # eq 11 on those 40 ms contacts (every arm model). Neither is a defect of the joint
    # model on the rig, whose arm has gravity; the gate is kept until rig trials with a
    # known lambda at 50 Hz say otherwise
    servo = (servo_channel(measured, robot.nv, where)
             if opt.arm_model == "joint" and not ch.flexible and 1.0 / rate <= opt.auto_joint_interval * (1 + 1e-9)
             else None)
    joint_model = servo is not None and servo[0][0] <= c.start
    post_window = opt.joint_model_window(rate) if joint_model else opt.post_window(rate)
    cin = ContactInput(ch.tf, ch.f, c, c.end + post_window + 1e-3)
    win = (tj >= c.start - opt.joint_pre_window) & (tj <= c.end + post_window)
    return _ArmWindow(t=tj[win], Q=ch.Q[win], post_window=post_window, cin=cin, servo=servo, joint_model=joint_model)


def _tip_series(measured, robot: Robot, ch: _Channels, c: ContactWindow, win: _ArmWindow, opt: IdentifyOptions,
                where: str) -> _TipSeries:
    """The tip's position along n over the window by forward kinematics, and on a flexible
    base the base point's motion: the arm part rotated with the base, the base point's
    velocities from one-sided fits (:func:`_base_fit`)."""
    tw = win.t
    P = tip_positions(robot, win.Q) if tw.size else np.empty((0, 3))
    if not ch.flexible:
        return _TipSeries(s=P @ ch.n, v_base_pre=0.0, v_base_post=0.0, R_base=None, tip0=None)
    tb = time_coordinate(measured, "t_base", where)
    pb = np.asarray(measured[ch.pose_names[0]].values, float)
    rb = np.asarray(measured[ch.pose_names[1]].values, float)
    if not (np.all(np.isfinite(pb)) and np.all(np.isfinite(rb))):
        raise InputError(f"{where}: base pose channels {ch.pose_names} have non-finite samples")
    tip0 = tip_positions(robot, ch.q_cmd[None, :])[0]
    r0 = np.asarray(ch.base_mount) + tip0      # tip at q_cmd in the base frame
    s_base = (pb + rotate(rb, r0)) @ ch.n
    rb_w = np.column_stack([np.interp(tw, tb, rb[:, k]) for k in range(3)])
    s_arm = rotate(rb_w, P - tip0) @ ch.n
    return _TipSeries(s=s_arm, v_base_pre=_base_fit(tb, s_base, c.start, "pre", opt),
                      v_base_post=_base_fit(tb, s_base, c.end, "post", opt), R_base=rb_w, tip0=tip0)


def _base_fit(t, s, t_edge, side, opt: IdentifyOptions) -> float:
    """One-sided quadratic fit of the base-point position, slope at the edge [m/s]."""
    if side == "pre":
        sel = (t <= t_edge) & (t >= t_edge - opt.base_window)
    else:
        sel = (t >= t_edge) & (t <= t_edge + opt.base_window)
    if sel.sum() < 5:
        return _NAN
    x = (t[sel] - t_edge) / opt.base_window
    c = np.polynomial.polynomial.polyfit(x, s[sel], 2)
    return float(c[1]) / opt.base_window


def _ft_velocities(measured, robot: Robot, ch: _Channels, c: ContactWindow, opt: IdentifyOptions,
                   where: str) -> _FTVelocities:
    """The F/T method when asked for (``arm_velocity``: "ft", "combined", or "auto" on
    encoders coarser than ``auto_joint_interval``) and the trial allows it."""
    coarse = float(np.median(np.diff(ch.tj))) > opt.auto_joint_interval
    want = opt.arm_velocity if opt.arm_velocity != "auto" else ("ft" if coarse else "encoders")
    info: dict = {}
    if want not in ("ft", "combined"):
        return _FTVelocities(v_a=_NAN, v_a_post=_NAN, method="encoders", note="", info=info)
    if ch.flexible:
        return _FTVelocities(v_a=_NAN, v_a_post=_NAN, method="encoders", info=info,
                             note="flexible base: the F/T sensor rides on the moving platform (encoders used)")
    v_ft, v_ft_post, note = ft_tip_velocity(measured, robot, ch.n, c, ch.tj, ch.Q, opt, where, info=info)
    return _FTVelocities(v_a=v_ft, v_a_post=v_ft_post, method="encoders" if note else want, note=note, info=info)


def _encoder_velocities(robot: Robot, ch: _Channels, c: ContactWindow, win: _ArmWindow, tip: _TipSeries, *,
                        method: str, opt: IdentifyOptions) -> _EncoderVelocities:
    """The encoders' tip velocities: the windows checked, then the joint-space model or the
    tip-space model fitted (neither when the F/T alone serves)."""
    info: dict = {}
    va_rel, va_post_rel, n_pre, n_con, n_post, why = arm_fit(win.t, tip.s, c.start, c.end, win.cin, win.post_window,
                                                             opt, fit=method != "ft" and not win.joint_model,
                                                             info=info)
    # m_eff_estimator="impulse": the tip's velocity change through the start pose's
    # Jacobian, n.J(q_s)(qd' - qd) (eq 11's impulsive limit), beside the edge velocities
    # (which eq 12 and the result keep). The joint model and the F/T give it from their
    # joint velocities; the tip-space models are fitted again on the joint samples mapped
    # linearly through J(q_s) (same model, same windows)
    impulse_estimator = opt.m_eff_estimator == "impulse"
    delta_lin = _NAN
    if win.joint_model and method != "ft" and not why:
        va_rel, va_post_rel = joint_dynamics_fit(robot, ch.n, win.t, win.Q, c, win.cin, win.servo[0], win.servo[1],
                                                 win.post_window, opt, info=info)
        if impulse_estimator:
            delta_lin = info.get("v_post_start_jacobian", _NAN) - va_rel
    elif impulse_estimator and method != "ft" and not why:
        s_lin = start_jacobian_series(robot, ch.n, win.t, win.Q, c.start, tip.R_base, tip.tip0)
        v_lin, v_lin_post, *_ = arm_fit(win.t, s_lin, c.start, c.end, win.cin, win.post_window, opt)
        delta_lin = v_lin_post - v_lin
    return _EncoderVelocities(v_a=va_rel, v_a_post=va_post_rel, delta_lin=delta_lin, n_pre=n_pre, n_contact=n_con,
                              n_post=n_post, why=why, info=info)


def _chosen_velocities(enc: _EncoderVelocities, ft: _FTVelocities, *,
                       impulse_estimator: bool) -> tuple[float, float, float, str, str]:
    """``(v_a, v'_a, delta_lin, method, note)`` of the method used: the F/T's, the
    encoders', or ``v'_a - v_a`` of both weighted by their variances ("combined"; falls
    back to the encoders without both variances)."""
    va_rel, va_post_rel, delta_lin = enc.v_a, enc.v_a_post, enc.delta_lin
    method, note = ft.method, ft.note
    if enc.why:
        return va_rel, va_post_rel, delta_lin, method, note
    if method == "ft":
        va_rel, va_post_rel = ft.v_a, ft.v_a_post
        if impulse_estimator:
            delta_lin = ft.info.get("v_post_start_jacobian", _NAN) - ft.v_a
    elif method == "combined":
        # v'_a - v_a from the encoders and from the F/T, weighted by their variances (the
        # encoder fit's residual scatter; the F/T noise integrated over the contact); v_a
        # from the encoders
        se, sf = enc.info.get("sd_delta", _NAN), ft.info.get("sd_delta", _NAN)
        if math.isfinite(se) and math.isfinite(sf) and se > 0 and sf > 0:
            we, wf = 1.0 / se**2, 1.0 / sf**2
            delta = (we * (va_post_rel - va_rel) + wf * (ft.v_a_post - ft.v_a)) / (we + wf)
            va_post_rel = va_rel + delta
            if impulse_estimator:
                delta_lin = (we * delta_lin + wf * (ft.info.get("v_post_start_jacobian", _NAN) - ft.v_a)) / (we + wf)
        else:
            method, note = "encoders", "no uncertainty for the encoder or F/T estimate (encoders used)"
    return va_rel, va_post_rel, delta_lin, method, note


# ----------------------------------------------------------------------------------------
# 4. m* and e
# ----------------------------------------------------------------------------------------
def _m_eff_and_e(ch: _Channels, hammer: _Hammer, arm: _ArmVelocities, *, impulse_estimator: bool) -> _Estimate:
    """m* from eq 10 (or the contact impulse over eq 11's impulsive-limit velocity change)
    and e from eq 12, with the base point's velocities added to the arm's."""
    v_b, v_b_post = hammer.v_b, hammer.v_b_post
    v_a = arm.v_a + arm.v_base_pre
    v_a_post = arm.v_a_post + arm.v_base_post
    dva = v_a_post - v_a
    if impulse_estimator:
        # P / n.J(q_s)(qd' - qd): the contact impulse from the hammer (user guide,
        # *Identification*, step 4) over the impulsive-limit tip velocity change (the base's part as measured)
        imp_mom = contact_impulse(ch.m_b, ch.radius, v_b, hammer.theta_start, v_b_post, hammer.theta_end,
                                   (hammer.w2_pre, hammer.w2_post), ch.tp, ch.theta, arm.cin)
        dv_m = arm.delta_lin + (arm.v_base_post - arm.v_base_pre)
    else:
        imp_mom = ch.m_b * (v_b - v_b_post)       # eq 10
        dv_m = dva
    with np.errstate(divide="ignore", invalid="ignore"):
        m_eff = imp_mom / dv_m if dv_m != 0 else float("inf")
        e = (v_a_post - v_b_post) / (v_b - v_a) if (v_b - v_a) != 0 else _NAN
    return _Estimate(v_a=v_a, v_a_post=v_a_post, dv_a=dva, dv_m=dv_m, impulse_momentum=imp_mom, m_eff=m_eff, e=e)


# ----------------------------------------------------------------------------------------
# 5. exclusion and the result
# ----------------------------------------------------------------------------------------
def _estimate_reasons(est: _Estimate, hammer: _Hammer, *, impulse_estimator: bool) -> list[str]:
    """Why velocities that passed every window check still give no trustworthy m*."""
    reasons = []
    if not hammer.v_b - est.v_a > 0:
        reasons.append(f"the hammer does not approach the tip (v_b - v_a = {hammer.v_b - est.v_a:.4g} m/s)")
    if not est.dv_a > 0:
        reasons.append(f"the arm tip did not move along n (v'_a - v_a = {est.dv_a:.4g} m/s)")
    elif impulse_estimator and not est.dv_m > 0:
        reasons.append(f"the arm tip did not move along n through the start pose's Jacobian "
                       f"(n.J(q_s)(qd' - qd) = {est.dv_m:.4g} m/s)")
    elif impulse_estimator and not math.isfinite(est.impulse_momentum):
        reasons.append("no pendulum w^2 to size the gravity impulse over the contact")
    return reasons


def _result(c: ContactWindow, hammer: _Hammer, arm: _ArmVelocities, est: _Estimate, reasons: list[str],
            ident: dict) -> TrialIdentification:
    """The trial's :class:`TrialIdentification`, excluded when there is a reason."""
    return TrialIdentification(
        m_eff=float(est.m_eff), e=float(est.e), v_a=float(est.v_a), v_a_post=float(est.v_a_post),
        v_b=float(hammer.v_b), v_b_post=float(hammer.v_b_post), impulse=c.impulse,
        impulse_momentum=float(est.impulse_momentum), contact_start=c.start, contact_end=c.end, peak_force=c.peak,
        excluded=bool(reasons), reason="; ".join(reasons), theta_contact=hammer.theta_start,
        n_joint_pre=arm.n_pre, n_joint_contact=arm.n_contact, n_joint_post=arm.n_post, arm_velocity=arm.method,
        arm_velocity_note=arm.note, **ident,
    )
