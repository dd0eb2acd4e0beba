"""m* and e of a recorded hit by momentum balance, from sparse position samples.

Along the impact direction n (the direction of the object's velocity change):

* the contact window is where the object's positions leave the motion fitted before it
  (growing forward from well before) and after it (growing backward from well after):
  the first sample that departs from the fit's prediction by more than ``k_sigma`` noise
  levels bounds the window;
* each body's velocity just before (after) the contact is the derivative, at the window's
  edge, of a polynomial fitted to the samples before (after) it, never across it:
  ``quadratic`` (default; constant acceleration: the object's sliding friction, the
  controller's push and re-acceleration) or ``linear`` (constant velocity);
* ``m* = m_o (v_o' - v_o) / (v_e - v_e')`` (the object's momentum change over the end
  effector's velocity change) and ``e = (v_o' - v_e') / (v_e - v_o)``;
* intervals: a bootstrap of each fit's residuals (scaled for the fitted parameters) with
  each edge drawn uniformly within the sample interval that holds it, seeded.

A hit is refused (no numbers) when a fit has too few samples, no contact is found or the
end effector does not slow along n; it is flagged (numbers kept) when the end effector's
velocity change is a small fraction of the approach speed (an object too light against
m*: the ratio is then dominated by noise) or the m* interval is wide.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ..core.errors import InputError
from .cleaning import impact_direction_of
from .fileformat import Recording

__all__ = ["FITS", "RecordedHitOptions", "identify_recording", "HIT_COLUMNS"]

#: the fits of the motion outside the contact
FITS = ("quadratic", "linear")
_DEGREE = {"quadratic": 2, "linear": 1}


@dataclasses.dataclass(frozen=True)
class RecordedHitOptions:
    """Options of :func:`identify_recording` (times in s).

    fit : {"quadratic", "linear"}
        The model of each body's motion before and after the contact.
    pre_window, post_window_object, post_window_robot : float
        Lengths of the fitted windows before the contact and after it (object, robot).
    min_samples : int or None
        Fewest samples a fit may use (default: 2 more than its parameters).
    k_sigma : float
        Departure from a fit, in noise levels, that marks the contact's edge.
    margin : int
        Samples added to the contact window on each side (the contact's soft start and end
        lie below the departure threshold).
    search : float
        How far from the object's largest velocity change the fits start their walk
        toward the contact.
    min_dv_ratio : float
        The end effector's velocity change below this fraction of the approach speed flags
        the hit (object too light against m*).
    max_rel_width : float
        An m* interval wider than this fraction of m* flags the hit.
    n_boot : int
        Bootstrap draws; ``seed`` their generator's seed.
    """

    fit: str = "quadratic"
    pre_window: float = 0.05
    post_window_object: float = 0.06
    post_window_robot: float = 0.04
    min_samples: int | None = None
    k_sigma: float = 8.0
    margin: int = 2
    search: float = 0.06
    min_dv_ratio: float = 0.10
    max_rel_width: float = 0.5
    n_boot: int = 400
    seed: int = 0

    def __post_init__(self) -> None:
        if self.fit not in FITS:
            raise InputError(f"fit {self.fit!r}: choose one of {', '.join(FITS)}")
        for name in ("pre_window", "post_window_object", "post_window_robot", "k_sigma", "min_dv_ratio",
                     "max_rel_width"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"{name} = {value!r}: must be a positive number")
        if self.n_boot < 20:
            raise InputError(f"n_boot = {self.n_boot}: at least 20 bootstrap draws")

    @property
    def need(self) -> int:
        return self.min_samples if self.min_samples is not None else _DEGREE[self.fit] + 3


def HIT_COLUMNS(n_joints: int) -> list[str]:  # noqa: N802 - a column list built like a constant
    """The columns of the per-hit table for ``n_joints`` joints."""
    return (["hit", "session", "object_mass", "n_x", "n_y", "n_z"] + [f"q_{k + 1}" for k in range(n_joints)]
            + ["speed", "m_eff", "m_eff_lo", "m_eff_hi", "e", "e_lo", "e_hi", "m_eff_logged", "flag",
               "contact_start", "contact_duration", "fit", "clock_offset"])


class _Refused(Exception):
    pass


def _noise(t: np.ndarray, s: np.ndarray) -> float:
    """Position noise from second differences (robust), with a floor."""
    d2 = s[2:] - 2 * s[1:-1] + s[:-2]
    if len(d2) < 3:
        return 1e-6
    return max(float(np.median(np.abs(d2 - np.median(d2)))) / 0.6745 / math.sqrt(6.0), 1e-6)


def _polyfit(t: np.ndarray, s: np.ndarray, deg: int, t_ref: float) -> np.ndarray:
    return np.polynomial.polynomial.polyfit(t - t_ref, s, deg)


def _edge(t: np.ndarray, s: np.ndarray, sigma: float, *, start: int, stop: int, step: int, deg: int,
          k_sigma: float, window: float) -> int:
    """Index of the last sample consistent with the motion outside the contact, walking from
    ``start`` toward ``stop`` (step +1: forward from before, -1: backward from after), each
    step predicting the next sample from a fit to the ``window`` seconds behind it."""
    j = start
    while j != stop:
        nxt = j + step
        idx = np.flatnonzero((np.abs(t - t[j]) <= window + 1e-9) & ((t <= t[j]) if step > 0 else (t >= t[j])))
        if len(idx) >= deg + 2:
            c = _polyfit(t[idx], s[idx], deg, t[j])
            pred = np.polynomial.polynomial.polyval(t[nxt] - t[j], c)
            if abs(s[nxt] - pred) > k_sigma * sigma:
                return j
        j = nxt
    return j


def _fit_velocity(t: np.ndarray, s: np.ndarray, deg: int, at: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Velocity of a polynomial fit at ``at``; the fit's values and scaled residuals for the bootstrap."""
    c = _polyfit(t, s, deg, at)
    fitted = np.polynomial.polynomial.polyval(t - at, c)
    resid = (s - fitted) * math.sqrt(len(t) / max(len(t) - deg - 1, 1))
    return float(c[1]), fitted, resid


def _window(t: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return np.flatnonzero((t >= lo - 1e-9) & (t <= hi + 1e-9))


def _contact(rec: Recording, n: np.ndarray, centre: float, opts: RecordedHitOptions) -> tuple[float, float, float, float]:
    """The bands (earliest, latest) holding the contact's start and end, on the robot's clock,
    widened by ``margin`` samples on each side."""
    t, s = rec.t_object, rec.object_position @ n
    sigma = _noise(t, s)
    deg = _DEGREE[opts.fit]
    k_c = int(np.searchsorted(t, centre))
    first = max(int(np.searchsorted(t, centre - opts.search - opts.pre_window)), 0)
    last = min(int(np.searchsorted(t, centre + opts.search + opts.post_window_object)), len(t) - 1)
    j_s = _edge(t, s, sigma, start=first, stop=k_c, step=1, deg=deg, k_sigma=opts.k_sigma,
                window=opts.pre_window)
    j_e = _edge(t, s, sigma, start=last, stop=k_c, step=-1, deg=deg, k_sigma=opts.k_sigma,
                window=opts.post_window_object)
    j_s, j_e = max(j_s - opts.margin, 0), min(j_e + opts.margin, len(t) - 1)
    if j_e <= j_s + 1:
        raise _Refused("no contact found: the object's motion has no velocity change between its fits")
    return float(t[j_s]), float(t[j_s + 1]), float(t[j_e - 1]), float(t[j_e])


def _velocities(bodies, edges, opts, rng=None):
    """(v_o, v_o', v_e, v_e') from the four fits; with ``rng`` one bootstrap draw."""
    (s_lo, s_hi, e_lo, e_hi) = edges
    t_s = rng.uniform(s_lo, s_hi) if rng is not None else 0.5 * (s_lo + s_hi)
    t_e = rng.uniform(e_lo, e_hi) if rng is not None else 0.5 * (e_lo + e_hi)
    out = []
    for (t, s, pre, post) in bodies:
        for idx, at in ((pre, t_s), (post, t_e)):
            v, fitted, resid = _fit_velocity(t[idx], s[idx], _DEGREE[opts.fit], at)
            if rng is not None:
                v = _fit_velocity(t[idx], fitted + rng.choice(resid, size=len(resid), replace=True),
                                  _DEGREE[opts.fit], at)[0]
            out.append(v)
    return out  # object pre, object post, robot pre, robot post


def identify_recording(rec: Recording, opts: RecordedHitOptions | None = None) -> dict[str, Any]:
    """Identify m* and e of one recorded hit: one row of :func:`HIT_COLUMNS`.

    A refused hit has empty numbers and ``flag`` ``refused: <reason>``; a flagged one its
    numbers and ``flag`` ``poor: <reason>``; a good one ``flag`` ``ok``.
    """
    opts = opts or RecordedHitOptions()
    nj = rec.q.shape[1]
    row: dict[str, Any] = {c: "" for c in HIT_COLUMNS(nj)}
    row.update(hit=rec.hit, session=rec.session, object_mass=rec.object_mass, fit=opts.fit,
               clock_offset=rec.attrs.get("object_attrs", {}).get("clock_offset", ""))
    try:
        _identify(rec, opts, row)
    except _Refused as exc:
        row["flag"] = f"refused: {exc}"
    return row


def _identify(rec: Recording, opts: RecordedHitOptions, row: dict[str, Any]) -> None:
    if len(rec.t_object) < 2 * opts.need + 2:
        raise _Refused(f"too few samples: the object has {len(rec.t_object)}")
    n, centre = impact_direction_of(rec.t_object, rec.object_position)
    edges = _contact(rec, n, centre, opts)
    row.update(n_x=n[0], n_y=n[1], n_z=n[2], contact_start=0.5 * (edges[0] + edges[1]),
               contact_duration=0.5 * (edges[2] + edges[3]) - 0.5 * (edges[0] + edges[1]))
    bodies = []
    for name, t, p, post_window in (("object", rec.t_object, rec.object_position, opts.post_window_object),
                                    ("robot", rec.t_robot, rec.ee_position, opts.post_window_robot)):
        s = p @ n
        pre = _window(t, edges[0] - opts.pre_window, edges[0])
        post = _window(t, edges[3], edges[3] + post_window)
        for where, idx in (("before", pre), ("after", post)):
            if len(idx) < opts.need:
                raise _Refused(f"too few samples: the {name} has {len(idx)} {where} the contact within its fit "
                               f"window (need {opts.need})")
        bodies.append((t, s, pre, post))
    t_s = row["contact_start"]
    for k in range(rec.q.shape[1]):
        row[f"q_{k + 1}"] = float(np.interp(t_s, rec.t_robot, rec.q[:, k]))
    if rec.inertia_inv is not None:
        k = max(int(np.searchsorted(rec.t_robot, edges[0], side="right")) - 1, 0)
        row["m_eff_logged"] = 1.0 / float(n @ rec.inertia_inv[k] @ n)
    vo, vo2, ve, ve2 = _velocities(bodies, edges, opts)
    speed = ve - vo
    if speed <= 0:
        raise _Refused(f"the end effector does not approach the object along n (approach speed {speed:.3g} m/s)")
    if ve - ve2 <= 0:
        raise _Refused(f"the end effector does not slow along n (velocity change {ve2 - ve:.3g} m/s)")
    m_eff = rec.object_mass * (vo2 - vo) / (ve - ve2)
    e = (vo2 - ve2) / speed
    rng = np.random.default_rng(opts.seed)
    draws = []
    for _ in range(opts.n_boot):
        a, b, c, d = _velocities(bodies, edges, opts, rng)
        if c - d > 0 and c - a > 0:
            draws.append((rec.object_mass * (b - a) / (c - d), (b - d) / (c - a)))
    if len(draws) < 0.9 * opts.n_boot:
        raise _Refused("the end effector's velocity change is lost in the noise (bootstrap draws without a "
                       "slowing end effector)")
    draws_arr = np.array(draws)
    lo, hi = np.percentile(draws_arr, [2.5, 97.5], axis=0)
    row.update(speed=speed, m_eff=m_eff, m_eff_lo=lo[0], m_eff_hi=hi[0], e=e, e_lo=lo[1], e_hi=hi[1])
    reasons = []
    ratio = (ve - ve2) / speed
    if ratio < opts.min_dv_ratio:
        reasons.append(f"object too light against m*: the end effector's velocity change is {100 * ratio:.0f} % "
                       f"of the speed (< {100 * opts.min_dv_ratio:.0f} %)")
    width = (hi[0] - lo[0]) / m_eff
    if width > opts.max_rel_width:
        reasons.append(f"m* interval {100 * width:.0f} % of m* wide (> {100 * opts.max_rel_width:.0f} %)")
    row["flag"] = "poor: " + "; ".join(reasons) if reasons else "ok"
