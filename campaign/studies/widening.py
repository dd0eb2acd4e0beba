"""How much wider the response model's interval must grow outside its domain.

:data:`campaign.joints.domain.WIDENING` holds, per quantity a prediction can lie outside
the model's domain in, the extra standard deviation of ``ln m*`` per unit of distance past
the bound. This module measures it on fixed-base trials outside the domain of the model it
is given, drawn with a seed of its own (:func:`cases`), simulated on the rig and identified
from their measured channels (:func:`measure`):

* speeds below and above the fitted ones (:attr:`Settings.speeds`; the rig's hammer reaches
  4.46 m/s), the rig's hammer;
* hammer heads lighter and heavier than the rig's (:attr:`Settings.heads`, the rig file's
  ``pendulum.head_mass``) at a speed inside the domain, predicted as the model's free
  object of the hammer's mass (``campaign meff --model --mass``);
* random poses at speeds inside the domain whose predicted m* lies outside its m* range.

Each trial's residual ``r = ln m*_model - ln m*_identified`` against the interval's own
standard deviation ``s`` and quantile ``k`` (:meth:`~campaign.joints.estimator.ResponseModel.interval_quantile`)
asks for the extra standard deviation ``sqrt(max((r / k)^2 - s^2, 0))``; divided by the
distance ``d`` past the bound it is the rate that trial needs. :func:`fit_rates` takes per
quantity the rate that makes ``level`` of its trials' widened intervals cover (trials
outside in that quantity alone); a quantity whose trials need none, or that no trial
reaches, gets the largest measured rate. :func:`coverage` checks rates on other trials
(:func:`campaign.joints.domain.widen_interval`'s widening). :func:`study` does all of it:
rates on one seed, checked on another, and the rates of both pooled. Method and findings:
user guide, *The response model*, "The widening, measured".
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, HIGH, LOW, ZERO
from ..identify import identify_trial
from ..identify.results import is_usable
from ..joints.domain import WIDENING, widen_interval
from ..joints.impacts import Impacts
from ..joints.modelfile import load_model, shipped_model_path
from ..model.paper import paper_offset_deg
from ..rig.trial import simulate_arrays
from ..scene.description import make_scene
from .common import Log, quiet
from .response_model import random_poses

__all__ = ["Settings", "cases", "measure", "fit_rates", "coverage", "study"]


@dataclasses.dataclass(frozen=True)
class Settings:
    """What :func:`cases` draws per seed (poses per group; each pose struck at every gain set)."""

    speeds: tuple = (0.3, 0.4, 3.5, 4.2)
    speed_poses: int = 10
    heads: tuple = (0.35, 0.9, 1.2)
    head_speed: float = 2.0
    head_poses: int = 6
    m_eff_poses: int = 10
    m_eff_pool: int = 120
    inside_speed_range: tuple = (0.5, 3.0)
    gains: tuple = (ZERO, LOW, HIGH)
    campaign_seed: int = 3601

    @classmethod
    def quick(cls) -> Settings:
        """One pose at Low gains at a speed below and one above the domain, one heavier hammer (seconds)."""
        return cls(speeds=(0.3, 4.2), speed_poses=1, heads=(1.2,), head_poses=1, m_eff_poses=0, gains=(LOW,))


def _dh(q_paper_deg) -> np.ndarray:
    return np.radians(np.asarray(q_paper_deg, float) + paper_offset_deg())


def _outside_m_eff(model, poses, gains) -> list[tuple]:
    """The poses whose predicted m* (the rig's hammer) lies outside the domain's m* range at some gain set."""
    if not poses:
        return []
    q = np.array([_dh(p[0]) for p in poses for _ in gains])
    n = np.array([p[1] for p in poses for _ in gains], float)
    imp = Impacts(q=q, direction=n, speed=np.array([p[2] for p in poses for _ in gains]),
                  gain=tuple(g for _ in poses for g in gains))
    m = model.predict(imp).reshape(len(poses), len(gains))
    lo, hi = model.domain_.m_eff
    out = (m < lo) | (m > hi)
    return [p for p, o in zip(poses, out.any(axis=1), strict=True) if o]


def cases(model, seed: int, s: Settings | None = None) -> list[dict]:
    """The cases of one seed: ``kind`` (speed, hammer, m_eff), ``q`` [paper deg], ``n``,
    ``gain``, ``speed`` [m/s], ``head`` (the hammer head's mass [kg] or None: the rig's)."""
    s = s or Settings()
    out = []
    for k, v in enumerate(s.speeds):
        out += [dict(kind="speed", q=q, n=n, gain=g, speed=v, head=None)
                for q, n, _ in random_poses(s.speed_poses, seed + 10 * k, speeds=v) for g in s.gains]
    for k, head in enumerate(s.heads):
        out += [dict(kind="hammer", q=q, n=n, gain=g, speed=s.head_speed, head=float(head))
                for q, n, _ in random_poses(s.head_poses, seed + 100 + 10 * k, speeds=s.head_speed) for g in s.gains]
    if s.m_eff_poses:
        pool = random_poses(s.m_eff_pool, seed + 200, speed_range=s.inside_speed_range)
        picked = _outside_m_eff(model, pool, s.gains)[:s.m_eff_poses]
        out += [dict(kind="m_eff", q=q, n=n, gain=g, speed=v, head=None) for q, n, v in picked for g in s.gains]
    return out


def _simulate(case: Mapping, campaign_seed: int) -> dict | None:
    params = None if case["head"] is None else {"pendulum.head_mass": case["head"]}
    try:
        trial = simulate_arrays(make_scene(base=FIXED, gain=case["gain"], speed=float(case["speed"]),
                                           campaign_seed=campaign_seed, config=0, q_paper_deg=list(case["q"]),
                                           direction=list(case["n"]), params=params))
    except InputError:
        return None
    rec = identify_trial(trial["measured"], meta=dict(trial.attrs)).to_dict()
    return rec if is_usable(rec) else None


def _row(model, case: Mapping, rec: Mapping, seed: int) -> dict | None:
    imp = Impacts.from_records([rec])
    free = case["head"] is not None          # another hammer: the model's free object of its mass
    imp = dataclasses.replace(imp, pendulum=not free)
    m, lo, hi = (float(x[0]) for x in model.predict_interval(imp))
    if not (math.isfinite(m) and m > 0):
        return None
    k = model.interval_quantile(0.95)
    mass = float(imp.mass[0])
    ex = model.domain_.excursions(speed=float(rec["speed"]), mass=mass if free else None, m_eff=m)
    return dict(seed=seed, kind=case["kind"], gain=rec["gain"], speed=float(rec["speed"]), mass=mass, m_identified=rec["m_eff"],
                m_model=m, residual=math.log(m / rec["m_eff"]), sd=math.log(hi / m) / k, quantile=k,
                excursions={x.quantity: x.distance for x in ex})


def measure(seed: int, *, model=None, settings: Settings | None = None, log: Log = quiet) -> list[dict]:
    """The trials of :func:`cases` at ``seed`` (``model`` a fitted response model, default the
    shipped one), each with the model's prediction: ``seed``, ``kind``, ``gain``, ``speed``, ``mass``
    (the hammer's [kg]), ``m_identified``, ``m_model`` [kg], ``residual`` (ln ratio), ``sd``
    and ``quantile`` of the model's own 95 % interval, ``excursions`` (quantity: distance).
    Trials the rig refuses or the identification excludes are left out."""
    model = model if model is not None else load_model(shipped_model_path())
    s = settings or Settings()
    todo = cases(model, seed, s)
    t0 = time.process_time()
    rows = []
    for case in todo:
        rec = _simulate(case, s.campaign_seed)
        row = _row(model, case, rec, seed) if rec is not None else None
        if row is not None:
            rows.append(row)
    log(f"seed {seed}: {len(rows)} of {len(todo)} trials usable, {time.process_time() - t0:.1f} s CPU")
    return rows


def _need(row: Mapping, quantity: str) -> float:
    excess = (row["residual"] / row["quantile"]) ** 2 - row["sd"] ** 2
    return math.sqrt(max(excess, 0.0)) / row["excursions"][quantity]


def fit_rates(rows: Sequence[Mapping], *, level: float = 0.95) -> tuple[dict, dict]:
    """Per :data:`WIDENING` quantity the rate that makes ``level`` of the trials outside in
    that quantity alone cover, and how many trials it rests on (0: none reach it, the largest
    measured rate stands in; a measured 0 also takes the largest)."""
    rates, counts = {}, {}
    for q in WIDENING:
        need = np.sort([_need(r, q) for r in rows if set(r["excursions"]) == {q}])
        counts[q] = int(need.size)
        rates[q] = float(need[min(int(math.ceil(level * need.size)) - 1, need.size - 1)]) if need.size else 0.0
    top = max(rates.values())
    if top <= 0:
        raise InputError("fit_rates: no trial outside the domain needs a widening; no rate can be measured")
    return {q: (v if v > 0 else top) for q, v in rates.items()}, counts


def group(row: Mapping) -> str:
    """The row's group in the guide's table: the speed, the hammer, or the m* side."""
    if row["kind"] == "speed":
        return f"speed {row['speed']:g} m/s"
    if row["kind"] == "hammer":
        return f"hammer {row['mass']:.3g} kg"
    side = [q for q in row["excursions"] if q.startswith("m_eff")]
    return "m* " + (side[0].split("_")[-1] if side else "inside") + " (in-domain speed)"


def coverage(rows: Sequence[Mapping], rates: Mapping[str, float]) -> list[dict]:
    """Per :func:`group` of the trials outside the domain: trials, median and worst m* error
    (model against identified), the share the model's own 95 % intervals hold and the share
    they hold widened with ``rates`` (:func:`campaign.joints.domain.widen_interval`); then
    the row ``all``."""
    groups: dict[str, list] = {}
    for r in rows:
        if not r["excursions"]:
            continue
        w = math.sqrt(sum((rates[q] * d) ** 2 for q, d in r["excursions"].items()))
        m, k = r["m_model"], r["quantile"]
        lo, hi = m * math.exp(-k * r["sd"]), m * math.exp(k * r["sd"])
        wlo, whi = widen_interval(m, lo, hi, w, quantile=k)
        groups.setdefault(group(r), []).append((m / r["m_identified"] - 1.0, lo <= r["m_identified"] <= hi,
                                                wlo <= r["m_identified"] <= whi))
    out = []
    for name, v in sorted(groups.items()) + [("all", [x for g in groups.values() for x in g])]:
        if not v:
            continue
        err = np.array([x[0] for x in v])
        out.append(dict(group=name, trials=len(v), median_error=float(np.median(err)),
                        worst_error=float(err[np.argmax(np.abs(err))]), own_covered=float(np.mean([x[1] for x in v])),
                        widened_covered=float(np.mean([x[2] for x in v]))))
    return out


def study(fit_seed: int = 38001, check_seed: int = 38101, *, model=None, settings: Settings | None = None,
          log: Log = quiet) -> dict:
    """The rates fitted on ``fit_seed``'s trials and checked on ``check_seed``'s, and the rates
    of both pooled: ``rates_fit``, ``counts_fit``, ``check`` (:func:`coverage` of the
    check seed with ``rates_fit``), ``rates``, ``counts`` and ``pooled`` (both seeds with the
    pooled rates), ``rows``. Defaults: the shipped model, :class:`Settings` (about 190 trials
    a seed, a minute of CPU each)."""
    model = model if model is not None else load_model(shipped_model_path())
    fit_rows = measure(fit_seed, model=model, settings=settings, log=log)
    check_rows = measure(check_seed, model=model, settings=settings, log=log)
    rates_fit, counts_fit = fit_rates(fit_rows)
    rates, counts = fit_rates(fit_rows + check_rows)
    return dict(rates_fit=rates_fit, counts_fit=counts_fit, check=coverage(check_rows, rates_fit), rates=rates,
                counts=counts, pooled=coverage(fit_rows + check_rows, rates), rows=fit_rows + check_rows)
