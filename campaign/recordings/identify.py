"""m* and e of a recorded hit by momentum balance, from sparse position samples.

Along the impact direction n (the direction of the object's velocity change):

* the contact window (start and duration) is fitted to the object's positions: its motion
  before and after plus a velocity change of free profile over the window, the shortest
  window that fits as well as the best (:mod:`campaign.recordings.contact`);
* n is then the object's velocity change across that window (each coordinate fitted with
  the window's model), not over a longer span that holds what else moves the object;
* each body's velocity just before (after) the contact is the derivative, at the window's
  edge, of a polynomial fitted to the samples before (after) it, never across it nor inside
  any window that fits as well: ``quadratic`` (default; constant acceleration: the object's
  sliding friction, the controller's push and re-acceleration; the end effector after the
  contact a cubic, its deceleration not being constant) or ``linear`` (constant velocity);
* ``m* = m_o (v_o' - v_o) / (v_e - v_e')`` (the object's momentum change over the end
  effector's velocity change) and ``e = (v_o' - v_e') / (v_e - v_o)``;
* intervals: a bootstrap of each fit's residuals (scaled for the fitted parameters), each
  draw taking one of the contact windows the samples fit as well (a soft contact's slow
  end gives many), moving its start and end each by up to a sample period (the samples
  place an edge no better) and the fitted windows' lengths within +-25 %, seeded; m* and e
  are the draws' medians, the intervals their 2.5 and 97.5 percentiles.

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
from .contact import Body, ContactFit, fit_contact, noise_level, velocity_change
from .fileformat import Recording

__all__ = ["FITS", "RecordedHitOptions", "identify_recording", "HIT_COLUMNS"]

#: the fits of the motion outside the contact
FITS = ("quadratic", "linear")
_DEGREE = {"quadratic": 2, "linear": 1}
#: the degree of the end effector's fit after the contact: an arm's tip does not decelerate
#: at a constant rate after a hit (its joints' velocities redistribute, its friction and
#: controller take over), so the quadratic model gets one more term there
_ROBOT_POST_DEGREE = {"quadratic": 3, "linear": 1}


def _degree(fit: str, body: str, side: str) -> int:
    return _ROBOT_POST_DEGREE[fit] if (body, side) == ("robot", "post") else _DEGREE[fit]


@dataclasses.dataclass(frozen=True)
class RecordedHitOptions:
    """Options of :func:`identify_recording` (times in s).

    fit : {"quadratic", "linear"}
        The model of each body's motion before and after the contact.
    pre_window, post_window_object, post_window_robot : float
        Lengths of the fitted windows before the contact and after it (object, robot).
    min_samples : int or None
        Fewest samples a fit may use (default: 2 more than its parameters).
    margin : int
        Robot sample periods excluded beyond the contact window on each side.
    window_spread : float
        Each bootstrap draw scales the fitted windows before and after the contact by a
        factor drawn within 1 +- this: the intervals include the choice of the windows.
    edge_spread : float
        Each bootstrap draw moves the contact's start and end, each on its own, by up to
        this many object sample periods (uniformly): samples a period apart place an edge
        only to within the period around it, and the velocities are read at the edges.
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
    post_window_robot: float = 0.06
    min_samples: int | None = None
    margin: int = 0
    window_spread: float = 0.25
    edge_spread: float = 1.0
    min_dv_ratio: float = 0.10
    max_rel_width: float = 0.5
    n_boot: int = 400
    seed: int = 0

    def __post_init__(self) -> None:
        if self.fit not in FITS:
            raise InputError(f"fit {self.fit!r}: choose one of {', '.join(FITS)}")
        for name in ("pre_window", "post_window_object", "post_window_robot", "min_dv_ratio",
                     "max_rel_width"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"{name} = {value!r}: must be a positive number")
        if not (isinstance(self.edge_spread, (int, float)) and math.isfinite(self.edge_spread)
                and self.edge_spread >= 0):
            raise InputError(f"edge_spread = {self.edge_spread!r}: must be a number >= 0")
        if self.n_boot < 20:
            raise InputError(f"n_boot = {self.n_boot}: at least 20 bootstrap draws")

    @property
    def need(self) -> int:
        return self.min_samples if self.min_samples is not None else _DEGREE[self.fit] + 3

    def need_of(self, body: str, side: str) -> int:
        """Fewest samples the fit of ``body`` on ``side`` ("pre", "post") may use."""
        if self.min_samples is not None:
            return self.min_samples
        return _degree(self.fit, body, side) + 3


def HIT_COLUMNS(n_joints: int) -> list[str]:  # noqa: N802 - a column list built like a constant
    """The columns of the per-hit table for ``n_joints`` joints."""
    return (["hit", "session", "object_mass", "n_x", "n_y", "n_z"] + [f"q_{k + 1}" for k in range(n_joints)]
            + ["speed", "m_eff", "m_eff_lo", "m_eff_hi", "e", "e_lo", "e_hi", "m_eff_logged", "flag",
               "contact_start", "contact_duration", "contact_duration_lo", "contact_duration_hi", "fit",
               "clock_offset"])


class _Refused(Exception):
    pass


def _polyfit(t: np.ndarray, s: np.ndarray, deg: int, t_ref: float) -> np.ndarray:
    return np.polynomial.polynomial.polyfit(t - t_ref, s, deg)


def _fit_velocity(t: np.ndarray, s: np.ndarray, deg: int, at: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Velocity of a polynomial fit at ``at``; the fit's values and scaled residuals for the bootstrap."""
    c = _polyfit(t, s, deg, at)
    fitted = np.polynomial.polynomial.polyval(t - at, c)
    resid = (s - fitted) * math.sqrt(len(t) / max(len(t) - deg - 1, 1))
    return float(c[1]), fitted, resid


def _contact(rec: Recording, n: np.ndarray, centre: float, opts: RecordedHitOptions) -> ContactFit:
    """The contact window on the robot's clock from the object's positions (a quick fit, then
    the grid near it); a body without enough samples on either side of it is refused."""
    deg = _DEGREE[opts.fit]
    bodies = []
    for name, t, p, post in (("object", rec.t_object, rec.object_position, opts.post_window_object),
                             ("robot", rec.t_robot, rec.ee_position, opts.post_window_robot)):
        s = p @ n
        bodies.append((name, Body(t, s, noise_level(t, s), opts.pre_window, post)))
    try:
        coarse = fit_contact([bodies[0][1]], guess=centre, deg=deg, search="refine")
    except ValueError:
        raise _Refused("too few samples: the object's samples around the contact do not determine it") from None
    for name, b in bodies:
        before = np.count_nonzero((b.t >= coarse.t_s - b.pre) & (b.t < coarse.t_s))
        after = np.count_nonzero((b.t > coarse.t_s + coarse.T) & (b.t <= coarse.t_s + coarse.T + b.post))
        for where, side, count in (("before", "pre", before), ("after", "post", after)):
            if count < opts.need_of(name, side):
                raise _Refused(f"too few samples: the {name} has {count} {where} the contact within its fit window "
                               f"(need {opts.need_of(name, side)})")
    try:
        return fit_contact([bodies[0][1]], guess=coarse.t_s, deg=deg, reach=0.02,
                           min_T=max(0.004, coarse.T - 0.03), max_T=coarse.T + 0.03)
    except ValueError:
        raise _Refused("too few samples: the samples around the contact do not determine it") from None


def _sets(bodies, lo_edge: float, hi_edge: float, opts: RecordedHitOptions, scale: tuple[float, float] = (1.0, 1.0)):
    """Each body's samples before and after the contact within its fit windows (scaled)."""
    out = []
    for name, t, s, post_window in bodies:
        pre = np.flatnonzero((t >= lo_edge - scale[0] * opts.pre_window) & (t < lo_edge))
        post = np.flatnonzero((t > hi_edge) & (t <= hi_edge + scale[1] * post_window))
        out.append((name, t, s, pre, post))
    return out


def _velocities(sets, t_s: float, t_e: float, opts: RecordedHitOptions, rng=None) -> list[float]:
    """(v_o, v_o', v_e, v_e') from the four fits, evaluated at the contact's edges; with ``rng``
    one bootstrap draw (each fit's residuals resampled)."""
    out = []
    for (name, t, s, pre, post) in sets:
        for idx, at, side in ((pre, t_s, "pre"), (post, t_e, "post")):
            deg = _degree(opts.fit, name, side)
            v, fitted, resid = _fit_velocity(t[idx], s[idx], deg, at)
            if rng is not None:
                v = _fit_velocity(t[idx], fitted + rng.choice(resid, size=len(resid), replace=True), deg, at)[0]
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
    found = _contact(rec, n, centre, opts)
    # the impact direction again, from the object's velocity change across the window only: the
    # change over a longer span holds what else moves the object (gravity along a curved path)
    dv = velocity_change(rec.t_object, rec.object_position, t_s=found.t_s, T=found.T, deg=_DEGREE[opts.fit],
                         pre=opts.pre_window, post=opts.post_window_object)
    if float(np.linalg.norm(dv)) > 0 and float(dv @ n) > 0:
        n = dv / float(np.linalg.norm(dv))
    t_s, t_e = found.t_s, found.t_s + found.T
    row.update(n_x=n[0], n_y=n[1], n_z=n[2], contact_start=t_s, contact_duration=found.T,
               contact_duration_lo=found.T_range[0], contact_duration_hi=found.T_range[1])
    # the fits take no sample any window that fits as well would put in the contact, and a
    # margin of whole samples beyond: a window too short would hand them in-contact samples
    dt = float(np.median(np.diff(rec.t_robot)))
    lo_edge = min(w[0] for w in found.windows) - opts.margin * dt
    hi_edge = max(w[0] + w[1] for w in found.windows) + opts.margin * dt
    bodies = [("object", rec.t_object, rec.object_position @ n, opts.post_window_object),
              ("robot", rec.t_robot, rec.ee_position @ n, opts.post_window_robot)]
    sets = _sets(bodies, lo_edge, hi_edge, opts)
    for name, _, _, pre, post in sets:
        for where, side, idx in (("before", "pre", pre), ("after", "post", post)):
            if len(idx) < opts.need_of(name, side):
                raise _Refused(f"too few samples: the {name} has {len(idx)} {where} the contact within its fit "
                               f"window (need {opts.need_of(name, side)})")
    for k in range(rec.q.shape[1]):
        row[f"q_{k + 1}"] = float(np.interp(t_s, rec.t_robot, rec.q[:, k]))
    if rec.inertia_inv is not None:
        k = max(int(np.searchsorted(rec.t_robot, t_s, side="right")) - 1, 0)
        row["m_eff_logged"] = 1.0 / float(n @ rec.inertia_inv[k] @ n)
    vo, vo2, ve, ve2 = _velocities(sets, t_s, t_e, opts)
    speed = ve - vo
    if speed <= 0:
        raise _Refused(f"the end effector does not approach the object along n (approach speed {speed:.3g} m/s)")
    if ve - ve2 <= 0:
        raise _Refused(f"the end effector does not slow along n (velocity change {ve2 - ve:.3g} m/s)")
    rng = np.random.default_rng(opts.seed)
    edge = opts.edge_spread * float(np.median(np.diff(rec.t_object)))
    draws = []
    for _ in range(opts.n_boot):
        ts_b, T_b = found.windows[int(rng.integers(len(found.windows)))]
        ts_b, te_b = ts_b + rng.uniform(-edge, edge), ts_b + T_b + rng.uniform(-edge, edge)
        if te_b <= ts_b:
            ts_b, te_b = t_s, t_e
        scale = tuple(rng.uniform(1 - opts.window_spread, 1 + opts.window_spread, 2))
        drawn = _sets(bodies, lo_edge, hi_edge, opts, scale)
        if any(len(pre) < opts.need_of(name, "pre") or len(post) < opts.need_of(name, "post")
               for name, _, _, pre, post in drawn):
            drawn = sets
        a, b, c, d = _velocities(drawn, ts_b, te_b, opts, rng)
        if c - d > 0 and c - a > 0:
            draws.append((rec.object_mass * (b - a) / (c - d), (b - d) / (c - a)))
    if len(draws) < 0.9 * opts.n_boot:
        raise _Refused("the end effector's velocity change is lost in the noise (bootstrap draws without a "
                       "slowing end effector)")
    draws_arr = np.array(draws)
    lo, mid, hi = np.percentile(draws_arr, [2.5, 50.0, 97.5], axis=0)
    m_eff, e = float(mid[0]), float(mid[1])
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
