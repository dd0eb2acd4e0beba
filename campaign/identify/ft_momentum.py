"""Arm velocity from the base F/T sensor: the arm's momentum, integrated from the measured wrench
and the piezo force (user guide, *Identification*, step 3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from ..core.errors import InputError
from ..core.lazy import LazyModule
from .channels import check_channels, time_coordinate
from .contact import ContactWindow
from .linalg import lstsq, solve
from .options import FT_CHANNELS, IdentifyOptions

#: imported on first use: the campaign's identification jobs read trials as plain arrays
#: (``load_trial(path, arrays=True)``) and so never pay ~0.6 s for xarray and pandas
xr = LazyModule("xarray")


def cross(a, b) -> np.ndarray:
    """``a x b`` of 3-vectors, or column by column of stacks (3, k) broadcast against each other.

    numpy.cross's products and differences in its order (the same numbers), without its
    ~30 us of axis handling per call (the F/T momentum balance calls it three times per
    F/T sample); a 3-vector is taken as three Python floats (the same IEEE products
    again, without numpy's per-element overhead).

    Parameters
    ----------
    a, b : array_like, shape (3,) or (3, k)

    Returns
    -------
    ndarray, shape (3,) or (3, k)
    """
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape == (3,):
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b.tolist()
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    a0, a1, a2 = a
    b0, b1, b2 = b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


#: the components of ``c x B`` per row: ``c[_NEXT] * B[_LAST] - c[_LAST] * B[_NEXT]``
_NEXT, _LAST = np.array([1, 2, 0]), np.array([2, 0, 1])


def cross_columns(c: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``c x B[:, j]`` for each column of ``B`` (3, k): :func:`cross`'s numbers, as whole rows."""
    return c.take(_NEXT)[:, None] * B.take(_LAST, axis=0) - c.take(_LAST)[:, None] * B.take(_NEXT, axis=0)


def _momentum_map(model, data, q, frame_id: int):
    """The arm's spatial-momentum map about the base origin and the impact point's kinematics.

    Returns ``(A, p, Jt, com)``: ``A`` (6 x nv) with ``h = A v`` = (linear momentum [N s],
    angular momentum about the base origin [N m s]), base axes; the impact point ``p`` [m];
    its translational Jacobian ``Jt`` (3 x nv, base axes); the arm's centre of mass [m].
    Pinocchio's centroidal map (about the centre of mass) shifted to the base origin. Link
    inertias only: the armature (reflected rotor inertia) is a joint-space term, and the
    mounting's F/T sensor does not see it either (:func:`campaign.rig.sensors.base_wrench`).
    """
    A = np.array(pin.computeCentroidalMap(model, data, q))
    com = np.array(data.com[0])
    A[3:] += cross_columns(com, A[:3])   # L_O = L_G + c x P (each column of P)
    pin.updateFramePlacements(model, data)
    p = np.array(data.oMf[frame_id].translation)
    Jt = pin.computeFrameJacobian(model, data, q, frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    return A, p, Jt, com


def zoh_integral(ts: np.ndarray, tau: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Integral from ``ts[0]`` to each ``t`` of the zero-order-hold signal ``tau`` (value
    ``tau[j]`` held on ``[ts[j], ts[j+1])``), shape (len(t), ncols)."""
    cum = np.vstack([np.zeros((1, tau.shape[1])), np.cumsum(tau[:-1] * np.diff(ts)[:, None], axis=0)])
    j = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, ts.size - 1)
    return cum[j] + tau[j] * (t - ts[j])[:, None]



@dataclasses.dataclass(frozen=True)
class _FTRecord:
    """The F/T channels of a trial, checked usable around the contact.

    Attributes
    ----------
    t : ndarray, shape (T,)
        The F/T clock [s].
    W : ndarray, shape (T, 6)
        Force [N] and torque [N m] readings, base axes.
    W_rest, sig : ndarray, shape (6,)
        Mean and standard deviation of the readings over the rest window before the contact.
    pre : ndarray of bool
        The joint samples of the pre-contact window (the encoders' start state).
    """

    t: np.ndarray
    W: np.ndarray
    W_rest: np.ndarray
    sig: np.ndarray
    pre: np.ndarray


@dataclasses.dataclass(frozen=True)
class _Balance:
    """The momentum balance's inputs on the F/T grid (the samples from the last before the
    contact start to the first at or after its end).

    Attributes
    ----------
    grid : ndarray, shape (K,)
        F/T sample times [s].
    dW : ndarray, shape (K, 6)
        Reading change from rest.
    Ig : ndarray, shape (K,)
        Accumulated piezo impulse [N s].
    mg : ndarray, shape (3,)
        The arm's weight as the sensor reads it at rest (gravity's size and sign) [N].
    held : tuple of ndarray or None
        The servo torque change since the grid's start, integrated exactly (zero-order
        hold) and as each sample reads it, ``(Tcum, tau_at)``; None without a usable servo channel.
    rows : slice
        The wrench rows the velocity is solved from (``ft_rows``).
    wrow : ndarray
        Their weights, the inverse rest scatter (with a floor).
    """

    grid: np.ndarray
    dW: np.ndarray
    Ig: np.ndarray
    mg: np.ndarray
    held: tuple | None
    rows: slice
    wrow: np.ndarray


def ft_tip_velocity(measured: xr.Dataset, robot, n: np.ndarray, c: ContactWindow, tj: np.ndarray, Q: np.ndarray,
                    opt: IdentifyOptions, where: str, info: dict | None = None) -> tuple[float, float, str]:
    """Tip velocities along n at the contact edges from the arm's momentum balance.

    ``dh/dt = (contact wrench) + (gravity wrench change) - (F/T reading change)`` on the
    F/T clock (user guide, *Identification*, step 3): the momentum ``h = A(q) v`` starts
    from the encoders' pre-contact state and is integrated over the contact; each step's
    joint velocities are solved from it.

    Parameters
    ----------
    measured : xarray.Dataset or campaign.scene.schema.GroupArrays
        The trial's ``measured`` group (channels ``ft_force``, ``ft_torque``, ``f_piezo``,
        optionally ``tau_cmd``).
    robot : campaign.model.robot.Robot
    n : ndarray, shape (3,)
        Unit impact direction, base frame.
    c : ContactWindow
    tj, Q : ndarray, shapes (N,), (N, nv)
        Joint encoder samples.
    opt : IdentifyOptions
    where : str
        Name of the trial in error messages.
    info : dict, optional
        Receives ``sd_delta`` (the F/T noise's standard deviation of ``v'_a - v_a``) and
        ``v_post_start_jacobian``, the end velocities mapped by the start pose's Jacobian,
        ``n . J(q_s) v(t_e)`` (``m_eff_estimator="impulse"``).

    Returns
    -------
    v_a, v_a_post : float
        Tip velocities along n at the contact start and end [m/s] (nan when the F/T
        channels cannot be used).
    why : str
        Why the F/T channels cannot be used ("" when they can; the caller falls back to the
        encoders and records why).

    Raises
    ------
    InputError
        The F/T channels have the wrong dims or non-finite samples.
    """
    nan = float("nan")
    ft, why = _ft_record(measured, c, tj, opt, where)
    if why:
        return nan, nan, why
    model = robot.model
    data = model.createData()
    # pre-contact state from the encoders: a line per joint over the pre window
    x = tj[ft.pre] - c.start
    qs, qd = np.empty(model.nv), np.empty(model.nv)
    for i in range(model.nv):
        qs[i], qd[i] = np.polynomial.polynomial.polyfit(x, Q[ft.pre, i], 1)
    _, _, Jt, com0 = _momentum_map(model, data, qs, robot.impact_frame_id)
    v_a = float(n @ Jt @ qd)
    Jn_s = n @ Jt              # the start pose's Jacobian (m_eff_estimator="impulse")

    bal = _balance_inputs(measured, ft, c, opt, where)
    q0 = qs + qd * (bal.grid[0] - c.start)
    u, u_lin, A, Jt = _momentum_balance(model, data, robot.impact_frame_id, n, Jn_s, q0, qd, com0, bal)
    v_post = float(np.interp(c.end, bal.grid, u))
    if info is not None:
        info["v_post_start_jacobian"] = float(np.interp(c.end, bal.grid, u_lin))
        info["sd_delta"] = _noise_sd(n, A, Jt, ft.sig, bal)
    return v_a, v_post, ""


def _ft_record(measured: xr.Dataset, c: ContactWindow, tj: np.ndarray, opt: IdentifyOptions,
               where: str) -> tuple[_FTRecord | None, str]:
    """The F/T channels checked usable for the momentum balance, or ``(None, why)`` not:
    missing, too few samples at rest or over the contact, a record that does not cover it,
    too few joint samples before it, or a reading that does not respond to it."""
    if not all(name in measured.variables for name in FT_CHANNELS):
        return None, "no F/T channels (ft_force, ft_torque)"
    check_channels(measured, FT_CHANNELS, where)
    tft = time_coordinate(measured, "t_ft", where)
    W = np.hstack([np.asarray(measured["ft_force"].values, float), np.asarray(measured["ft_torque"].values, float)])
    if not np.all(np.isfinite(W)):
        raise InputError(f"{where}: F/T channels have non-finite samples")
    rest = (tft <= c.start - opt.ft_guard) & (tft >= c.start - opt.ft_guard - opt.ft_rest_window)
    if rest.sum() < 5:
        return None, f"only {int(rest.sum())} F/T samples in the {opt.ft_rest_window:g} s before the contact"
    if not (tft[0] < c.start and tft[-1] >= c.end):
        return None, "the F/T record does not cover the contact"
    n_in = int(((tft >= c.start) & (tft <= c.end)).sum())
    if n_in < opt.ft_min_samples:
        # a contact of a few F/T samples is not resolved by trapezoids (ideal scene: 1 ms)
        return None, f"the contact spans only {n_in} F/T samples (need {opt.ft_min_samples})"
    pre = (tj < c.start) & (tj >= c.start - opt.joint_pre_window)
    if pre.sum() < 2:
        return None, "fewer than 2 joint samples before the contact"
    W_rest = W[rest].mean(axis=0)
    sig = W[rest].std(axis=0)
    during = (tft >= c.start) & (tft <= c.end)
    dF = np.abs(W[during, :3] - W_rest[:3]).max() if during.any() else 0.0
    # on a fixed base the mounting carries the joint-1 reaction: tens of per cent of the
    # contact force; a channel that does not move is not a sensor reading (e.g. zeros)
    if not dF > max(5.0 * sig[:3].max(), 0.01 * c.peak):
        return None, (f"the F/T force does not respond to the contact (change {dF:.3g} N, "
                      f"noise {sig[:3].max():.3g} N, contact peak {c.peak:.3g} N)")
    return _FTRecord(t=tft, W=W, W_rest=W_rest, sig=sig, pre=pre), ""


def _balance_inputs(measured: xr.Dataset, ft: _FTRecord, c: ContactWindow, opt: IdentifyOptions,
                    where: str) -> _Balance:
    """The F/T grid over the contact with the reading change, the accumulated piezo impulse
    along n (baseline-corrected, clipped at 0) and the held servo torque on it."""
    tf = time_coordinate(measured, "t_force", where)
    r = np.asarray(measured["f_piezo"].values, float) - c.baseline
    inside = (tf > c.start) & (tf < c.end)
    tt = np.concatenate([[c.start], tf[inside], [c.end]])
    rr = np.concatenate([[0.0], np.clip(r[inside], 0.0, None), [0.0]])
    I = np.concatenate([[0.0], np.cumsum(0.5 * (rr[1:] + rr[:-1]) * np.diff(tt))])

    k0 = int(np.searchsorted(ft.t, c.start)) - 1          # last F/T sample before the start
    k1 = int(np.searchsorted(ft.t, c.end))                # first F/T sample at/after the end
    grid = ft.t[k0:k1 + 1]
    dW = ft.W[k0:k1 + 1] - ft.W_rest
    Ig = np.interp(grid, tt, I, left=0.0, right=I[-1])
    rows = {"all": slice(0, 6), "linear": slice(0, 3), "angular": slice(3, 6)}[opt.ft_rows]
    wrow = 1.0 / np.maximum(ft.sig, np.array([1e-3] * 3 + [1e-4] * 3))[rows]
    return _Balance(grid=grid, dW=dW, Ig=Ig, mg=ft.W_rest[:3], held=_held_servo_torque(measured, grid, where),
                    rows=rows, wrow=wrow)


def _held_servo_torque(measured: xr.Dataset, grid: np.ndarray, where: str) -> tuple | None:
    """``(Tcum, tau_at)``: the servo torque change since ``grid[0]`` integrated exactly to
    each grid time, and as each sample reads it; None without a finite ``tau_cmd`` that
    starts by ``grid[0]``.

    Servo torques are held between ticks, and each tick steps the reading by -A H^-1 dtau;
    a trapezoid across those steps is off by half a tick per step (1-3 % of h at High
    gains), so the held part is integrated exactly and only the rest by trapezoids.
    """
    if not ("tau_cmd" in measured.variables and tuple(measured["tau_cmd"].dims) == ("t_servo", "joint")):
        return None
    ts = time_coordinate(measured, "t_servo", where)
    tau = np.asarray(measured["tau_cmd"].values, float)
    if not bool(np.all(np.isfinite(tau)) and ts[0] <= grid[0]):
        return None
    tau0 = tau[int(np.searchsorted(ts, grid[0], side="right")) - 1]
    Tcum = zoh_integral(ts, tau - tau0, grid)
    # a sample on a tick reads the new torque (the command written at the tick)
    tau_at = tau[np.clip(np.searchsorted(ts, grid + 1e-9 * (grid[1] - grid[0]), side="right") - 1, 0, None)] - tau0
    return Tcum, tau_at


def _servo_wrench(A: np.ndarray, H: np.ndarray, dtau: np.ndarray) -> np.ndarray:
    """The reading change a servo torque change ``dtau`` causes: ``-A H^-1 dtau``."""
    return -(A @ solve(H, dtau))


def _momentum_balance(model, data, frame_id: int, n: np.ndarray, Jn_s: np.ndarray, q: np.ndarray, qd: np.ndarray,
                      com0: np.ndarray, bal: _Balance):
    """Integrate the arm's momentum over the F/T grid from the state ``(q, qd)`` at its start.

    Returns ``(u, u_lin, A, Jt)``: the tip velocity along n at each grid time, the same
    through the start pose's Jacobian ``Jn_s``, and the momentum map and tip Jacobian at
    the grid's end.
    """
    grid, dW, Ig, rows, wrow = bal.grid, bal.dW, bal.Ig, bal.rows, bal.wrow
    servo = bal.held is not None
    Tcum, tau_at = bal.held if servo else (None, None)
    v = qd.copy()
    A, p, Jt, com = _momentum_map(model, data, q, frame_id)
    h = A @ v
    H = pin.crba(model, data, q)
    u = np.empty(grid.size)
    u[0] = n @ Jt @ v
    u_lin = np.empty(grid.size)
    u_lin[0] = Jn_s @ v
    prev_smooth = dW[0] - (_servo_wrench(A, H, tau_at[0]) if servo else 0.0)
    v_prev = v
    for k in range(1, grid.size):
        dt = grid[k] - grid[k - 1]
        dI = Ig[k] - Ig[k - 1]
        # the joints barely move: second-order Adams-Bashforth for q is ample; the moments
        # of the contact force and of gravity take the mean of the step's end points (the
        # gravity term is 10-20 % of the angular momentum at the contact end, so a step of lag
        # in the centre of mass would cost 1-2 %)
        p0, com_prev = p, com
        q = q + (1.5 * v - 0.5 * v_prev) * dt
        A_prev, H_prev = A, H
        A, p, Jt, com = _momentum_map(model, data, q, frame_id)
        dh = np.empty(6)
        dh[:3] = n * dI
        dh[3:] = cross(0.5 * (p0 + p), n) * dI
        dh[3:] += cross(0.5 * (com_prev + com) - com0, bal.mg) * dt
        if servo:
            H = pin.crba(model, data, q)
            smooth = dW[k] - _servo_wrench(A, H, tau_at[k])
            dh -= (0.5 * (smooth + prev_smooth) * dt
                   + _servo_wrench(0.5 * (A_prev + A), 0.5 * (H_prev + H), Tcum[k] - Tcum[k - 1]))
            prev_smooth = smooth
        else:
            dh -= 0.5 * (dW[k] + dW[k - 1]) * dt
        h = h + dh
        v_prev = v
        Aw = A[rows] * wrow[:, None]
        v = lstsq(Aw, h[rows] * wrow)
        u[k] = n @ Jt @ v
        u_lin[k] = Jn_s @ v
    return u, u_lin, A, Jt


def _noise_sd(n: np.ndarray, A: np.ndarray, Jt: np.ndarray, sig: np.ndarray, bal: _Balance) -> float:
    """Standard deviation of ``v'_a - v_a`` from the F/T noise (the rest window's scatter
    per row) integrated over the contact: a random walk of var sig^2 dt^2 per sample in h,
    mapped to the tip like v."""
    dt = float(np.median(np.diff(bal.grid)))
    Aw = A[bal.rows] * bal.wrow[:, None]
    gtip = (n @ Jt) @ np.linalg.pinv(Aw) * bal.wrow
    return float(np.sqrt(np.sum((gtip * sig[bal.rows]) ** 2) * dt * dt * (bal.grid.size - 1)))
