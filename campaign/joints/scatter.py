"""The residual scatter a response model's intervals carry: what makes identified m* noisier.

Eq 10 divides the hammer's momentum change by the tip's velocity change along n,
``dv = P / m* = (1 + e) v mu / m*`` (``mu`` the reduced mass of m* and the hammer). The
identification reads ``dv`` from joint encoders sampled every 20 ms, so its error in ``dv``
is roughly a velocity, and its relative error in m* grows as ``1 / dv``: with m* (the tip
hardly moves along n) and as the blow gets lighter. The momentum ``P`` is read from the
hammer's own velocity change, with an error that is again roughly a velocity, so a further
relative error grows as ``1 / v`` whatever m* (at low speed the contact is long and soft
against the 20 ms samples and the servo's own motion). Where m* is small the model's own
remaining error (the contact's local compliance it leaves out) is a further share that grows
as ``1 / m*``. On top of that each gain set has its own floor (the High-gain servo's hunting
at rest, the model's own remaining error). On the flexible base the identification also reads
the base's motion: a further floor per gain set (at High gains the 50 Hz joint samples leave
the tip-space velocity model) and a further velocity noise per structure. The scatter of
``ln m*`` is ::

    sigma^2 = a_g^2 + b_g^2 / dv^2 + h_g^2 / v^2 + d^2 (m_0 / m*)^2            (fixed base)
    sigma^2 = (the same) + f_g^2 + c_s^2 / dv^2                    (flexible base, structure s)

with ``a_g``, ``b_g``, ``h_g``, ``f_g`` per gain set, ``c_s`` per named structure, ``d`` one
small-m* share at ``m_0`` = :data:`SMALL_MASS_REFERENCE`, ``dv`` the model's predicted tip
velocity change [m/s], ``v`` the hammer's speed and ``m*`` the predicted value. A
prediction's interval is ``ln m* +- k sigma_total`` (``sigma_total`` with the parameters' own
share in quadrature) with ``k`` the quantile of a Student t distribution scaled to unit
variance with :attr:`ScatterModel.dof` degrees of freedom. :func:`fit_scatter` fits every
scale and the degrees of freedom to residuals ``ln m*_model - ln m*_identified`` so that the
90 % and the 95 % intervals hold what they say: it minimises the quantile (pinball) loss of
``|residual|`` against both intervals' half-widths. The residuals' tails grow at low speed
faster than their bulk (a few slow blows off by several times the rest), which a likelihood
fit, led by the bulk, leaves under-covered; the quantile loss weighs exactly the misses the
intervals are read for.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..core.errors import InputError

__all__ = ["ScatterModel", "fit_scatter", "tip_velocity_change", "SMALL_MASS_REFERENCE", "LEVELS"]

#: the smallest and largest degrees of freedom a scatter model may have
DOF_RANGE = (2.5, 200.0)
#: the m* [kg] the small-m* share ``d`` is given at
SMALL_MASS_REFERENCE = 10.0
#: the interval levels :func:`fit_scatter` calibrates
LEVELS = (0.90, 0.95)
#: the degrees of freedom :func:`fit_scatter` tries (two levels pin the t's shape only
#: loosely: a grid keeps the fit from drifting to a bound)
DOF_GRID = (3.0, 4.0, 6.0, 10.0, 20.0, 50.0, 200.0)
#: the range of the scales' logarithms in the fit (a term that reaches the lower end is
#: nil, and can come back from there)
_LOG_SCALE = (-18.0, 0.0)


def tip_velocity_change(m_eff, speed, mass, restitution) -> np.ndarray:
    """``dv = (1 + e) v mu / m*`` [m/s] with ``mu = m* m_b / (m* + m_b)``: the tip's velocity
    change along n that eq 10 divides by (0 where m* is unbounded)."""
    m = np.asarray(m_eff, float)
    mb = np.asarray(mass, float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        dv = (1.0 + np.asarray(restitution, float)) * np.asarray(speed, float) * mb / (m + mb)
    return np.where(np.isfinite(m) & (m > 0), dv, 0.0)


@dataclasses.dataclass(frozen=True)
class ScatterModel:
    """The scatter of ``ln m*`` per prediction (see the module notes).

    Attributes
    ----------
    floor : dict of str to float
        ``a_g`` per gain set [1].
    velocity_noise : dict of str to float
        ``b_g`` per gain set [m/s].
    speed_noise : dict of str to float
        ``h_g`` per gain set [m/s] (the share growing as ``1 / v``).
    small_mass : float
        ``d`` [1]: the share at m* = :data:`SMALL_MASS_REFERENCE`, growing as ``1 / m*``.
    structure : dict of str to float
        ``c_s`` per named structure [m/s] (the flexible base's further velocity noise).
    flexible_floor : dict of str to float
        ``f_g`` per gain set [1] (the flexible base's further floor).
    dof : float
        Degrees of freedom of the Student t distribution the intervals' quantiles come from.
    n_residuals : int
        The residuals it was fitted on.
    """

    floor: Mapping[str, float]
    velocity_noise: Mapping[str, float]
    speed_noise: Mapping[str, float]
    small_mass: float
    structure: Mapping[str, float]
    flexible_floor: Mapping[str, float]
    dof: float
    n_residuals: int = 0

    def __post_init__(self):
        for name, table in (("floor", self.floor), ("velocity_noise", self.velocity_noise),
                            ("speed_noise", self.speed_noise), ("structure", self.structure),
                            ("flexible_floor", self.flexible_floor), ("small_mass", {"": self.small_mass})):
            for key, value in table.items():
                if isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value)
                                                   and value >= 0):
                    where = f" of {key!r}" if key else ""
                    raise InputError(f"scatter model: {name}{where} must be a finite number >= 0, got {value!r}")
        for name, table in (("velocity_noise", self.velocity_noise), ("speed_noise", self.speed_noise),
                            ("flexible_floor", self.flexible_floor)):
            if set(table) != set(self.floor):
                raise InputError(f"scatter model: floor and {name} name other gain sets ({sorted(self.floor)} vs "
                                 f"{sorted(table)})")
        if not (isinstance(self.dof, (int, float)) and DOF_RANGE[0] <= self.dof <= DOF_RANGE[1]):
            raise InputError(f"scatter model: dof must be in [{DOF_RANGE[0]}, {DOF_RANGE[1]}], got {self.dof!r}")

    def sd(self, gains: Sequence[str], dv, speed, m_eff, *, structure: str | None = None) -> np.ndarray:
        """sigma of ``ln m*`` per prediction: gain set names, predicted ``dv`` [m/s], the
        hammer's speed [m/s], the predicted m* [kg], and on the flexible base the structure's
        name (None: the fixed base). Infinite where ``dv`` is 0 (m* unbounded)."""
        missing = sorted(set(gains) - set(self.floor))
        if missing:
            raise InputError(f"the scatter model has no gain set {missing[0]!r}; it was fitted on {sorted(self.floor)}")
        if structure is not None and structure not in self.structure:
            raise InputError(f"the scatter model has no structure {structure!r}; it was fitted on "
                             f"{sorted(self.structure)}")
        gi = [sorted(self.floor).index(g) for g in gains]
        tables = [np.array([t[g] for g in sorted(self.floor)], float)
                  for t in (self.floor, self.velocity_noise, self.speed_noise, self.flexible_floor)]
        c = None if structure is None else self.structure[structure]
        return np.sqrt(_variance(tables, self.small_mass, c, np.asarray(gi, int), np.asarray(dv, float),
                                 np.asarray(speed, float), np.asarray(m_eff, float)))

    def quantile(self, level: float) -> float:
        """The multiple of sigma a two-sided interval of ``level`` spans."""
        if not (0.0 < float(level) < 1.0):
            raise InputError(f"interval level must be in (0, 1), got {level!r}")
        return _t_quantile(float(level), float(self.dof))

    @property
    def scale(self) -> float:
        """``sqrt((dof - 2) / dof)``: the t distribution scaled to unit variance."""
        return math.sqrt((self.dof - 2.0) / self.dof)

    def to_dict(self) -> dict:
        """Plain numbers (the model file's ``fit.scatter_model``)."""
        return {"floor": {k: float(v) for k, v in sorted(self.floor.items())},
                "velocity_noise": {k: float(v) for k, v in sorted(self.velocity_noise.items())},
                "speed_noise": {k: float(v) for k, v in sorted(self.speed_noise.items())},
                "small_mass": float(self.small_mass),
                "structure": {k: float(v) for k, v in sorted(self.structure.items())},
                "flexible_floor": {k: float(v) for k, v in sorted(self.flexible_floor.items())},
                "dof": float(self.dof), "n_residuals": int(self.n_residuals)}

    @classmethod
    def from_dict(cls, doc: Mapping) -> ScatterModel:
        """Read :meth:`to_dict` back (InputError naming a missing or bad entry)."""
        if not isinstance(doc, Mapping):
            raise InputError(f"scatter model must be a JSON object, got {type(doc).__name__}")
        tables = ("floor", "velocity_noise", "speed_noise", "structure", "flexible_floor")
        for key in (*tables, "small_mass", "dof", "n_residuals"):
            if key not in doc:
                raise InputError(f"scatter model has no key {key!r}")
        for key in tables:
            if not isinstance(doc[key], Mapping):
                raise InputError(f"scatter model: {key} must be a JSON object")
        if isinstance(doc["dof"], bool) or isinstance(doc["n_residuals"], bool) or not isinstance(doc["n_residuals"],
                                                                                                  int):
            raise InputError("scatter model: dof must be a number and n_residuals an integer")
        return cls(**{k: dict(doc[k]) for k in tables}, small_mass=doc["small_mass"], dof=doc["dof"],
                   n_residuals=doc["n_residuals"])


def _t_quantile(level: float, dof: float) -> float:
    """The two-sided ``level`` quantile of the unit-variance t distribution with ``dof``."""
    from scipy.stats import t  # scipy.stats costs ~0.3 s to import; only intervals need it

    return float(t.ppf(0.5 + level / 2.0, dof)) * math.sqrt((dof - 2.0) / dof)


def _variance(tables, small_mass, c, gi, dv, speed, m_eff) -> np.ndarray:
    """sigma^2 of the module notes: ``tables`` (a_g, b_g, h_g, f_g as arrays over the gain sets'
    sorted names), ``c`` the structure's velocity noise (None: the fixed base), ``gi`` each
    prediction's gain set index. Infinite where ``dv`` is 0 or m* is not a positive number."""
    a, b, h, f = (np.asarray(t, float)[gi] for t in tables)
    moving = (dv > 0) & np.isfinite(m_eff) & (m_eff > 0)
    inv_dv2 = np.where(moving, 1.0 / np.where(moving, dv, 1.0) ** 2, 0.0)
    small = np.where(moving, SMALL_MASS_REFERENCE / np.where(moving, m_eff, 1.0), 0.0)
    var = a ** 2 + b ** 2 * inv_dv2 + h ** 2 / speed ** 2 + (small_mass * small) ** 2
    if c is not None:
        c = np.asarray(c, float)
        var = var + f ** 2 + c ** 2 * inv_dv2
    return np.where(moving, var, np.inf)


def _unpack(x, n_gains: int, n_structures: int):
    G, S = n_gains, n_structures
    x = np.clip(x, *_LOG_SCALE)
    e = np.where(x > _LOG_SCALE[0], np.exp(x), 0.0)         # a term at the lower end is nil
    return [e[:G], e[G:2 * G], e[2 * G:3 * G], e[3 * G:4 * G]], e[4 * G], e[4 * G + 1:4 * G + 1 + S]


def fit_scatter(residuals, gains: Sequence[str], dv, *, speed, m_eff, structures: Sequence[str | None],
                parameter_sd=None, dof: tuple[float, float] = DOF_RANGE) -> ScatterModel:
    """Fit a :class:`ScatterModel` so that its 90 % and 95 % intervals hold what they say.

    Minimises the quantile (pinball) loss of ``|residual|`` against both intervals'
    half-widths ``k sigma_total`` at the levels :data:`LEVELS` (see the module notes),
    starting from a normal likelihood fit, at each degrees of freedom of ``DOF_GRID``
    within ``dof`` (or at ``dof`` held); the least loss wins.

    Parameters
    ----------
    residuals : array_like, shape (N,)
        ``ln m*_model - ln m*_identified`` (non-finite ones are left out).
    gains : sequence of N str
        Each residual's gain set.
    dv : array_like, shape (N,)
        The model's predicted tip velocity change [m/s] (:func:`tip_velocity_change`).
    speed : array_like, shape (N,)
        The hammer's speed [m/s].
    m_eff : array_like, shape (N,)
        The model's predicted m* [kg].
    structures : sequence of N str or None
        Each residual's structure on the flexible base, None on the fixed base.
    parameter_sd : array_like, shape (N,), optional
        The parameters' share of each residual's sd (added in quadrature).
    dof : (float, float)
        The range the degrees of freedom are chosen in (equal bounds: held there).
    """
    from scipy.optimize import minimize  # scipy.optimize costs ~0.4 s to import: the fit only

    r, dv, v, m = (np.asarray(x, float) for x in (residuals, dv, speed, m_eff))
    p2 = np.zeros_like(r) if parameter_sd is None else np.asarray(parameter_sd, float) ** 2
    gains, structures = list(gains), list(structures)
    if not (len(gains) == len(structures) == r.size == dv.size == v.size == m.size == p2.size):
        raise InputError("fit_scatter: residuals, gains, dv, speed, m_eff, structures and parameter_sd must have one "
                         "entry each")
    if not (DOF_RANGE[0] <= dof[0] <= dof[1] <= DOF_RANGE[1]):
        raise InputError(f"fit_scatter: dof range {dof} is not within {DOF_RANGE}")
    ok = (np.isfinite(r) & np.isfinite(dv) & (dv > 0) & np.isfinite(p2) & np.isfinite(v) & (v > 0)
          & np.isfinite(m) & (m > 0))
    gains, structures = [str(g) for g in gains], [None if s is None else str(s) for s in structures]
    names = sorted({g for g, k in zip(gains, ok, strict=True) if k})
    st_names = sorted({s for s, k in zip(structures, ok, strict=True) if k and s is not None})
    if ok.sum() < 5 * len(names) + len(st_names) + 5:
        raise InputError(f"fit_scatter: {int(ok.sum())} usable residuals are too few for {len(names)} gain sets and "
                         f"{len(st_names)} structures")
    r, dv, v, m, p2 = r[ok], dv[ok], v[ok], m[ok], p2[ok]
    gi = np.array([names.index(g) for g, k in zip(gains, ok, strict=True) if k])
    si = np.array([st_names.index(s) if s is not None else -1 for s, k in zip(structures, ok, strict=True) if k])
    flex = si >= 0
    G, S = len(names), len(st_names)

    def variance(x):
        tables, d, c = _unpack(x, G, S)
        fixed = _variance(tables, d, None, gi, dv, v, m) + p2
        if not S:
            return fixed
        return np.where(flex, _variance(tables, d, c[np.maximum(si, 0)], gi, dv, v, m) + p2, fixed)

    def normal_nll(x):
        var = np.maximum(variance(x), 1e-12)                  # every term nil: a tiny floor
        return float(np.sum(0.5 * np.log(var) + r ** 2 / (2 * var)))

    def pinball(x, ks):
        sd, loss = np.sqrt(variance(x)), 0.0
        for level, k in zip(LEVELS, ks, strict=True):
            u = np.abs(r) - k * sd
            loss += float(np.sum(np.where(u >= 0, level * u, (level - 1.0) * u)))
        return loss

    # every scale starts at a typical residual (the velocity noises at it times a typical dv or v)
    rms, mdv, mv = float(np.sqrt(np.mean(r ** 2))), float(np.median(dv)), float(np.median(v))
    x0 = np.log(np.concatenate([np.full(G, rms / 3), np.full(G, rms * mdv / 3), np.full(G, rms * mv / 3),
                                np.full(G, rms / 3), [rms / 3], np.full(S, rms * mdv / 3)]))
    bounds = [_LOG_SCALE] * x0.size
    x0 = minimize(normal_nll, x0, method="L-BFGS-B", bounds=bounds).x
    options = {"maxiter": 80000, "maxfev": 80000, "xatol": 1e-8, "fatol": 1e-12}
    best = None
    for nu in ([dof[0]] if dof[0] == dof[1] else [n for n in DOF_GRID if dof[0] <= n <= dof[1]] or [dof[0]]):
        ks = [_t_quantile(level, nu) for level in LEVELS]
        # the loss is piecewise linear: Powell's line searches (which reach back from a nil
        # term), then Nelder-Mead restarted where it stopped until a restart gains nothing;
        # from the likelihood fit and from the best so far
        for x in [x0] + ([best[1]] if best is not None else []):
            x = minimize(pinball, x, args=(ks,), method="Powell", bounds=bounds, options={"xtol": 1e-6}).x
            loss = pinball(x, ks)
            for _ in range(12):
                x = np.clip(minimize(pinball, x, args=(ks,), method="Nelder-Mead", options=options).x, *_LOG_SCALE)
                loss, gained = pinball(x, ks), loss - pinball(x, ks)
                if gained <= 1e-9 * loss:
                    break
            if best is None or loss < best[0]:
                best = (loss, x, nu)
    _, x, nu = best
    (a, b, h, f), d, c = _unpack(x, G, S)
    table = lambda values: dict(zip(names, values.tolist(), strict=True))  # noqa: E731
    return ScatterModel(floor=table(a), velocity_noise=table(b), speed_noise=table(h), small_mass=float(d),
                        structure=dict(zip(st_names, c.tolist(), strict=True)), flexible_floor=table(f),
                        dof=float(nu), n_residuals=int(ok.sum()))
