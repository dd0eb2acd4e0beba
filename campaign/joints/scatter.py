"""The residual scatter a response model's intervals carry: what makes identified m* noisier.

Eq 10 divides the hammer's momentum change by the tip's velocity change along n,
``dv = P / m* = (1 + e) v mu / m*`` (``mu`` the reduced mass of m* and the hammer). The
identification reads ``dv`` from joint encoders sampled every 20 ms, so its error in ``dv``
is roughly a velocity, and its relative error in m* grows as ``1 / dv``: with m* (the tip
hardly moves along n) and as the blow gets lighter. On top of that each gain set has its
own floor (the High-gain servo's hunting at rest, the model's own remaining error). On the
flexible base the identification also reads the base's motion: a further floor per gain set
(at High gains the 50 Hz joint samples leave the tip-space velocity model) and a further
velocity noise per structure. The scatter of ``ln m*`` is ::

    sigma^2 = a_g^2 + b_g^2 / dv^2                                (fixed base)
    sigma^2 = a_g^2 + b_g^2 / dv^2 + f_g^2 + c_s^2 / dv^2         (flexible base, structure s)

with ``a_g``, ``b_g``, ``f_g`` per gain set and ``c_s`` per named structure, ``dv`` the
model's predicted tip velocity change [m/s]. :func:`fit_scatter` fits them by maximum
likelihood to residuals ``ln m*_model - ln m*_identified`` whose variance is ``sigma^2``
plus the parameters' own share, Student t distributed with :attr:`ScatterModel.dof` degrees
of freedom: the residuals' tails are heavier than a normal distribution's (a few poses
where the model's remaining structure, not noise, sets the miss). A prediction's interval is
``ln m* +- k sigma_total`` with ``k`` that distribution's quantile, so the 90 % and 95 %
intervals both cover what they say.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..core.errors import InputError

__all__ = ["ScatterModel", "fit_scatter", "tip_velocity_change", "DESIGNED_DOF"]

#: the smallest and largest degrees of freedom a scatter model may have
DOF_RANGE = (2.5, 200.0)
#: the degrees of freedom the designed campaign's scatter model is held at: fitted freely on
#: its few hundred residuals they fall to the bound (a handful of outliers), and held-out
#: development draws (fixed and flexible base, every gain set, 0.5-3.0 m/s) were likeliest
#: under 4 of 2, 3, 4, 6 and 10
DESIGNED_DOF = 4.0


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
    structure: Mapping[str, float]
    flexible_floor: Mapping[str, float]
    dof: float
    n_residuals: int = 0

    def __post_init__(self):
        for name, table in (("floor", self.floor), ("velocity_noise", self.velocity_noise),
                            ("structure", self.structure), ("flexible_floor", self.flexible_floor)):
            for key, value in table.items():
                if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                    raise InputError(f"scatter model: {name} of {key!r} must be a finite number >= 0, got {value!r}")
        for name, table in (("velocity_noise", self.velocity_noise), ("flexible_floor", self.flexible_floor)):
            if set(table) != set(self.floor):
                raise InputError(f"scatter model: floor and {name} name other gain sets ({sorted(self.floor)} vs "
                                 f"{sorted(table)})")
        if not (isinstance(self.dof, (int, float)) and DOF_RANGE[0] <= self.dof <= DOF_RANGE[1]):
            raise InputError(f"scatter model: dof must be in [{DOF_RANGE[0]}, {DOF_RANGE[1]}], got {self.dof!r}")

    def sd(self, gains: Sequence[str], dv, *, structure: str | None = None) -> np.ndarray:
        """sigma of ``ln m*`` per prediction: gain set names, predicted ``dv`` [m/s], and on the
        flexible base the structure's name (None: the fixed base)."""
        dv = np.asarray(dv, float)
        missing = sorted(set(gains) - set(self.floor))
        if missing:
            raise InputError(f"the scatter model has no gain set {missing[0]!r}; it was fitted on {sorted(self.floor)}")
        if structure is not None and structure not in self.structure:
            raise InputError(f"the scatter model has no structure {structure!r}; it was fitted on "
                             f"{sorted(self.structure)}")
        a = np.array([self.floor[g] for g in gains], float)
        b = np.array([self.velocity_noise[g] for g in gains], float)
        with np.errstate(divide="ignore", invalid="ignore"):
            var = a ** 2 + np.where(dv > 0, (b / np.where(dv > 0, dv, 1.0)) ** 2, np.inf)
        if structure is not None:
            f = np.array([self.flexible_floor[g] for g in gains], float)
            with np.errstate(divide="ignore"):
                var = var + f ** 2 + np.where(dv > 0, (self.structure[structure] / np.where(dv > 0, dv, 1.0)) ** 2,
                                              np.inf)
        return np.sqrt(var)

    def quantile(self, level: float) -> float:
        """The multiple of sigma a two-sided interval of ``level`` spans."""
        from scipy.stats import t  # scipy.stats costs ~0.3 s to import; only intervals need it

        if not (0.0 < float(level) < 1.0):
            raise InputError(f"interval level must be in (0, 1), got {level!r}")
        return float(t.ppf(0.5 + float(level) / 2.0, self.dof)) * self.scale

    @property
    def scale(self) -> float:
        """``sqrt((dof - 2) / dof)``: the t distribution scaled to unit variance."""
        return math.sqrt((self.dof - 2.0) / self.dof)

    def to_dict(self) -> dict:
        """Plain numbers (the model file's ``fit.scatter_model``)."""
        return {"floor": {k: float(v) for k, v in sorted(self.floor.items())},
                "velocity_noise": {k: float(v) for k, v in sorted(self.velocity_noise.items())},
                "structure": {k: float(v) for k, v in sorted(self.structure.items())},
                "flexible_floor": {k: float(v) for k, v in sorted(self.flexible_floor.items())},
                "dof": float(self.dof), "n_residuals": int(self.n_residuals)}

    @classmethod
    def from_dict(cls, doc: Mapping) -> ScatterModel:
        """Read :meth:`to_dict` back (InputError naming a missing or bad entry)."""
        if not isinstance(doc, Mapping):
            raise InputError(f"scatter model must be a JSON object, got {type(doc).__name__}")
        for key in ("floor", "velocity_noise", "structure", "flexible_floor", "dof", "n_residuals"):
            if key not in doc:
                raise InputError(f"scatter model has no key {key!r}")
        for key in ("floor", "velocity_noise", "structure", "flexible_floor"):
            if not isinstance(doc[key], Mapping):
                raise InputError(f"scatter model: {key} must be a JSON object")
        if isinstance(doc["dof"], bool) or not isinstance(doc["n_residuals"], int):
            raise InputError("scatter model: dof must be a number and n_residuals an integer")
        return cls(floor=dict(doc["floor"]), velocity_noise=dict(doc["velocity_noise"]),
                   structure=dict(doc["structure"]), flexible_floor=dict(doc["flexible_floor"]), dof=doc["dof"],
                   n_residuals=doc["n_residuals"])


def _unpack(x, gains, structures, dof):
    G, S = len(gains), len(structures)
    with np.errstate(over="ignore"):        # a held dof leaves its coordinate free to drift
        e = np.exp(x)
    nu = dof[0] + e[-1] if dof[0] < dof[1] else dof[0]
    return e[:G], e[G:2 * G], e[2 * G:3 * G], e[3 * G:3 * G + S], nu


def fit_scatter(residuals, gains: Sequence[str], dv, *, structures: Sequence[str | None], parameter_sd=None,
                dof: tuple[float, float] = DOF_RANGE) -> ScatterModel:
    """Fit a :class:`ScatterModel` by maximum likelihood (Student t residuals).

    Parameters
    ----------
    residuals : array_like, shape (N,)
        ``ln m*_model - ln m*_identified`` (non-finite ones are left out).
    gains : sequence of N str
        Each residual's gain set.
    dv : array_like, shape (N,)
        The model's predicted tip velocity change [m/s] (:func:`tip_velocity_change`).
    structures : sequence of N str or None
        Each residual's structure on the flexible base, None on the fixed base.
    parameter_sd : array_like, shape (N,), optional
        The parameters' share of each residual's sd (added in quadrature).
    dof : (float, float)
        The range the degrees of freedom are fitted in (equal bounds: held there).
    """
    from scipy.optimize import minimize  # scipy.optimize costs ~0.4 s to import: the fit only
    from scipy.special import gammaln

    r = np.asarray(residuals, float)
    dv = np.asarray(dv, float)
    p2 = np.zeros_like(r) if parameter_sd is None else np.asarray(parameter_sd, float) ** 2
    gains, structures = list(gains), list(structures)
    if not (len(gains) == len(structures) == r.size == dv.size == p2.size):
        raise InputError("fit_scatter: residuals, gains, dv, structures and parameter_sd must have one entry each")
    if not (DOF_RANGE[0] <= dof[0] <= dof[1] <= DOF_RANGE[1]):
        raise InputError(f"fit_scatter: dof range {dof} is not within {DOF_RANGE}")
    ok = np.isfinite(r) & np.isfinite(dv) & (dv > 0) & np.isfinite(p2)
    names = sorted({g for g, k in zip(gains, ok, strict=True) if k})
    st_names = sorted({s for s, k in zip(structures, ok, strict=True) if k and s is not None})
    if ok.sum() < 3 * len(names) + len(st_names) + 2:
        raise InputError(f"fit_scatter: {int(ok.sum())} usable residuals are too few for {len(names)} gain sets and "
                         f"{len(st_names)} structures")
    r, dv, p2 = r[ok], dv[ok], p2[ok]
    gi = np.array([names.index(g) for g, k in zip(gains, ok, strict=True) if k])
    si = np.array([st_names.index(s) if s is not None else -1 for s, k in zip(structures, ok, strict=True) if k])
    flex = si >= 0
    inv_dv2 = 1.0 / dv ** 2

    def nll(x):
        a, b, f, c, nu = _unpack(x, names, st_names, dof)
        var = a[gi] ** 2 + b[gi] ** 2 * inv_dv2 + p2
        if c.size:
            var = var + np.where(flex, f[gi] ** 2 + c[np.maximum(si, 0)] ** 2 * inv_dv2, 0.0)
        s2 = var * (nu - 2.0) / nu                          # the t's scale^2 for variance var
        return -np.sum(gammaln((nu + 1) / 2) - gammaln(nu / 2) - 0.5 * np.log(nu * math.pi * s2)
                       - (nu + 1) / 2 * np.log1p(r ** 2 / (nu * s2)))

    # every scale starts at a typical residual (the velocity noises at it times a typical dv)
    rms = float(np.sqrt(np.mean(r ** 2)))
    x = np.log(np.concatenate([np.full(len(names), rms / 3), np.full(len(names), rms * float(np.median(dv)) / 3),
                               np.full(len(names), rms / 3), np.full(len(st_names), rms * float(np.median(dv)) / 3),
                               [2.0]]))
    for _ in range(3):                                       # Nelder-Mead restarted where it stopped
        x = minimize(nll, x, method="Nelder-Mead", options={"maxiter": 40000, "maxfev": 40000, "xatol": 1e-7,
                                                            "fatol": 1e-10}).x
    a, b, f, c, nu = _unpack(x, names, st_names, dof)
    return ScatterModel(floor=dict(zip(names, a.tolist(), strict=True)),
                        velocity_noise=dict(zip(names, b.tolist(), strict=True)),
                        structure=dict(zip(st_names, c.tolist(), strict=True)),
                        flexible_floor=dict(zip(names, f.tolist(), strict=True)),
                        dof=float(min(nu, DOF_RANGE[1])), n_residuals=int(ok.sum()))
