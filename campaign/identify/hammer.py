"""The hammer (pendulum) side: its velocity at the contact edges and the contact impulse it delivers."""

from __future__ import annotations

import math

import numpy as np

from .contact import ContactInput
from .options import IdentifyOptions


# ----------------------------------------------------------------------------------------
# hammer
# ----------------------------------------------------------------------------------------
def _pendulum_window(t: np.ndarray, th: np.ndarray, t_edge: float, side: str, length: float, guard: float,
                     stop_time: float) -> np.ndarray:
    """Indices of the one-sided pendulum window; a run of one encoder count lasting
    ``stop_time`` or longer (the device's brake holding the hammer, or the hammer at rest)
    ends the window on the far side (post: the window stops before the run; pre: it starts
    after it)."""
    if side == "pre":
        sel = (t <= t_edge - guard) & (t >= t_edge - guard - length)
    elif side == "post":
        sel = (t >= t_edge + guard) & (t <= t_edge + guard + length)
    else:
        raise ValueError(f"side must be 'pre' or 'post', got {side!r}")
    idx = np.flatnonzero(sel)
    if idx.size < 2 or not stop_time > 0:
        return idx
    y, x = th[idx], t[idx]
    change = np.flatnonzero(np.diff(y) != 0)          # the count changes between k and k+1
    bounds = np.concatenate([[-1], change, [y.size - 1]])
    # runs of equal counts: samples bounds[i]+1 .. bounds[i+1]
    for i in (range(bounds.size - 1) if side == "post" else range(bounds.size - 2, -1, -1)):
        a, b = bounds[i] + 1, bounds[i + 1]
        if x[b] - x[a] >= stop_time:
            return idx[:a] if side == "post" else idx[b + 1:]
    return idx


def hammer_velocity(t, theta, t_edge: float, side: str, radius: float,
                    options: IdentifyOptions | None = None) -> tuple[float, float, int]:
    """Hammer velocity along n at a contact edge from the pendulum encoder.

    ``pendulum_model="ode"`` (default): the free pendulum's equation of motion
    ``theta'' = -w^2 sin(theta)`` written as the linear model
    ``theta(t) = a + b (t - t_edge) - w^2 S2(t)``, ``S2`` the double time integral of
    ``sin(theta)`` of the measured samples (trapezoids), fitted by linear least squares
    (``a``, ``b``, ``w^2``) on the one-sided window of ``pendulum_pre_window``
    (``pendulum_post_window``) ending (starting) ``pendulum_guard`` away from ``t_edge``;
    ``theta'(t_edge) = b - w^2 S1(t_edge)``. The model holds over the whole free swing (no
    truncation), so the windows can be long enough to average the encoder's quantisation.
    ``pendulum_model="poly"``: a polynomial of degree ``pendulum_degree`` on a window of
    ``pendulum_window``, evaluated at ``t_edge`` (kept for comparison).
    Either way ``v = r theta' cos(theta)`` [m/s]. A run of one count lasting
    ``pendulum_stop_time`` (the brake holding the hammer) ends the window.

    Returns
    -------
    v : float
        Hammer velocity along n [m/s] (``nan`` when the window has too few samples).
    theta_edge : float
        Pendulum angle at the edge [rad].
    n : int
        Samples in the window.
    """
    v, th_e, nsel, _ = hammer_fit(t, theta, t_edge, side, radius, options)
    return v, th_e, nsel


def hammer_fit(t, theta, t_edge: float, side: str, radius: float, options: IdentifyOptions | None = None):
    """:func:`hammer_velocity` and, with the ODE model, the fitted ``w^2`` [1/s^2] and its
    variance from the fit's residual scatter (``(nan, nan)`` otherwise); returns
    ``(v, theta_edge, n, (w2, var_w2))``."""
    opt = options or IdentifyOptions()
    nan = float("nan")
    t = np.asarray(t, float)
    th = np.asarray(theta, float)
    if opt.pendulum_model == "poly":
        length = opt.pendulum_window
    else:
        length = opt.pendulum_pre_window if side == "pre" else opt.pendulum_post_window
    idx = _pendulum_window(t, th, t_edge, side, length, opt.pendulum_guard, opt.pendulum_stop_time)
    nsel = int(idx.size)
    need = opt.pendulum_degree + 3 if opt.pendulum_model == "poly" else 6
    if nsel < need:
        return nan, nan, nsel, (nan, nan)
    x, y = t[idx], th[idx]
    if opt.pendulum_model == "poly":
        scale = length
        c = np.polynomial.polynomial.polyfit((x - t_edge) / scale, y, opt.pendulum_degree)
        th_e = float(c[0])
        thd_e = float(c[1]) / scale
        return float(radius * thd_e * math.cos(th_e)), th_e, nsel, (nan, nan)
    s = np.sin(y)
    S1 = np.concatenate([[0.0], np.cumsum(0.5 * (s[1:] + s[:-1]) * np.diff(x))])
    S2 = np.concatenate([[0.0], np.cumsum(0.5 * (S1[1:] + S1[:-1]) * np.diff(x))])
    # the integrals from the window's first sample to the edge (the last stretch, at most
    # the guard plus a sample, with the nearest sample's sin)
    if side == "pre":
        d = t_edge - x[-1]
        s1e, s2e = S1[-1] + s[-1] * d, S2[-1] + S1[-1] * d + 0.5 * s[-1] * d * d
    else:
        d = x[0] - t_edge
        s1e, s2e = -s[0] * d, 0.5 * s[0] * d * d
    scale = max(float(x[-1] - x[0]), 1e-12)
    A = np.column_stack([np.ones_like(x), (x - t_edge) / scale, S2 - s2e])
    colscale = np.abs(A).max(axis=0)
    colscale[colscale == 0] = 1.0
    p = np.linalg.lstsq(A / colscale, y, rcond=None)[0] / colscale
    th_e = float(p[0])
    thd_e = float(p[1]) / scale + float(p[2]) * s1e
    w2, var_w2 = -float(p[2]), nan
    if nsel > 3:
        # the variance of w^2 weighs the pre and post fits (m_eff_estimator="impulse"): a
        # hammer nearly at rest after the contact hardly determines it
        res = A @ p - y
        As = A / colscale
        try:
            var_w2 = float(res @ res) / (nsel - 3) * float(np.linalg.inv(As.T @ As)[2, 2]) / colscale[2] ** 2
        except np.linalg.LinAlgError:
            var_w2 = nan
    return float(radius * thd_e * math.cos(th_e)), th_e, nsel, (w2, var_w2)


def contact_impulse(m_b: float, radius: float, v_b: float, th_s: float, v_b_post: float, th_e: float, w2s,
                     tp: np.ndarray, theta: np.ndarray, cin: ContactInput) -> float:
    """The contact impulse along n from the pendulum, gravity's impulse removed [N s].

    The hammer (pivot at rest, ``m_b = I_p / r^2``, the contact force ``F`` along n at the
    head, lever arm ``r cos(theta)``) obeys ``m_b r theta'' = -m_b r w^2 sin(theta) -
    F cos(theta)``, so over the contact ``[t_s, t_e]``::

        int F cos(theta) dt = m_b r (theta'_s - theta'_e) - m_b r w^2 int sin(theta) dt

    and ``P = int F dt`` is that over ``kappa = int F cos(theta) dt / int F dt``, the mean of
    ``cos(theta)`` weighted by the piezo force shape. Eq 10's ``m_b (v_b - v'_b)``
    (``v = r theta' cos(theta)``) holds the gravity term, 0.35-0.55 % of ``P`` on a 40 ms
    contact while the hammer swings up through the bottom. ``theta'`` at the edges from the
    ODE fits (``v / (r cos(theta))``), ``theta`` inside the contact from the encoder
    (interpolated on the piezo clock), ``w^2`` the inverse-variance weighted mean of the
    pre- and post-contact fits' (``w2s``: ``(w2, var)`` pairs; their plain mean when a
    variance is missing). ``nan`` without a finite ``w^2``.
    """
    pairs = [(w, v) for w, v in w2s if math.isfinite(w)]
    if not pairs:
        return float("nan")
    if all(math.isfinite(v) and v > 0 for _, v in pairs):
        wt = np.array([1.0 / v for _, v in pairs])
        w2 = float(np.dot(wt, [w for w, _ in pairs]) / wt.sum())
    else:
        w2 = float(np.mean([w for w, _ in pairs]))
    thd_s = v_b / (radius * math.cos(th_s))
    thd_e = v_b_post / (radius * math.cos(th_e))
    tt = cin._tt
    th = np.interp(tt, tp, theta)
    sin_int = float(np.sum(0.5 * (np.sin(th[1:]) + np.sin(th[:-1])) * np.diff(tt)))
    cos_th = np.cos(th)
    kappa = float(np.sum(0.5 * (cos_th[1:] + cos_th[:-1]) * np.diff(cin._I)))   # cin._I: 0 -> 1
    return m_b * radius * (thd_s - thd_e - w2 * sin_int) / kappa
