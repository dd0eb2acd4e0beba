"""Where a fitted response model holds: the speeds, gain sets, object masses, impact directions,
m* and structures of the trials it was fitted and checked on; a prediction outside them.

:meth:`Domain.from_impacts` records the domain of the trials a fit saw (each model's
``fit`` does, :meth:`campaign.joints.estimator.ResponseModel._record_fit`; the designed
campaign adds the structures it checked the model on, :meth:`Domain.with_structure`); the
model file stores it (:mod:`campaign.joints.modelfile`). :meth:`Domain.check` refuses a
prediction outside it with one line naming the bound and the value (:class:`OutsideDomain`,
an InputError: exit status 2 in the CLI), or, asked to extrapolate, returns what lies
outside (:class:`Excursion`) and the extra scatter of ``ln m*`` the interval then carries
(:func:`widening`): per quantity a rate times the distance outside the bound
(:data:`WIDENING`, measured on held-out trials outside the domain; user guide, *The
response model*, "Where the model holds").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FLEXIBLE

__all__ = ["Domain", "Excursion", "OutsideDomain", "WIDENING", "widening", "widen_interval", "m_eff_state"]

#: extra standard deviation of ln m* per unit of distance outside the domain, added in
#: quadrature to the interval's own: speed, object mass and m* per unit of ln(value / bound)
#: on each side, direction per radian of elevation beyond the bound. Measured for the shipped
#: model on 378 fixed-base trials outside its domain (seeds 38001 and 38101: speeds 0.3, 0.4,
#: 3.5 and 4.2 m/s; hammers of 0.38-1.23 kg against a free object of that mass; poses whose
#: m* lies outside its range), each rate the one that makes 95 % of its trials' intervals
#: cover (:mod:`campaign.studies.widening`); where the trials needed none (above the speeds,
#: m* on either side) or none can be struck (a tilted direction: the rig strikes horizontally)
#: the largest measured rate stands in. User guide, *The response model*.
WIDENING = {"speed_below": 0.0353, "speed_above": 0.0353, "mass_below": 0.00607, "mass_above": 0.0353,
            "m_eff_below": 0.0353, "m_eff_above": 0.0353, "direction": 0.0353}
#: relative slack on a bound (rounding of the stored numbers)
SLACK = 1e-9

_UNITS = {"speed": "m/s", "mass": "kg", "m_eff": "kg"}
_WHAT = {"speed": "speed", "mass": "object mass", "m_eff": "m*"}


class OutsideDomain(InputError):
    """A prediction asked outside the model's domain (one line: the bound and the value)."""


@dataclasses.dataclass(frozen=True)
class Excursion:
    """One quantity outside the domain: its name, the one-line description and the distance
    outside the bound (ln ratio for speed, mass and m*; radians for the direction; None for a
    gain set or structure the model never saw)."""

    quantity: str          # a key of WIDENING (or base, structure, gain)
    message: str
    distance: float | None


def _span(values) -> tuple[float, float]:
    a = np.asarray(values, float)
    return float(np.min(a)), float(np.max(a))


@dataclasses.dataclass(frozen=True)
class Domain:
    """The trials a model saw.

    Attributes
    ----------
    speed : (low, high) object speed [m/s].
    gain_sets : the gain sets.
    mass : (low, high) object mass [kg].
    max_abs_nz : the largest absolute vertical component of the impact directions (0: horizontal only).
    m_eff : (low, high) identified m* [kg].
    base_names : the bases (``fixed``, ``flexible``).
    structures : the flexible base's named structures.
    """

    speed: tuple[float, float]
    gain_sets: tuple[str, ...]
    mass: tuple[float, float]
    max_abs_nz: float
    m_eff: tuple[float, float]
    base_names: tuple[str, ...]
    structures: tuple[str, ...] = ()

    @classmethod
    def from_impacts(cls, impacts, *, masses, structure: str | None = None) -> Domain:
        """The domain of ``impacts`` (:class:`campaign.joints.impacts.Impacts` with identified
        m*; ``masses`` the objects' [kg]; ``structure`` the flexible base's name)."""
        structures = (str(structure),) if impacts.base == FLEXIBLE and structure else ()
        return cls(speed=_span(impacts.speed), gain_sets=tuple(sorted(set(impacts.gain))), mass=_span(masses),
                   max_abs_nz=float(np.max(np.abs(impacts.direction[:, 2]))), m_eff=_span(impacts.m_eff),
                   base_names=(impacts.base,), structures=structures)

    def with_structure(self, name: str, impacts, *, masses) -> Domain:
        """This domain and the trials ``impacts`` on the flexible base under the structure ``name``."""
        other = Domain.from_impacts(impacts, masses=masses, structure=name)
        return Domain(speed=(min(self.speed[0], other.speed[0]), max(self.speed[1], other.speed[1])),
                      gain_sets=tuple(sorted(set(self.gain_sets) | set(other.gain_sets))),
                      mass=(min(self.mass[0], other.mass[0]), max(self.mass[1], other.mass[1])),
                      max_abs_nz=max(self.max_abs_nz, other.max_abs_nz),
                      m_eff=(min(self.m_eff[0], other.m_eff[0]), max(self.m_eff[1], other.m_eff[1])),
                      base_names=tuple(sorted(set(self.base_names) | {FLEXIBLE})),
                      structures=tuple(sorted(set(self.structures) | {str(name)})))

    # -- the file -----------------------------------------------------------------------
    def to_json(self) -> dict:
        return {"speed_m_s": list(self.speed), "gain_sets": list(self.gain_sets), "object_mass_kg": list(self.mass),
                "max_abs_direction_z": self.max_abs_nz, "m_eff_kg": list(self.m_eff), "bases": list(self.base_names),
                "structures": list(self.structures)}

    @classmethod
    def from_json(cls, doc: Mapping, *, where: str, gain_sets: Sequence[str], bases: Sequence[str]) -> Domain:
        """The domain of a model file's ``domain`` entry; InputError (one line) names a bad value."""
        if not isinstance(doc, Mapping):
            raise InputError(f"{where}: domain must be a JSON object")
        need = ("speed_m_s", "gain_sets", "object_mass_kg", "max_abs_direction_z", "m_eff_kg", "bases", "structures")
        for key in need:
            if key not in doc:
                raise InputError(f"{where}: domain has no key {key!r}")
        spans = {k: _checked_span(doc[k], f"{where}: domain.{k}") for k in ("speed_m_s", "object_mass_kg", "m_eff_kg")}
        nz = doc["max_abs_direction_z"]
        if isinstance(nz, bool) or not isinstance(nz, (int, float)) or not 0.0 <= nz <= 1.0:
            raise InputError(f"{where}: domain.max_abs_direction_z = {nz!r} must be in [0, 1]")
        names = {}
        for key, known in (("gain_sets", gain_sets), ("bases", bases), ("structures", None)):
            v = doc[key]
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v) or (key != "structures" and not v):
                raise InputError(f"{where}: domain.{key} must be a list of names, got {v!r}")
            bad = [x for x in v if known is not None and x not in known]
            if bad:
                raise InputError(f"{where}: domain.{key} names {bad[0]!r}, not one of {sorted(known)}")
            names[key] = tuple(v)
        return cls(speed=spans["speed_m_s"], gain_sets=names["gain_sets"], mass=spans["object_mass_kg"],
                   max_abs_nz=float(nz), m_eff=spans["m_eff_kg"], base_names=names["bases"], structures=names["structures"])

    # -- the check ----------------------------------------------------------------------
    def _range(self, quantity: str, value: float, span: tuple[float, float]) -> Excursion | None:
        lo, hi = span
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{_WHAT[quantity]} {value:g} {_UNITS[quantity]} must be finite and > 0")
        if lo * (1 - SLACK) <= value <= hi * (1 + SLACK):
            return None
        side, bound = ("below", lo) if value < lo else ("above", hi)
        unit = _UNITS[quantity]
        fitted = f"{lo:.4g} {unit}" if lo == hi else f"{lo:.4g}-{hi:.4g} {unit}"
        msg = f"{_WHAT[quantity]} {value:.6g} {unit} is {side} the model's domain (fitted on {fitted})"
        return Excursion(f"{quantity}_{side}", msg, abs(math.log(value / bound)))

    def excursions(self, *, speed=None, gain=None, mass=None, direction=None, base=None, structure=None,
                   m_eff=None) -> list[Excursion]:
        """What of a prediction lies outside the domain (nothing is checked for a None)."""
        out: list[Excursion | None] = []
        if base is not None and base not in self.base_names:
            out.append(Excursion("base", f"the {base} base is outside the model's domain (fitted on the "
                                         f"{' and '.join(self.base_names)} base)", None))
        if base == FLEXIBLE and structure is not None and structure not in self.structures:
            shown = ", ".join(self.structures) or "none"
            out.append(Excursion("structure", f"structure {structure!r} is outside the model's domain (checked on "
                                              f"{shown})", None))
        if gain is not None:
            for g in [gain] if isinstance(gain, str) else gain:
                if g not in self.gain_sets:
                    out.append(Excursion("gain", f"gain set {g!r} is outside the model's domain (fitted on "
                                                 f"{', '.join(self.gain_sets)})", None))
        for name, value, span in (("speed", speed, self.speed), ("mass", mass, self.mass), ("m_eff", m_eff, self.m_eff)):
            if value is not None:
                out.append(self._range(name, float(value), span))
        if direction is not None:
            n = np.atleast_2d(np.asarray(direction, float))
            n = n / np.linalg.norm(n, axis=1, keepdims=True)
            i = int(np.argmax(np.abs(n[:, 2])))
            nz = float(n[i, 2])
            if abs(nz) > self.max_abs_nz + SLACK:
                kind = "horizontal directions only, n_z = 0" if self.max_abs_nz == 0 else f"|n_z| <= {self.max_abs_nz:.4g}"
                out.append(Excursion("direction", f"direction {_vec(n[i])} (n_z = {nz:.4g}) is outside the model's "
                                                  f"domain (fitted on {kind})",
                                     math.asin(min(abs(nz), 1.0)) - math.asin(min(self.max_abs_nz, 1.0))))
        return [x for x in out if x is not None]

    def check(self, *, extrapolate: bool = False, hint: str = "", **what) -> list[Excursion]:
        """Refuse (:class:`OutsideDomain`, the first quantity outside with its bound and value,
        then ``hint``) a prediction of ``what`` (:meth:`excursions`'s keywords) outside the
        domain; with ``extrapolate`` return the excursions instead. A gain set, base or
        structure the model never saw is refused either way (no widening is known for it)."""
        found = self.excursions(**what)
        unknown = [x for x in found if x.distance is None]
        if unknown:
            raise OutsideDomain(unknown[0].message + "; no extrapolation is defined for it")
        if found and not extrapolate:
            raise OutsideDomain(found[0].message + hint)
        return found


def _vec(v) -> str:
    return "[" + ", ".join(f"{float(np.round(x, 9)) + 0.0:.4g}" for x in v) + "]"


def _checked_span(v, where: str) -> tuple[float, float]:
    ok = (isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                        for x in v))
    if not ok or not (math.isfinite(v[0]) and math.isfinite(v[1]) and 0 < v[0] <= v[1]):
        raise InputError(f"{where} = {v!r} must be two finite numbers 0 < low <= high")
    return float(v[0]), float(v[1])


def widening(excursions: Iterable[Excursion]) -> float:
    """The extra standard deviation of ln m* for ``excursions``: :data:`WIDENING`'s rate times
    the distance outside, added in quadrature."""
    return math.sqrt(sum((WIDENING[x.quantity] * float(x.distance)) ** 2 for x in excursions))


def m_eff_state(m_eff, tip_velocity) -> np.ndarray:
    """What eq 10's ``m* = P / n.v_a`` is per case: ``"finite"``; ``"recoil"`` where the tip
    moves backward (against n) at the contact's end, so ``P / n.v_a`` would be negative and m*
    has no value; ``"unbounded"`` where the tip does not move along n (m* infinite)."""
    m = np.asarray(m_eff, float)
    v = np.asarray(tip_velocity, float)
    return np.where(np.isfinite(m) & (m > 0), "finite", np.where(v < 0, "recoil", "unbounded"))



def widen_interval(m, lower, upper, extra_sd: float, *, quantile: float):
    """``(lower, upper)`` of an interval symmetric in ln m*, ``quantile`` standard deviations
    each side (the model's :meth:`~campaign.joints.estimator.ResponseModel.interval_quantile`
    of its level), with ``extra_sd`` added in quadrature to its standard deviation."""
    m, lower, upper = (np.asarray(x, float) for x in (m, lower, upper))
    k = float(quantile)
    if not (math.isfinite(k) and k > 0):
        raise InputError(f"widen_interval: quantile {quantile!r} must be finite and > 0")
    sd = np.log(upper / m) / k
    wide = np.sqrt(sd ** 2 + float(extra_sd) ** 2)
    return m * np.exp(-k * wide), m * np.exp(k * wide)
