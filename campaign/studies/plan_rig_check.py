"""The impact planner checked on the rig: predicted against simulated peak force and base displacement.

At each contact point every candidate of the planner (IK branch x gain set x horizontal
impact direction) is simulated on the VES-II rig at one impact speed; the rig's peak contact
force (fixed base, simulator truth ``f_contact``) and peak base displacement (flexible base,
truth ``base_position``) are set beside the planner's predictions (:mod:`campaign.plan.prediction`:
the contact as a pulse, :mod:`campaign.plan.compression`, :mod:`campaign.plan.post_contact`),
beside the same with the impulse at once, and beside eq 8's release alone. Gain sets zero,
low and high carry the paper's Table 3 lambda of their class. Objects: the rig's hammer and
a heavier head, the planner given the same mass. Per object, point and base: Spearman's
rank correlation of predicted and measured values, and the measured value of the planner's
best candidate over the largest measured one (``plan_rig_check.csv``, which the campaign
report renders; every candidate in ``candidates.csv``).

Beside it: the impulsive limit of the structure prediction (``impulsive_limit.csv``), the
same candidates with a passive arm (``passive.csv``), the rig's Coulomb friction against the
planner's linear arm (``coulomb.csv``), and why candidates that differ only by the sign of n
measure apart (``sign_asymmetry.csv``).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, FLEXIBLE, HIGH, LOW, SPACE_CLASS, STIFF_MAST, ZERO, ZERO_LOW
from ..model.exiit import effective_mass
from ..model.paper import configuration_q, impact_direction, load_paper, paper_offset_deg
from ..model.robot import load_robot
from ..model.robot.ik import impact_point, position_branches
from ..plan.directions import horizontal_directions
from ..plan.factory import build_planner
from ..plan.prediction import pose_terms, predict
from ..rig.beam import Beam
from ..rig.contact import ContactLaw, pulse_shape
from ..rig.pendulum import Pendulum
from ..rig.trial import simulate_arrays
from ..scene.description import make_scene
from .common import PASSIVE, Log, quiet, write_csv

__all__ = ["Settings", "POINTS", "BASES", "CSV_COLUMNS", "GAIN_CLASS", "contact_points", "with_structure",
           "simulate_truth", "measure", "hammer_mass", "check_point", "rank_scores", "csv_rows", "impulsive_limit",
           "passive_check", "coulomb_check", "sign_asymmetry", "run"]

#: contact points: the paper's configuration 1 (two branches within the limits) and a point
#: beside the arm reached by four branches [paper degrees], low enough for the hammer's stand
#: and exposed from every horizontal direction on each branch
POINTS = {"config 1 wrist centre": None, "side point": (30.0, 120.0, 0.0)}
#: bases of the check: the fixed base, then the flexible base under each named structure
BASES = ((FIXED, None), (FLEXIBLE, SPACE_CLASS), (FLEXIBLE, STIFF_MAST))
CSV_COLUMNS = ("object_kg", "point", "base", "structure", "f1_Hz", "branches", "candidates", "refused",
               "quantity", "unit", "predicted_min", "predicted_max", "measured_min", "measured_max",
               "spearman", "best_over_worst", "spearman_at_once", "best_over_worst_at_once",
               "spearman_release", "best_over_worst_release")
CANDIDATE_COLUMNS = ("object_kg", "point", "base", "structure", "branch", "gain", "direction", "contact_s",
                     "predicted", "measured", "at_once", "release")
CHECK_COLUMNS = {
    "impulsive_limit": ("contact_scale", "coupling", "contact_s", "predicted_m", "measured_m"),
    "passive": ("point", "structure", "candidates", "predicted_over_measured_min", "predicted_over_measured_max",
                "spearman", "best_over_worst", "release_over_measured_min", "release_over_measured_max",
                "spearman_release", "best_over_worst_release"),
    "coulomb": ("rig", "measured_over_predicted_min", "measured_over_predicted_max"),
    "sign_asymmetry": ("speed_m_s", "rig", "gain", "largest_pm_n_difference", "largest_joint_excursion_rad"),
}
GAIN_CLASS = {ZERO: ZERO_LOW, LOW: ZERO_LOW, HIGH: HIGH}
#: the rig settings of the sign check: as calibrated, and without the effects the planner's
#: linear arm could still be missing (Coulomb friction, gravity)
SIGN_SETTINGS = (("as calibrated", {}), ("Coulomb friction off", {"arm.coulomb_scale": 0.0}),
                 ("gravity off", {"gravity": 0.0}),
                 ("Coulomb friction and gravity off", {"arm.coulomb_scale": 0.0, "gravity": 0.0}))


@dataclasses.dataclass(frozen=True)
class Settings:
    """What the study sweeps; :meth:`quick` is a reduced set for the tests."""

    speed: float = 2.0
    directions: int = 4
    #: pendulum head masses [kg] of the heavier objects, beside the rig's hammer
    head_masses: tuple = (5.0,)
    points: tuple = tuple(POINTS)
    bases: tuple = BASES
    gains: tuple = tuple(GAIN_CLASS)
    #: the impulsive limit, passive, Coulomb and sign checks
    checks: bool = True

    @classmethod
    def quick(cls) -> Settings:
        return cls(directions=2, head_masses=(), points=("config 1 wrist centre",),
                   bases=((FIXED, None), (FLEXIBLE, SPACE_CLASS)), gains=(ZERO, HIGH), checks=False)


def contact_points() -> dict:
    """{name: impact point [m]} of :data:`POINTS`."""
    robot = load_robot("puma560")
    return {name: impact_point(robot, configuration_q(1) if q_deg is None else np.radians(q_deg))
            for name, q_deg in POINTS.items()}


def with_structure(params, structure):
    """``params`` with the flexible base's named structure set (None: the rig file's own)."""
    out = dict(params or {})
    if structure is not None:
        out["flexible.structure"] = structure
    return out or None


def simulate_truth(base: str, q_dh, gain: str, n, speed: float, params=None):
    """(simulator truth, scene, None) of one rig trial, or (None, None, refusal reason)."""
    q_paper = np.degrees(q_dh) - paper_offset_deg()
    kw = dict(base=base, config=None, gain=gain, speed=speed, q_paper_deg=[float(x) for x in q_paper], params=params)
    if not np.allclose(n, impact_direction()):
        kw["direction"] = [float(x) for x in n]
    try:
        scene = make_scene(**kw)
        trial = simulate_arrays(scene)
    except InputError as exc:
        return None, None, str(exc)
    return trial["truth"], scene, None


def measure(base: str, q_dh, gain: str, n, speed: float, params=None, *, duration: bool = False):
    """(measured peak, refusal reason) of one rig trial; with ``duration`` also the time the
    contact force is non-zero [s] (None when refused)."""
    truth, scene, why = simulate_truth(base, q_dh, gain, n, speed, params)
    if why is not None:
        return (None, why, None) if duration else (None, why)
    if base == FIXED:
        peak = float(np.max(truth["f_contact"].values))
    else:
        peak = float(np.max(np.linalg.norm(truth["base_position"].values, axis=1)))
    if not duration:
        return peak, None
    return peak, None, np.count_nonzero(truth["f_contact"].values > 0) / float(scene.p("sensors.truth_rate"))


def hammer_mass(params=None) -> float:
    """Effective mass m_b of the rig's hammer [kg] with the parameter overrides."""
    return Pendulum.from_scene(make_scene(params=params)).m_b


def rank_scores(predicted, measured) -> dict:
    """Spearman's rank correlation of predicted and measured values, and the measured value of the
    best predicted candidate over the largest measured value (NaN below 3 candidates)."""
    from scipy.stats import spearmanr  # scipy.stats loads only where a ranking is scored

    predicted, measured = np.asarray(predicted, float), np.asarray(measured, float)
    if predicted.size < 3:
        return {"spearman": float("nan"), "best_over_worst": float("nan")}
    return {"spearman": float(spearmanr(predicted, measured).statistic),
            "best_over_worst": float(measured[int(np.argmin(predicted))] / measured.max())}


def _predictions(base: str, structure, point, directions, *, speed: float, params):
    """The planner fitted at ``point`` (it gets the object's mass and the rig's parameters,
    never the rig's answers) and its predictions: (planner, predicted, at once, release)."""
    table3 = {k: [float(v) for v in lam] for k, lam in load_paper()["table3"].items()}
    planner = build_planner(base=base, lambdas=table3, speed=speed, mass=hammer_mass(params),
                            objective="force" if base == FIXED else "displacement", structure=structure, params=params)
    P = planner.fit(point, directions).predictions_
    predicted = P.peak_force if base == FIXED else P.structure_peak
    release = None if base == FIXED else P.structure_peak_release
    # the same planner with the impulse arriving at once (lambda's m* for the force)
    planner.arm = dataclasses.replace(planner.arm, pulse=False)
    A = planner.fit(point, directions).predictions_
    return planner, predicted, A.peak_force if base == FIXED else A.structure_peak, release


def _candidates(base, planner, predicted, at_once, release, *, gains, speed, params):
    """Every branch x gain set x direction of ``planner`` simulated: (candidates, refusals)."""
    names = planner.gain_classes_
    cands, refused = [], []
    for i, q in enumerate(planner.q_):
        for gain in gains:
            g = names.index(gain) if gain in names else names.index(GAIN_CLASS[gain])
            for d, n in enumerate(planner.directions_):
                measured, why, contact = measure(base, q, gain, n, speed, params, duration=True)
                if why is not None:
                    refused.append(why)
                    continue
                cands.append({"branch": i + 1, "gain": gain, "d": d, "contact": contact,
                              "predicted": float(predicted[i, g, d]), "measured": measured,
                              "at_once": float(at_once[i, g, d]),
                              "release": None if release is None else float(release[i, g, d])})
    return cands, refused


def check_point(name: str, point, *, directions, speed: float, params=None, bases=BASES,
                gains=tuple(GAIN_CLASS)) -> list[dict]:
    """Simulate every branch x gain set (``gains``) x direction at ``point`` on each of ``bases``
    and score the planner's predictions against the rig's measurements (one row per base)."""
    rows = []
    for base, structure in bases:
        planner, predicted, at_once, release = _predictions(base, structure, point, directions, speed=speed,
                                                            params=params)
        t0 = time.perf_counter()
        cands, refused = _candidates(base, planner, predicted, at_once, release, gains=gains, speed=speed,
                                     params=with_structure(params, structure))
        pred = np.array([c["predicted"] for c in cands])
        meas = np.array([c["measured"] for c in cands])
        row = {"point": name, "base": base, "structure": structure or "", "object_kg": hammer_mass(params),
               "branches": int(planner.q_.shape[0]), "candidates": len(cands), "refused": len(refused),
               "refusals": sorted(set(refused)), **rank_scores(pred, meas),
               "pred_range": (pred.min(), pred.max()) if cands else (np.nan, np.nan),
               "meas_range": (meas.min(), meas.max()) if cands else (np.nan, np.nan),
               "frequency": float(np.mean(planner.frequency_)) if planner.frequency_ is not None else None,
               "contact": float(np.median([c["contact"] for c in cands])) if cands else float("nan"),
               "wall": time.perf_counter() - t0, "cands": cands}
        once = rank_scores(np.array([c["at_once"] for c in cands]), meas)
        row.update(spearman_at_once=once["spearman"], best_over_worst_at_once=once["best_over_worst"])
        if release is not None:
            rel = rank_scores(np.array([c["release"] for c in cands]), meas)
            row.update(spearman_release=rel["spearman"], best_over_worst_release=rel["best_over_worst"])
        rows.append(row)
    return rows


def csv_rows(rows: list[dict]) -> list[dict]:
    """The summary rows of the check as the CSV the campaign report renders (one per object,
    contact point and base; SI units, the quantity named)."""
    out = []
    for r in rows:
        fixed = r["base"] == FIXED
        out.append({"object_kg": f"{r['object_kg']:.6g}", "point": r["point"], "base": r["base"],
                    "structure": r["structure"], "f1_Hz": "" if r["frequency"] is None else f"{r['frequency']:.6g}",
                    "branches": r["branches"], "candidates": r["candidates"], "refused": r["refused"],
                    "quantity": "peak contact force" if fixed else "peak base displacement",
                    "unit": "N" if fixed else "m",
                    "predicted_min": f"{r['pred_range'][0]:.6g}", "predicted_max": f"{r['pred_range'][1]:.6g}",
                    "measured_min": f"{r['meas_range'][0]:.6g}", "measured_max": f"{r['meas_range'][1]:.6g}",
                    "spearman": f"{r['spearman']:.4f}", "best_over_worst": f"{r['best_over_worst']:.4f}",
                    # the same with the impulse at once (lambda's m* for the force, eq 8's release
                    # with the arm's post-contact motion for the structure)
                    "spearman_at_once": f"{r['spearman_at_once']:.4f}",
                    "best_over_worst_at_once": f"{r['best_over_worst_at_once']:.4f}",
                    # the flexible base's prediction without the post-contact term (eq 8's release)
                    "spearman_release": "" if fixed else f"{r['spearman_release']:.4f}",
                    "best_over_worst_release": "" if fixed else f"{r['best_over_worst_release']:.4f}"})
    return out


def candidate_rows(rows: list[dict]) -> list[dict]:
    """Every simulated candidate of every summary row: its prediction and measurement."""
    return [{"object_kg": r["object_kg"], "point": r["point"], "base": r["base"], "structure": r["structure"],
             "branch": c["branch"], "gain": c["gain"], "direction": c["d"], "contact_s": c["contact"],
             "predicted": c["predicted"], "measured": c["measured"], "at_once": c["at_once"], "release": c["release"]}
            for r in rows for c in r["cands"]]


def impulsive_limit(speed: float) -> list[dict]:
    """Configuration 1, passive arm (lambda = 0), contact 1x and 100x stiffer than calibrated,
    ideal coupling and the VES-II loop: the rig's peak base displacement against the
    prediction (eq 8's release), as the contact becomes impulsive."""
    robot = load_robot("puma560")
    rows = []
    for scale in (1.0, 100.0):
        for mode in ("ideal", "loop"):
            params = dict(PASSIVE, **{"ves.mode": mode})
            k = scale * float(make_scene(params=params).p("contact.stiffness"))
            params["contact.stiffness"] = k
            sc = make_scene(base=FLEXIBLE, config=1, gain=ZERO, speed=speed, params=params)
            truth = simulate_arrays(sc)["truth"]
            p = sc.p
            contact = ContactLaw(k, float(p("contact.exponent")), float(p("contact.restitution")))
            P = predict(pose_terms(robot, configuration_q(1)[None], beam=Beam.from_scene(sc)), [[0.0, 0.0, 0.0]],
                        [[-1.0, 0.0, 0.0]], mass=hammer_mass(params), speed=speed,
                        restitution=float(p("contact.restitution")), contact=contact)
            rows.append({"contact_scale": scale, "coupling": mode,
                         "contact_s": np.count_nonzero(truth["f_contact"].values > 0) / float(p("sensors.truth_rate")),
                         "predicted_m": float(P.structure_peak[0, 0, 0]),
                         "measured_m": float(np.max(np.linalg.norm(truth["base_position"].values, axis=1)))})
    return rows


def passive_check(speed: float, directions) -> list[dict]:
    """Both contact points on both structures with a passive arm (lambda = 0 in the planner):
    the rig's peak base displacement against the prediction over every branch x direction, with
    the arm's joints free after the impact and with eq 8's release alone (the arm locked)."""
    rows = []
    for name, point in contact_points().items():
        for structure in (SPACE_CLASS, STIFF_MAST):
            planner = build_planner(base=FLEXIBLE, lambdas={ZERO: [0.0, 0.0, 0.0]}, speed=speed,
                                    mass=hammer_mass(), objective="displacement", structure=structure, params=PASSIVE)
            P = planner.fit(point, directions).predictions_
            pred, rel, meas = [], [], []
            for i, q in enumerate(planner.q_):
                for d, n in enumerate(planner.directions_):
                    measured, why = measure(FLEXIBLE, q, ZERO, n, speed, with_structure(PASSIVE, structure))
                    if why is None:
                        pred.append(float(P.structure_peak[i, 0, d]))
                        rel.append(float(P.structure_peak_release[i, 0, d]))
                        meas.append(measured)
            pred, rel, meas = np.array(pred), np.array(rel), np.array(meas)
            a, b = rank_scores(pred, meas), rank_scores(rel, meas)
            rows.append({"point": name, "structure": structure, "candidates": len(pred),
                         "predicted_over_measured_min": (pred / meas).min(),
                         "predicted_over_measured_max": (pred / meas).max(), **a,
                         "release_over_measured_min": (rel / meas).min(), "release_over_measured_max": (rel / meas).max(),
                         "spearman_release": b["spearman"], "best_over_worst_release": b["best_over_worst"]})
    return rows


def coulomb_check(speed: float, directions) -> list[dict]:
    """Measured / predicted of the zero gain set's candidates along +-y at the side point
    (space-class structure, the rig's hammer) with the rig's Coulomb friction and without it
    (the planner's linear arm has none)."""
    zero_low = [float(v) for v in load_paper()["table3"][ZERO_LOW]]
    rows = []
    for label, params in (("as calibrated", None), ("Coulomb friction off", {"arm.coulomb_scale": 0.0})):
        planner = build_planner(base=FLEXIBLE, lambdas={ZERO: zero_low}, speed=speed, mass=hammer_mass(params),
                                objective="displacement", structure=SPACE_CLASS, params=params)
        planner.fit(contact_points()["side point"], directions)
        ratios = []
        for i, q in enumerate(planner.q_):
            for d, n in enumerate(planner.directions_):
                if abs(n[1]) >= 0.5:
                    measured, why = measure(FLEXIBLE, q, ZERO, n, speed, with_structure(params, SPACE_CLASS))
                    if why is None:
                        ratios.append(measured / float(planner.predictions_.structure_peak[i, 0, d]))
        rows.append({"rig": label, "measured_over_predicted_min": min(ratios),
                     "measured_over_predicted_max": max(ratios)})
    return rows


def _sign_cell(qs, dirs, pairs, gain: str, speed: float, params) -> dict:
    """The largest relative difference between the measured peaks of a +-n pair over the
    branches ``qs``, and the arm's largest joint excursion up to the structure's peak."""
    diff, excursion = [], []
    for q in qs:
        peak = {}
        for d in sorted({i for pair in pairs for i in pair}):
            truth, _, why = simulate_truth(FLEXIBLE, q, gain, dirs[d], speed, params)
            if why is not None:
                continue
            x = np.linalg.norm(truth["base_position"].values, axis=1)
            k = int(np.argmax(x))
            qt = truth["q"].values
            peak[d] = float(x[k])
            excursion.append(float(np.max(np.abs(qt[:k + 1] - qt[0]))))
        diff += [abs(peak[d] / peak[e] - 1) for d, e in pairs if d in peak and e in peak]
    return {"largest_pm_n_difference": max(diff) if diff else None,
            "largest_joint_excursion_rad": max(excursion) if excursion else None}


def sign_asymmetry(speed: float, directions, params=None, *, speeds=(0.5, 1.0), gains=(ZERO, HIGH),
                   settings=SIGN_SETTINGS) -> list[dict]:
    """Why candidates that differ only by the sign of n measure apart: configuration 1's point on
    the space-class structure, the object of ``params``, gain sets ``gains``; at ``speed`` under
    each of ``settings`` (name, rig parameters), and at the lower ``speeds`` under the last one.
    One row per run and gain set (:func:`_sign_cell`)."""
    qs = position_branches(load_robot("puma560"), contact_points()["config 1 wrist centre"]).q
    dirs = np.asarray(directions, dtype=float)
    pairs = [(d, e) for d in range(len(dirs)) for e in range(d + 1, len(dirs)) if np.allclose(dirs[d], -dirs[e])]
    runs = [(speed, name, over) for name, over in settings] + [(v, settings[-1][0], settings[-1][1]) for v in speeds]
    rows = []
    for v, name, over in runs:
        trial_params = with_structure({**(params or {}), **over}, SPACE_CLASS)
        rows += [{"speed_m_s": v, "rig": name, "gain": gain, **_sign_cell(qs, dirs, pairs, gain, v, trial_params)}
                 for gain in gains]
    return rows


def facts(directions) -> list[dict]:
    """The numbers the findings rest on: the smallest free m* over the candidates (the rig
    strikes only lighter objects) and where the contact law's force peaks in the contact."""
    robot = load_robot("puma560")
    m1 = min(effective_mass(robot, q, n) for p in contact_points().values()
             for q in position_branches(robot, p).q for n in directions)
    c = ContactLaw.from_scene(make_scene())
    _, f = pulse_shape(c.damping, c.exponent)
    return [{"name": "smallest free m* over the candidates [kg]", "value": m1},
            {"name": "contact force peak, fraction of the contact", "value": int(np.argmax(f)) / (f.size - 1)},
            {"name": "contact exponent p", "value": float(c.exponent)}]


def run(out_dir, *, quick: bool = False, log: Log = quiet) -> list[str]:
    """Run the study and write its CSV files into ``out_dir``; returns their paths."""
    s = Settings.quick() if quick else Settings()
    out = Path(out_dir)
    directions = horizontal_directions(s.directions)
    points = {k: v for k, v in contact_points().items() if k in s.points}
    variants = [None] + [{"pendulum.head_mass": x} for x in s.head_masses]
    rows = []
    for params in variants:
        for name, point in points.items():
            part = check_point(name, point, directions=directions, speed=s.speed, params=params, bases=s.bases,
                               gains=s.gains)
            for r in part:
                log(f"m_b {r['object_kg']:.3g} kg, {r['point']}, {r['base']} {r['structure']}: {r['candidates']} "
                    f"candidates ({r['refused']} refused), Spearman {r['spearman']:.2f}, best / worst "
                    f"{r['best_over_worst']:.2f} ({r['wall']:.1f} s)")
            rows += part
    files = [write_csv(out / "plan_rig_check.csv", csv_rows(rows), CSV_COLUMNS),
             write_csv(out / "candidates.csv", candidate_rows(rows), CANDIDATE_COLUMNS),
             write_csv(out / "facts.csv", facts(directions), ("name", "value"))]
    checks = {"impulsive_limit": lambda: impulsive_limit(s.speed), "passive": lambda: passive_check(s.speed, directions),
              "coulomb": lambda: coulomb_check(s.speed, directions),
              "sign_asymmetry": lambda: sign_asymmetry(s.speed, directions, variants[-1])}
    for name, check in checks.items():
        # a quick run skips the checks: their files hold only the header
        table = check() if s.checks else []
        log(f"{name}: {len(table)} rows")
        files.append(write_csv(out / f"{name}.csv", table, CHECK_COLUMNS[name]))
    return files
