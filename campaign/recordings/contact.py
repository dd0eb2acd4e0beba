"""The contact window of a recorded hit from a body's positions along the impact direction.

A body's position along n is modelled, around the contact, as its motion before the contact
(a polynomial in ``tau = t - t_s``: constant velocity, or constant acceleration) plus the
velocity change ``dv`` the contact brings over its duration ``T``, free in shape (a
piecewise-linear velocity profile with :data:`KNOTS` segments: a contact force may rise fast
and fall slowly), plus, for the constant-acceleration model, another acceleration after
the contact. For given ``t_s`` and ``T`` the model is linear in its other parameters, so
only ``t_s`` and ``T`` are searched (variable projection); the samples fitted are those
within ``pre`` seconds before and ``post`` seconds after the window. The contact window of
a hit is the shortest one the object's positions fit as well as the best
(:func:`fit_contact`; it takes several bodies sharing a window too).

The same model, with ``T`` and the profile fixed to the object's, finds when the end
effector's velocity change starts on the robot's clock (:func:`fit_onset`): the offset
between the two starts is the offset between the clocks.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import least_squares

__all__ = ["Body", "ContactFit", "KNOTS", "fit_contact", "fit_onset", "design", "noise_level", "velocity_change"]

#: segments of the velocity change's piecewise-linear profile over the contact
KNOTS = 6


@dataclasses.dataclass(frozen=True)
class ContactFit:
    """The contact window of a body: start ``t_s``, duration ``T`` [s]; the windows
    (start, duration) the samples fit as well (``windows``, residual per degree of freedom
    within two standard errors of the least) and their ranges; the velocity change ``dv``
    [m/s], the position noise ``sigma`` [m] the fit leaves, and the velocity change's
    profile at the knots as fractions of ``dv`` (``shape``)."""

    t_s: float
    T: float
    t_s_range: tuple[float, float]
    T_range: tuple[float, float]
    dv: float
    sigma: float
    shape: tuple[float, ...] = ()
    windows: tuple[tuple[float, float], ...] = ()


def design(t: np.ndarray, t_s: float, T: float, deg: int, knots: int = KNOTS,
           shape: tuple[float, ...] | None = None) -> np.ndarray:
    """The model's columns at times ``t``: the motion before the contact (``deg`` 1: constant
    velocity, 2: constant acceleration), the velocity change over ``[t_s, t_s + T]`` as a
    piecewise-linear profile with ``knots`` segments (0 at ``t_s``, free at each knot, held
    after ``t_s + T``: the last column's coefficient is the whole velocity change), and for
    ``deg`` 2 another acceleration after the contact. With ``shape`` (the profile at the knots
    as fractions of the whole change) the profile is that one, scaled: one column."""
    tau = t - t_s
    h = T / knots

    def ramp2(x):
        return 0.5 * np.maximum(x, 0.0) ** 2

    cols = [np.ones_like(t), tau] + ([0.5 * tau ** 2] if deg >= 2 else [])
    profile = [(ramp2(tau - (k - 1) * h) - 2 * ramp2(tau - k * h) + ramp2(tau - (k + 1) * h)) / h
               for k in range(1, knots)]
    profile.append((ramp2(tau - (knots - 1) * h) - ramp2(tau - T)) / h)
    if shape is None:
        cols += profile
    else:
        cols.append(np.column_stack(profile) @ np.asarray(shape, dtype=float))
    if deg >= 2:
        cols.append(ramp2(tau - T))
    return np.column_stack(cols)


def _solve(t, s, t_s, T, deg, shape=None):
    A = design(t, t_s, T, deg, shape=shape)
    coef, *_ = np.linalg.lstsq(A, s, rcond=None)
    return coef, s - A @ coef


def _samples(t, t_s, T, pre, post):
    return (t >= t_s - pre) & (t <= t_s + T + post)


@dataclasses.dataclass(frozen=True)
class Body:
    """One body's positions along n for :func:`fit_contact`: times, positions, the noise
    that weighs its residuals [m], and its fit windows before and after the contact [s]."""

    t: np.ndarray
    s: np.ndarray
    noise: float
    pre: float
    post: float


def noise_level(t: np.ndarray, s: np.ndarray, floor: float = 1e-6) -> float:
    """A body's position noise [m] from its second differences (median absolute deviation),
    at least ``floor``."""
    d2 = np.diff(np.asarray(s, float), 2)
    if len(d2) < 3:
        return floor
    return max(float(np.median(np.abs(d2 - np.median(d2)))) / 0.6745 / np.sqrt(6.0), floor)


def _weighted(bodies, x, deg, masks):
    return np.concatenate([_solve(b.t[m], b.s[m], x[0], x[1], deg)[1] / b.noise for b, m in zip(bodies, masks, strict=True)])


def _cost(bodies: list[Body], ts: float, T: float, deg: int) -> tuple[float, list[np.ndarray], int] | None:
    """Weighted residual per degree of freedom of a window, each body's samples and the
    degrees of freedom; None when a body has too few samples before or after it."""
    n_par = deg + KNOTS + 2
    masks, sse, n = [], 0.0, 0
    for b in bodies:
        m = _samples(b.t, ts, T, b.pre, b.post)
        if np.count_nonzero(m & (b.t < ts)) < deg + 3 or np.count_nonzero(m & (b.t > ts + T)) < deg + 3:
            return None
        sse += float(np.sum((_solve(b.t[m], b.s[m], ts, T, deg)[1] / b.noise) ** 2))
        n += int(m.sum()) - n_par
        masks.append(m)
    dof = max(n - 2, 1)
    return sse / dof, masks, dof


def _grid(bodies, deg, starts, durations):
    """The windows on a grid whose residual per degree of freedom is within two standard
    errors of the least one, and the shortest of them (a longer window's free profile fits
    noise as well as the contact): (cost, (t_s, T), each body's samples, the windows)."""
    found = []
    for ts in starts:
        for T in durations:
            c = _cost(bodies, float(ts), float(T), deg)
            if c is not None:
                found.append((c[0], float(ts), float(T), c[1], c[2]))
    if not found:
        raise ValueError("too few samples around the contact")
    least = min(found, key=lambda f: f[0])
    bound = least[0] * (1.0 + 2.0 * np.sqrt(2.0 / least[4]))
    accepted = [f for f in found if f[0] <= bound]
    cost, ts, T, masks, _ = min(accepted, key=lambda f: (round(f[2], 6), f[0]))
    return cost, np.array([ts, T]), masks, tuple((f[1], f[2]) for f in accepted)


def _refined(bodies, deg, guess, durations, min_T, max_T):
    """Least-squares refinements started from each duration centred on ``guess`` (twice, the
    samples taken again around the window found); the best: (cost, (t_s, T), samples)."""
    best = None
    for T0 in durations:
        x = np.array([guess - T0 / 2, T0])
        for _ in range(2):
            found = _cost(bodies, float(x[0]), float(x[1]), deg)
            if found is None:
                break
            masks = found[1]
            lo, hi = [x[0] - 0.05, min_T], [x[0] + 0.05, max_T]
            x = least_squares(lambda y, masks=masks: _weighted(bodies, y, deg, masks), np.clip(x, lo, hi),
                              bounds=(lo, hi), diff_step=1e-3, x_scale=[1e-3, 1e-3]).x
        else:
            found = _cost(bodies, float(x[0]), float(x[1]), deg)
            if found is not None and (best is None or found[0] < best[0]):
                best = (found[0], x, found[1])
    if best is None:
        raise ValueError("too few samples around the contact")
    return best


def fit_contact(bodies: list[Body], *, guess: float, deg: int, search: str = "grid", reach: float = 0.05,
                min_T: float = 0.004, max_T: float = 0.12) -> ContactFit:
    """The contact window shared by ``bodies`` (the object first) whose velocities change near ``guess`` [s].

    Every body has its own motion and profile, the window is common; a window is scored by
    its weighted residual per degree of freedom, each body fitted on its own samples around
    the window (a body needs samples of its fit on both sides). ``search`` ``"grid"``: a 2 ms
    grid of starts within ``reach`` of ``guess`` (a start) and of durations from ``min_T`` to
    ``max_T``, then a 0.5 ms grid around
    the best, each body's residuals weighed first by its noise, then by what its fit leaves
    (noise and the model's own error); the windows of the fine grid that fit as well are
    kept. ``"refine"``: least squares from a few durations
    centred on ``guess`` (the velocity change's middle; quicker). Returns the
    window, those that fit as well, and the first body's velocity change and profile.
    """
    if search == "grid":
        _, x, masks, _ = _grid(bodies, deg, np.arange(guess - reach, guess + reach + 1e-4, 0.002),
                               np.arange(min_T, max_T + 1e-4, 0.002))
        bodies = [dataclasses.replace(b, noise=max(b.noise, float(np.sqrt(np.mean(
            _solve(b.t[m], b.s[m], x[0], x[1], deg)[1] ** 2))))) for b, m in zip(bodies, masks, strict=True)]
        fine = np.arange(-0.004, 0.004 + 1e-5, 5e-4)
        _, x, masks, windows = _grid(bodies, deg, x[0] + fine, np.clip(x[1] + fine, min_T, max_T))
    else:
        _, x, masks = _refined(bodies, deg, guess, (0.01, 0.02, 0.04, 0.08), min_T, max_T)
        windows = ((float(x[0]), float(x[1])),)
    t_s, T = float(x[0]), float(x[1])
    coef, res = _solve(bodies[0].t[masks[0]], bodies[0].s[masks[0]], t_s, T, deg)
    first = 3 if deg >= 2 else 2
    knots = coef[first:first + KNOTS]
    shape = tuple(float(v) for v in knots / knots[-1]) if knots[-1] != 0 else ()
    sigma = float(np.sqrt(np.sum(res ** 2) / max(len(res) - len(coef), 1)))
    starts, durations = [w[0] for w in windows], [w[1] for w in windows]
    return ContactFit(t_s, T, (min(starts), max(starts)), (min(durations), max(durations)), float(knots[-1]), sigma,
                      shape, windows)


def velocity_change(t: np.ndarray, p: np.ndarray, *, t_s: float, T: float, deg: int, pre: float,
                    post: float) -> np.ndarray:
    """A body's velocity change over the window ``[t_s, t_s + T]`` [m/s], each coordinate of its
    positions ``p`` (samples x coordinates) fitted with the window's model on the samples within
    ``pre`` before and ``post`` after it: the direction of the contact's impulse on a free body."""
    t = np.asarray(t, float)
    m = _samples(t, t_s, T, pre, post)
    coef, *_ = np.linalg.lstsq(design(t[m], t_s, T, deg), np.asarray(p, float)[m], rcond=None)
    first = 3 if deg >= 2 else 2
    return coef[first + KNOTS - 1]


def fit_onset(t: np.ndarray, s: np.ndarray, *, T: float, shape: tuple[float, ...] | None, guess: float,
              reach: float, deg: int, pre: float, post: float, step: float = 2.5e-4) -> float:
    """The start of a body's velocity change of duration ``T`` and profile ``shape`` (another
    body's, :class:`ContactFit`; None: free), searched within ``reach`` of ``guess``.

    The samples fitted are those around the window at ``guess`` widened by ``reach``, the same
    for every candidate start, so the residuals compare; the best start on a grid of ``step``
    is refined by a parabola through its neighbours.
    """
    t, s = np.asarray(t, float), np.asarray(s, float)
    mask = (t >= guess - reach - pre) & (t <= guess + T + reach + post)
    tt, ss = t[mask], s[mask]
    starts = np.arange(guess - reach, guess + reach + step / 2, step)
    cost = np.array([float(np.sum(_solve(tt, ss, ts, T, deg, shape)[1] ** 2)) for ts in starts])
    i = int(np.argmin(cost))
    if 0 < i < len(starts) - 1:
        y0, y1, y2 = cost[i - 1], cost[i], cost[i + 1]
        curv = y0 - 2 * y1 + y2
        if curv > 0:
            return float(starts[i] + 0.5 * (y0 - y2) / curv * step)
    return float(starts[i])
