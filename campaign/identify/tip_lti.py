"""Tip-space arm velocity: fits of the impact point's position along n (LTI, polynomial, one-sided)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..model.exiit import impact_jacobian
from .contact import ContactInput
from .linalg import lstsq
from .options import IdentifyOptions


# ----------------------------------------------------------------------------------------
# arm
# ----------------------------------------------------------------------------------------
def rotate(rotvec: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate ``v`` ((3,) or (N, 3)) by the rotation vectors ``rotvec`` (N, 3) (Rodrigues)."""
    rotvec = np.atleast_2d(np.asarray(rotvec, float))
    v = np.broadcast_to(np.asarray(v, float), rotvec.shape)
    th = np.linalg.norm(rotvec, axis=1)[:, None]
    k = rotvec / np.where(th > 0, th, 1.0)
    c, s = np.cos(th), np.sin(th)
    return v * c + np.cross(k, v) * s + k * np.sum(k * v, axis=1, keepdims=True) * (1 - c)


def tip_positions(robot, Q: np.ndarray) -> np.ndarray:
    """Impact-point positions (N, 3) in the arm's base frame [m] (forward kinematics)."""
    model = robot.model
    data = model.createData()
    out = np.empty((Q.shape[0], 3))
    for i, q in enumerate(Q):
        pin.framesForwardKinematics(model, data, q)
        out[i] = data.oMf[robot.impact_frame_id].translation
    return out


def arm_fit(t, s, t_s, t_e, cin: ContactInput, post_window: float, opt: IdentifyOptions, fit: bool = True,
             info: dict | None = None):
    """Velocities along n at the contact edges from a position series ``s(t)`` [m].

    Returns ``(v_a, v'_a, n_pre, n_contact, n_post, reason)``; ``reason`` is non-empty
    (and the velocities nan) when a window has too few samples. With ``fit=False`` only the
    windows are checked (velocities nan).
    """
    pre = (t < t_s) & (t >= t_s - opt.joint_pre_window)
    contact = (t >= t_s) & (t <= t_e)
    post = (t > t_e) & (t <= t_e + post_window)
    n_pre, n_con, n_post = int(pre.sum()), int(contact.sum()), int(post.sum())
    k = opt.resistance_order
    reasons = []
    if n_pre < opt.min_pre_samples:
        reasons.append(f"only {n_pre} joint samples in the {opt.joint_pre_window:g} s before the contact "
                       f"(need {opt.min_pre_samples})")
    need_post = max(opt.min_post_samples, k + 2 if opt.arm_model == "onesided" else 0)
    if n_post < need_post:
        reasons.append(f"only {n_post} joint samples in the {post_window:g} s after the contact "
                       f"(need {need_post})")
    if reasons:
        return float("nan"), float("nan"), n_pre, n_con, n_post, "; ".join(reasons)
    if not fit:
        return float("nan"), float("nan"), n_pre, n_con, n_post, ""
    T = t_e - t_s
    sel = pre | contact | post
    if opt.arm_model in ("lti", "joint"):     # "joint" without a servo channel or on a flexible base
        v_pre, v_post = _lti_fit(t[sel], s[sel], t_s, t_e, cin, info=info)
    elif opt.arm_model == "poly":
        tt, ss = t[sel], s[sel]
        u = tt - t_s
        up = np.clip(u, 0.0, None)
        cols = [np.ones_like(u), u, cin.phi(tt)]
        for m in range(1, k + 1):
            cols.append(up ** (m + 1) / math.factorial(m + 1))
        A = np.column_stack(cols)
        sc = np.abs(A).max(axis=0)
        sc[sc == 0] = 1.0
        p, *_ = np.linalg.lstsq(A / sc, ss, rcond=None)
        p = p / sc
        v_pre = float(p[1])
        v_post = float(p[1] + p[2] + sum(p[2 + m] * T**m / math.factorial(m) for m in range(1, k + 1)))
    else:  # onesided
        c = np.polynomial.polynomial.polyfit(t[pre] - t_s, s[pre], 1)
        v_pre = float(c[1])
        c = np.polynomial.polynomial.polyfit((t[post] - t_e) / post_window, s[post], k + 1)
        v_post = float(c[1]) / post_window
    return v_pre, v_post, n_pre, n_con, n_post, ""


def _lti_kernels(a1: float, a0: float, x: np.ndarray):
    """Impulse responses of ``y'' + a1 y' + a0 y = delta``: position ``h`` and velocity ``h'``.

    Closed form with the (possibly complex) roots of ``s^2 + a1 s + a0``; the repeated-root
    limit ``t exp(r t)`` is used when the roots nearly coincide (including a1 = a0 = 0,
    the free double integrator ``h = t``).
    """
    disc = a1 * a1 - 4.0 * a0
    half = 0.5 * math.sqrt(abs(disc))     # |r1 - r2| / 2
    span = float(x[-1]) if x.size else 0.0
    alpha = -a1 / 2.0
    if 2.0 * half * max(span, 1e-12) < 1e-6:
        e = np.exp(alpha * x)
        return x * e, (1.0 + alpha * x) * e
    if disc > 0:    # real roots alpha +- half
        r1, r2 = alpha + half, alpha - half
        e1, e2 = np.exp(r1 * x), np.exp(r2 * x)
        return (e1 - e2) / (r1 - r2), (r1 * e1 - r2 * e2) / (r1 - r2)
    # complex roots alpha +- i half: the real parts of the same expressions
    e = np.exp(alpha * x)
    s, c = np.sin(half * x), np.cos(half * x)
    return e * s / half, e * (c + alpha * s / half)


class _GridPoints:
    """Where a fit reads the responses on ``cin.grid``: the grid intervals around the times
    ``x``, as :func:`numpy.interp` brackets them, and the grid samples those intervals need.

    The responses are convolutions over the whole grid (up to 20,000 samples after a long
    post-contact window) of which a fit reads a few dozen; evaluating the convolution at
    the samples read alone gives the same numbers (sums of the same products) at a
    fraction of the cost.
    """

    def __init__(self, grid: np.ndarray, x: np.ndarray):
        self.grid, self.x = grid, np.asarray(x, float)
        n = grid.size
        self.j = np.clip(np.searchsorted(grid, self.x, side="right") - 1, 0, max(n - 2, 0))
        self.needed, inverse = np.unique(np.concatenate([self.j, np.minimum(self.j + 1, n - 1)]),
                                         return_inverse=True)
        self.at_j, self.at_j1 = inverse[:self.j.size], inverse[self.j.size:]
        self._lags: dict[tuple[int, int], np.ndarray] = {}
        # numpy.interp's cases, fixed by the times: on a grid sample, past either end
        if n >= 2:
            self._step = grid[self.j + 1] - grid[self.j]
            self._offset = self.x - grid[self.j]
            self._on_sample = self.x == grid[self.j]
            self._right = self.x >= grid[-1]
            self._left = self.x < grid[0]
            self._special = bool(self._on_sample.any() or self._right.any() or self._left.any())

    def interp(self, values: np.ndarray) -> np.ndarray:
        """:func:`numpy.interp` of a response given at ``needed`` (its formula, its end values)."""
        y0, y1 = values[self.at_j], values[self.at_j1]
        if self.grid.size < 2:
            return np.full(self.x.shape, y0[0] if y0.size else np.nan)
        with np.errstate(invalid="ignore", divide="ignore"):
            out = (y1 - y0) / self._step * self._offset + y0
        if self._special:
            out = np.where(self._on_sample, y0, out)
            out = np.where(self._right, y1, out)
            out = np.where(self._left, y0, out)
        return out


    def lags(self, support: int, n: int) -> np.ndarray:
        """Indices into ``h`` padded with one zero (length ``n + 1``) of ``h[k - j]`` for each
        needed ``k`` and ``0 <= j < support`` (the zero where ``k < j``); made once per fit."""
        key = (support, n)
        if key not in self._lags:
            lag = self.needed[:, None] - np.arange(support)[None, :]
            self._lags[key] = np.where(lag >= 0, lag, n)
        return self._lags[key]


def _convolution_at(g: np.ndarray, support: int, h: np.ndarray, points: _GridPoints) -> np.ndarray:
    """``sum_j g[j] h[k - j]`` over ``0 <= j <= k`` at the indices ``k = points.needed``,
    for a ``g`` that is zero from index ``support`` on (``np.convolve(g, h)[k]``)."""
    padded = np.concatenate([h, [0.0]])
    return padded[points.lags(support, h.size)] @ g[:support]


def _lti_responses(cin: ContactInput, a1: float, a0: float, with_step: bool, velocity: bool = True,
                   points: _GridPoints | None = None):
    """Position and velocity responses of ``y'' + a1 y' + a0 y = input`` on ``cin.grid``.

    Inputs: the normalised contact force ``g`` (integral 1) and, with ``with_step``, a
    unit step from the contact start. Trapezoid-rule convolutions with the closed-form
    impulse responses. Returns a list of (position, velocity) arrays; the force's velocity
    response is None unless ``velocity`` (the fit's residuals need positions only). With
    ``points``, each response is evaluated at ``points.needed`` only (the grid samples a
    fit reads; :class:`_GridPoints`).
    """
    dt = cin.dt
    x = cin.grid - cin.grid[0]
    h, hd = _lti_kernels(a1, a0, x)
    n = x.size
    out = []
    if points is None:
        pos = np.convolve(cin.g, h)[:n] * dt                              # h(0) = 0
        vel = None
        if velocity:
            vel = np.convolve(cin.g, hd)[:n] * dt - 0.5 * dt * cin.g * hd[0]  # trapezoid end weight
    else:
        k = points.needed
        pos = _convolution_at(cin.g, cin.support, h, points) * dt
        vel = None
        if velocity:
            vel = _convolution_at(cin.g, cin.support, hd, points) * dt - 0.5 * dt * cin.g[k] * hd[0]
    out.append((pos, vel))
    if with_step:
        # response to a unit step: the integrals of h and h' from 0 to t
        ipos = np.concatenate([[0.0], np.cumsum(0.5 * (h[1:] + h[:-1]) * dt)])
        ivel = h
        if points is not None:
            ipos, ivel = ipos[points.needed], ivel[points.needed]
        out.append((ipos, ivel))
    return out


#: starting points (a1 [1/s], a0 [1/s^2]) of the resistance-law fit: nearly free, and damped
#: servo-like; the better end point wins
_LTI_STARTS = ((1.0, 0.0), (30.0, 300.0))


def _lti_fit(t, s, t_s, t_e, cin: ContactInput, with_step: bool = True, info: dict | None = None):
    """Fit ``s = s_s + v_a u + w y_f(t) + c y_step(t)`` (user guide, *Identification*, step 3, ``arm_model="lti"``).

    ``y_f`` and ``y_step`` are the responses of the joint-resistance law
    ``y'' + a1 y' + a0 y = input`` to the normalised measured force and to a unit step
    (Coulomb friction) from the contact start; ``(a1, a0) >= 0`` by bounded nonlinear least
    squares, the linear coefficients by variable projection, three starting points.
    Returns ``(v_a, v'_a)`` [m/s].
    """
    u = t - t_s
    after = t >= t_s
    # the responses are read at the samples after the contact start and at its end only
    samples = _GridPoints(cin.grid, t[after])
    both = _GridPoints(cin.grid, np.concatenate([t[after], [t_e]]))

    def design(x, velocity=False):
        resp = _lti_responses(cin, x[0], x[1], with_step, velocity, points=both if velocity else samples)
        cols = [np.ones_like(u), u]
        for pos, _ in resp:
            col = np.zeros_like(u)
            col[after] = (both if velocity else samples).interp(pos)[:samples.x.size]
            cols.append(col)
        return np.column_stack(cols), resp

    def solve(x, velocity=False):
        A, resp = design(x, velocity)
        sc = np.abs(A).max(axis=0)
        sc[sc == 0] = 1.0
        p = lstsq(A / sc, s)
        return p / sc, A, resp

    def resid(x):
        p, A, _ = solve(x)
        return A @ p - s

    from scipy.optimize import least_squares  # lazily: see campaign.identify.contact._edge_power

    best = None
    for x0 in _LTI_STARTS:
        r = least_squares(resid, x0, bounds=([0.0, 0.0], [1000.0, 1e5]), x_scale=[10.0, 500.0], method="trf")
        if best is None or r.cost < best.cost:
            best = r
    p, A, resp = solve(best.x, velocity=True)
    g_end = [float(both.interp(vel)[-1]) for _, vel in resp]
    v_post = p[1] + sum(p[2 + i] * g for i, g in enumerate(g_end))
    if info is not None:
        # standard deviation of v'_a - v_a from the residual scatter (linear coefficients at
        # the fitted a1, a0; 2 more degrees of freedom for those)
        res = A @ p - s
        dof = max(s.size - A.shape[1] - 2, 1)
        sc = np.abs(A).max(axis=0)
        sc[sc == 0] = 1.0
        gvec = np.zeros(A.shape[1])
        gvec[2:] = g_end
        row = np.linalg.pinv(A / sc).T @ (gvec / sc)
        info["sd_delta"] = float(math.sqrt(float(res @ res) / dof) * np.linalg.norm(row))
    return float(p[1]), float(v_post)


def start_jacobian_series(robot, n: np.ndarray, t: np.ndarray, Q: np.ndarray, t_s: float,
                           rb_w: np.ndarray | None = None, tip0: np.ndarray | None = None) -> np.ndarray:
    """The impact point's position along n with the joint motion mapped linearly through
    the Jacobian at the contact start: ``n . (p(q_s) + J(q_s) (q(t) - q_s))`` [m].

    The tip-space models (``lti``, ``poly``, ``onesided``) fitted to this series give
    ``n . J(q_s) qd`` at both edges, the tip velocity change of eq 11's impulsive limit
    (``m_eff_estimator="impulse"``), where forward kinematics gives ``n . J(q(t)) qd``.
    ``q_s`` is a line per joint over the pre-contact samples, evaluated at ``t_s``. On a
    flexible base (``rb_w``: the base rotation at the samples, ``tip0``: the tip at
    ``q_cmd``) the arm part is rotated into the inertial frame as the forward-kinematics
    series is; the base's own rotation over the contact is left as measured.
    """
    pre = t < t_s
    if pre.sum() >= 2:
        x = t[pre] - t_s
        q_s = np.array([np.polynomial.polynomial.polyfit(x, Q[pre, i], 1)[0] for i in range(Q.shape[1])])
    else:
        q_s = Q[pre].mean(axis=0) if pre.any() else Q[0]
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q_s)
    p_s = np.array(data.oMf[robot.impact_frame_id].translation)
    Jt_s = pin.computeFrameJacobian(model, data, q_s, robot.impact_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    P = p_s + (Q - q_s) @ Jt_s.T
    if rb_w is None:
        return P @ n
    return rotate(rb_w, P - tip0) @ n


def tip_displacement(robot, q_cmd, n, t, s, t_s, t_e, post_window, opt):
    """Largest tip displacement along n after the contact relative to the pre-contact mean
    [m], and the joint encoders' resolution projected on the tip along n [m]."""

    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q_cmd)
    Jn = n @ impact_jacobian(robot.model, data, q_cmd, robot.impact_frame_id)[:3]
    quantum = float(np.sum(np.abs(Jn) * robot.encoder_resolution))
    pre = (t < t_s) & (t >= t_s - opt.joint_pre_window)
    post = (t > t_e) & (t <= t_e + post_window)
    return float(np.max(s[post]) - np.mean(s[pre])), quantum
