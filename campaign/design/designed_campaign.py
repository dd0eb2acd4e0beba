"""The designed campaign: the paper's design, a designed one and held-out poses, on the fixed base.

Three stages, each one function the workflow's thin scripts call (``snakemake designed``,
``config/designed.yaml``):

* :func:`plan` designs the poses (:func:`campaign.design.run.run_design`) and draws the
  held-out set: seeded random poses within the joint limits with random horizontal
  directions, kept when the rig can strike them at every gain and speed and when they are
  none of the paper's or the designed poses. It writes the plan (JSON): every trial by role
  (``paper``, ``designed``, ``heldout``), pose, direction and speeds.
* :func:`run_trials` simulates the plan's trials of one role and gain set, writes each trial
  file and identifies them (:func:`campaign.identify.table.identify_trials`, measured channels only).
* :func:`report` fits lambda per gain class on the paper's trials and on the designed ones
  (:class:`campaign.joints.lambda_fit.LambdaFit`, each trial along its own direction), predicts the
  held-out trials' m* with eq 11 from each fit and compares it with the m* identified from
  their measured channels, and fits lambda per impact speed on the designed trials (is it
  constant?); the speed-wise lambda predicts the held-out trials too, and so does the
  response model the campaign saved (:mod:`campaign.design.designed_model`: the joints'
  impedance over the contact, fitted on the designed trials), with its 95 % intervals.

Its measured results: user guide, *Experiment design for lambda*, "The designed campaign"
and "Measured results" (``docs/design.rst``).
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..archive import trial_path, write_trial
from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.stats import Z95
from ..core.timing import Timer
from ..core.vocabulary import FIXED, FLEXIBLE, direction_azimuth, gain_classes, gain_sets
from ..identify.results import is_usable
from ..identify.table import identify_trials, read_identification
from ..joints.coulomb import CoulombLambdaFit
from ..joints.impacts import Impacts
from ..joints.impedance import servo_gains
from ..joints.lambda_fit import (
    IdentifiabilityWarning,
    LambdaFit,
    design_arrays,
    sensitivity_matrix,
)
from ..joints.modelfile import load_model
from ..model.paper import load_paper, paper_offset_deg
from ..model.robot import load_robot
from ..rig import simulate_arrays
from ..scene.description import make_scene
from .candidates import feasible, paper_design, random_candidates, rig_refusal
from .run import run_design, write_design

__all__ = ["plan", "run_trials", "report", "report_markdown", "ROLES"]

#: trial roles of the designed campaign
ROLES = ("paper", "designed", "heldout")


def _js(x):
    if isinstance(x, dict):
        return {k: _js(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_js(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.ndarray):
        return _js(x.tolist())
    return x


def _write_json(path, data) -> None:

    write_atomic(path, json.dumps(_js(data), indent=2, sort_keys=True) + "\n")


# ----------------------------------------------------------------------------------------
# plan
# ----------------------------------------------------------------------------------------
def plan(settings: Mapping[str, Any], out_json, out_md=None) -> dict[str, Any]:
    """Design the poses, draw the held-out set, and write the plan.

    Parameters
    ----------
    settings : mapping
        ``config/designed.yaml``: ``speeds``, ``repeats``, ``design`` (``n_poses``,
        ``criterion``, ``candidates``, ``lambda_prior``), ``heldout`` (``n``, ``seed``), ``rig``.
    out_json : path-like
        The plan.
    out_md : path-like, optional
        The design's Markdown tables (:func:`campaign.design.run.design_markdown`).
    """

    speeds = [float(v) for v in settings["speeds"]]
    repeats = int(settings.get("repeats", 1))
    des = dict(settings.get("design") or {})
    rig = settings.get("rig") or None
    # every candidate offered, those repeating another's measurement (n and -n of a pose) too: the
    # poses whose results the guide reports (docs/design.rst) are that design's, and offering only
    # distinct measurements would choose others (the design's Markdown says which applies)
    design = run_design(n_poses=int(des.get("n_poses", 6)), criterion=str(des.get("criterion", "D")),
                        candidates=str(des.get("candidates", "grid")), speeds=speeds, repeats=repeats, rig=rig,
                        lambda_prior=des.get("lambda_prior") or None, repeat_information=True)
    if out_md is not None:
        write_design(design, out_md=out_md)
    paper = load_paper()
    gains = [g for g in gain_sets() if any(g in v for v in gain_classes().values())]
    poses: dict[str, list] = {"paper": [], "designed": [], "heldout": []}
    Qp, Dp = paper_design()
    for k, q in enumerate(Qp, 1):
        poses["paper"].append({"config": k, "q_paper_deg": q.tolist(), "direction": None, "speeds": speeds})
    seen = set()
    for name, cls in design["classes"].items():
        for q, n in zip(cls["designed"]["q_paper_deg"], cls["designed"]["directions"], strict=True):
            key = _key(q, n)
            if key not in seen:
                seen.add(key)
                poses["designed"].append({"config": 0, "q_paper_deg": list(q), "direction": list(n), "speeds": speeds,
                                          "designed_for": [name]})
            else:
                for p in poses["designed"]:
                    if _key(p["q_paper_deg"], p["direction"]) == key:
                        p["designed_for"].append(name)
    # held-out: seeded random poses and directions the rig strikes at every gain and speed
    ho = dict(settings.get("heldout") or {})
    n_ho, seed = int(ho.get("n", 12)), int(ho.get("seed", 7))
    robot = load_robot(paper["robot"])
    taken = seen | {_key(q, n) for q, n in zip(Qp, Dp, strict=True)}
    Q, D = random_candidates(40 * n_ho, robot=robot, seed=seed)
    Q = np.round(Q, 1)                                  # poses a person can type
    ok, _ = feasible(robot, Q, D, speed=max(speeds), rig=rig)
    for i in np.flatnonzero(ok):
        if len(poses["heldout"]) >= n_ho:
            break
        if _key(Q[i], D[i]) in taken:
            continue
        # each held-out pose at one speed, alternating, so both speeds are predicted
        v = [speeds[len(poses["heldout"]) % len(speeds)]]
        if rig_refusal(Q[i], D[i], gains=gains, speeds=v, rig=rig):
            continue
        poses["heldout"].append({"config": 0, "q_paper_deg": Q[i].tolist(), "direction": D[i].tolist(), "speeds": v,
                                 "azimuth_deg": direction_azimuth(D[i])})
    if len(poses["heldout"]) < n_ho:
        raise InputError(f"only {len(poses['heldout'])} of {n_ho} held-out poses are reachable among "
                         f"{len(Q)} random draws (heldout.seed = {seed})")
    out = {"speeds": speeds, "repeats": repeats, "gains": gains, "gain_classes": paper["gain_classes"],
           "rig": rig, "campaign_seed": int(settings.get("campaign_seed", 0)), "poses": poses, "design": design,
           "fit": dict(settings.get("fit") or {})}
    _write_json(out_json, out)
    print(f"plan: {len(poses['paper'])} paper, {len(poses['designed'])} designed, {len(poses['heldout'])} held-out "
          f"poses; speeds {speeds} m/s, {repeats} repeat(s), gains {gains}")
    return out


def _key(q, n) -> tuple:
    n = (-1.0, 0.0, 0.0) if n is None else n
    return tuple(round(float(x), 6) for x in list(q) + list(n))


# ----------------------------------------------------------------------------------------
# trials
# ----------------------------------------------------------------------------------------
def scenes(the_plan: Mapping[str, Any], role: str, gain: str, *, structure: str | None = None) -> list:
    """The scenes of one role and gain set of a plan; on the flexible base under the named
    ``structure`` when one is given."""

    if role not in ROLES:
        raise InputError(f"unknown role {role!r}; expected one of {ROLES}")
    base = FIXED if structure is None else FLEXIBLE
    params = None if structure is None else {"flexible.structure": structure}
    out = []
    for p in the_plan["poses"][role]:
        for v in p["speeds"]:
            for r in range(int(the_plan["repeats"])):
                if p["config"]:
                    sc = make_scene(base=base, config=int(p["config"]), gain=gain, speed=float(v), repeat=r,
                                    rig=the_plan.get("rig"), campaign_seed=int(the_plan["campaign_seed"]),
                                    params=params)
                else:
                    sc = make_scene(base=base, config=0, q_paper_deg=p["q_paper_deg"], direction=p["direction"],
                                    gain=gain, speed=float(v), repeat=r, rig=the_plan.get("rig"),
                                    campaign_seed=int(the_plan["campaign_seed"]), params=params)
                out.append(sc)
    return out


def run_trials(plan_json, role: str, gain: str, *, archive_dir, out_csv, timer=None,
               structure: str | None = None) -> list[dict]:
    """Simulate and identify one role x gain set of a plan; one trial file per trial, one CSV.
    With ``structure`` the trials are on the flexible base under that named structure, and a
    trial the rig refuses (the platform's stroke) is left out with a line saying why."""

    timer = timer if timer is not None else Timer()
    with open(plan_json, encoding="utf-8") as fh:
        the_plan = json.load(fh)
    todo = scenes(the_plan, role, gain, structure=structure)
    paths = []
    for i, sc in enumerate(todo, 1):
        path = trial_path(archive_dir, sc)
        with timer("simulate"):
            try:
                trial = simulate_arrays(sc)
            except InputError as exc:
                if structure is None:
                    raise
                print(f"[{i}/{len(todo)}] {sc.cell}: refused by the rig ({exc})", flush=True)
                continue
        with timer("write"):
            write_trial(trial, path)
        print(f"[{i}/{len(todo)}] {sc.cell}: seed {sc.seed} -> {path}", flush=True)
        paths.append(path)
    return identify_trials(paths, out_csv, timer=timer)


# ----------------------------------------------------------------------------------------
# report
# ----------------------------------------------------------------------------------------
def _fit(robot, rows, *, seed, options):


    Q = np.array([r["q_cmd"] for r in rows], float)
    D = np.array([r["impact_direction"] for r in rows], float)
    m = np.array([r["m_eff"] for r in rows], float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        est = LambdaFit(robot, direction=D[0], random_state=int(seed), **dict(options or {}))
        est.fit(Q, m, directions=D)
    return est


def _coulomb_fit(robot, rows):

    col = lambda k: np.array([r[k] for r in rows], float)  # noqa: E731
    return CoulombLambdaFit(robot).fit(col("q_cmd"), col("impact_direction"), col("m_eff"), speed=col("speed"),
                                       e=col("e"), m_b=col("hammer_mass"))


def impedance_arrays(robot, rows, rig):
    """Per-trial inputs of :class:`campaign.joints.impedance.ImpedanceFit`: poses, directions,
    speeds, restitutions, hammer masses, measured contact durations and servo gains."""

    col = lambda k: np.array([r[k] for r in rows], float)  # noqa: E731
    gains = {g: servo_gains(robot, g, rig=rig) for g in sorted({r["gain"] for r in rows})}
    return dict(Q=col("q_cmd"), D=col("impact_direction"), m=col("m_eff"), speed=col("speed"), e=col("e"),
                m_b=col("hammer_mass"), duration=col("contact_end") - col("contact_start"),
                stiffness=np.array([gains[r["gain"]][0] for r in rows]),
                damping=np.array([gains[r["gain"]][1] for r in rows]))


def _fit_summary(est) -> dict[str, Any]:
    lam = np.asarray(est.lambda_, float)
    lo, hi = np.asarray(est.lambda_ci_, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.maximum(hi / lam - 1.0, 1.0 - lo / lam)
    return {"lambda": lam, "lambda_ci": [lo, hi], "relative_ci": rel, "condition_number": est.condition_number_,
            "identifiable": [bool(x) for x in est.identifiable_], "identifiability": list(est.identifiability_),
            "n_trials": est.n_trials_, "n_configurations": est.n_configurations_,
            "rms_log_residual": est.rms_log_residual_}


def _asymptotic_ci(est, rows, *, z: float = Z95) -> dict[str, Any]:
    """Gauss-Newton 95 % intervals of a LambdaFit from its per-trial sensitivities and residuals:
    ``cov(ln lambda) = s^2 (S^T S)^-1``, ``s^2 = RSS / (N - nv)``. Used where a stratified
    bootstrap cannot vary (one trial per pose, as in a fit per speed)."""

    Q = np.array([r["q_cmd"] for r in rows], float)
    D = np.array([r["impact_direction"] for r in rows], float)
    lam = np.asarray(est.lambda_, float)
    S = sensitivity_matrix(*design_arrays(est.robot_, Q, D), lam)
    res = np.asarray(est.residuals_, float)
    nv = lam.size
    s2 = float(res @ res) / max(len(res) - nv, 1)
    sd = np.full(nv, np.inf)
    ok = lam > 0
    if ok.any():
        Sk = S[:, ok]
        try:
            sd[ok] = np.sqrt(np.clip(np.diag(s2 * np.linalg.inv(Sk.T @ Sk)), 0.0, None))
        except np.linalg.LinAlgError:
            pass
    with np.errstate(over="ignore", invalid="ignore"):
        lo, hi = lam * np.exp(-z * sd), lam * np.exp(z * sd)
        rel = np.expm1(z * sd)
    return {"lambda": lam, "lambda_ci": [lo, hi], "relative_ci": rel, "condition_number": est.condition_number_,
            "identifiable": [bool(x) for x in est.identifiable_], "n_trials": est.n_trials_,
            "n_configurations": est.n_configurations_, "rms_log_residual": est.rms_log_residual_,
            "interval": "asymptotic (Gauss-Newton)"}


def _errors(pred, meas) -> dict[str, Any]:
    e = np.abs(np.asarray(pred, float) / np.asarray(meas, float) - 1.0)
    return {"median": float(np.median(e)), "p90": float(np.quantile(e, 0.9)), "max": float(np.max(e)),
            "mean": float(np.mean(e)), "errors": e}


def report(plan_json, ident_tables: Mapping[str, Sequence[str]], out_json, out_md, *, model_json) -> dict[str, Any]:
    """Fit, predict the held-out trials, fit per speed; write JSON and Markdown.

    Parameters
    ----------
    plan_json : path-like
    ident_tables : mapping
        Role -> identification CSVs of that role (all gain sets).
    out_json, out_md : path-like
    model_json : path-like
        The response model the campaign saved (:func:`campaign.design.designed_model.fit_model`).
    """

    with open(plan_json, encoding="utf-8") as fh:
        the_plan = json.load(fh)
    rows = {role: [r for r in read_identification(ident_tables.get(role, ())) if is_usable(r)] for role in ROLES}
    excluded = {role: sum(1 for r in read_identification(ident_tables.get(role, ())) if r["excluded"])
                for role in ROLES}
    robot = load_robot(next(r["robot"] for role in ROLES for r in rows[role]))
    options = {"n_bootstrap": 200, "ci": 0.95, **dict(the_plan.get("fit") or {})}
    seed = int(the_plan["campaign_seed"])
    out: dict[str, Any] = {"classes": {}, "excluded": excluded, "speeds": the_plan["speeds"],
                           "n_heldout_poses": len(the_plan["poses"]["heldout"]), "fit_options": options}
    # the response model the campaign saved: one fit on every designed trial (the joints'
    # damping and friction serve every gain set), read back as any user would
    model = load_model(model_json, rig=the_plan.get("rig"))
    out["response_model"] = {**model.summary(), "file": str(model_json),
                             "structure_scatter": dict(getattr(model, "structure_scatter_", {}))}
    for name, gains in the_plan["gain_classes"].items():
        pick = {role: [r for r in rows[role] if r["gain"] in gains] for role in ROLES}
        if not pick["paper"] or not pick["designed"] or not pick["heldout"]:
            raise InputError(f"class {name}: no usable trials of some role "
                             f"({', '.join(f'{k} {len(v)}' for k, v in pick.items())})")
        fits = {role: _fit(robot, pick[role], seed=seed, options=options) for role in ("paper", "designed")}
        ho = pick["heldout"]
        Qh = np.array([r["q_cmd"] for r in ho], float)
        Dh = np.array([r["impact_direction"] for r in ho], float)
        mh = np.array([r["m_eff"] for r in ho], float)
        cls: dict[str, Any] = {"gains": list(gains), "fits": {k: _fit_summary(v) for k, v in fits.items()},
                               "prediction": {}, "per_speed": {}}
        for role, est in fits.items():
            cls["prediction"][role] = _errors(est.predict(Qh, directions=Dh), mh)
        # a constant lambda fitted with the held-out trials themselves (in-sample, not a
        # prediction): how close any constant lambda gets to them
        both = _fit(robot, pick["designed"] + ho, seed=seed, options={**options, "n_bootstrap": 0})
        cls["prediction"]["constant_in_sample"] = _errors(both.predict(Qh, directions=Dh), mh)
        # is lambda a constant? fit it per speed on the designed trials
        per_speed = {}
        for v in the_plan["speeds"]:
            sel = [r for r in pick["designed"] if abs(r["speed"] - v) < 1e-9]
            per_speed[v] = _fit(robot, sel, seed=seed, options={**options, "n_bootstrap": 0})
            cls["per_speed"][f"{v:g}"] = _asymptotic_ci(per_speed[v], sel)
        lam = np.array([per_speed[v].lambda_ for v in the_plan["speeds"]])
        ci = np.array([cls["per_speed"][f"{v:g}"]["lambda_ci"] for v in the_plan["speeds"]])   # (speeds, 2, nv)
        v0, v1 = the_plan["speeds"][0], the_plan["speeds"][-1]
        drift = lam[-1] / lam[0] - 1.0
        # the intervals overlap when the lower speed's upper bound reaches the higher's lower bound
        overlap = [bool(min(ci[0, 1, j], ci[-1, 1, j]) >= max(ci[0, 0, j], ci[-1, 0, j])) for j in range(lam.shape[1])]
        cls["drift"] = {"from_speed": v0, "to_speed": v1, "relative_change": drift, "intervals_overlap": overlap}
        # the smallest model beyond a constant: lambda of the trial's speed (fitted per speed)
        pred = np.empty(len(ho))
        for i, r in enumerate(ho):
            vs = min(per_speed, key=lambda s: abs(s - r["speed"]))
            pred[i] = per_speed[vs].predict(Qh[i][None, :], directions=Dh[i][None, :])[0]
        cls["prediction"]["designed_per_speed"] = _errors(pred, mh)
        # lambda plus a Coulomb impulse per joint, on the designed trials (campaign.joints.coulomb)
        cf = _coulomb_fit(robot, pick["designed"])
        cls["coulomb"] = cf.summary()
        cls["prediction"]["designed_coulomb"] = _errors(
            cf.predict(Qh, Dh, speed=np.array([r["speed"] for r in ho], float)), mh)
        m_imp, lo, hi = model.predict_interval(Impacts.from_records(ho))
        cls["prediction"]["response_model"] = _errors(m_imp, mh)
        cls["response_model_coverage"] = float(np.mean((mh >= lo) & (mh <= hi)))
        cls["heldout"] = [{"q_paper_deg": _paper_deg(r["q_cmd"]), "direction": list(r["impact_direction"]),
                           "gain": r["gain"], "speed": r["speed"], "m_eff_identified": r["m_eff"],
                           **{f"m_eff_{k}": float(fits[k].predict(Qh[i][None], directions=Dh[i][None])[0])
                              for k in fits}, "m_eff_response_model": float(m_imp[i]), "interval_response_model": [float(lo[i]), float(hi[i])]}
                          for i, r in enumerate(ho)]
        out["classes"][name] = cls
    _write_json(out_json, out)
    md = report_markdown(out)
    write_atomic(out_md, md)
    print(md)
    return out


def _paper_deg(q_dh) -> list[float]:

    off = paper_offset_deg()
    return (np.degrees(np.asarray(q_dh, float)) - off).round(6).tolist()


def _ci_cell(lam, lo, hi, rel) -> str:
    return f"{lam:.4g} [{lo:.4g}, {hi:.4g}] (+-{100 * rel:.3g} %)" if math.isfinite(rel) else f"{lam:.4g} [unbounded]"


def _model_cell(m) -> str:
    p = m["parameters"]
    lo, hi = p["params_ci"]
    nv = len(p["damping"])
    return ("damping beta = [" + ", ".join(f"{p['damping'][j]:.4g} [{lo[j]:.4g}, {hi[j]:.4g}]" for j in range(nv))
            + f"] N m s/rad, Coulomb scale s = {p['friction_scale']:.4g} [{lo[nv]:.4g}, {hi[nv]:.4g}] of the drive "
            f"file's levels, rms log residual {m['rms_log_residual']:.3g}")


def report_markdown(out: Mapping[str, Any]) -> str:
    """The designed campaign's report: paper design vs designed, held-out prediction, lambda per speed."""
    lines = ["# Paper design vs designed", "",
             f"Fixed base, speeds {', '.join(f'{v:g}' for v in out['speeds'])} m/s. Lambda [kg m^2] with its 95 % "
             f"bootstrap interval ({out['fit_options'].get('n_bootstrap')} resamples, stratified by pose); held-out: "
             f"{out['n_heldout_poses']} poses with random horizontal directions, in neither fit, m* predicted with "
             "eq 11 and compared with m* identified from their measured channels.", ""]
    rm = out["response_model"]
    lines += ["Response model (the joints' impedance over the contact law's pulse: damping, the servo's known gains, "
              f"Coulomb friction with sticking; read from {rm['file']}, fitted on {rm['n_trials']} designed trials of "
              "every gain set, 95 % intervals): " + _model_cell(rm) + ".", ""]
    for name, cls in out["classes"].items():
        nv = len(cls["fits"]["paper"]["lambda"])
        lines += [f"## {name} (gains {', '.join(cls['gains'])})", "",
                  "| design | trials | poses | " + " | ".join(f"lambda_{j + 1}" for j in range(nv))
                  + " | condition number | identifiable |", "|---|---|---|" + "---|" * nv + "---|---|"]
        for role, label in (("paper", "paper (configurations 1-3, n = -x)"), ("designed", "designed")):
            f = cls["fits"][role]
            cells = [_ci_cell(f["lambda"][j], f["lambda_ci"][0][j], f["lambda_ci"][1][j],
                              f["relative_ci"][j] if f["relative_ci"][j] is not None else math.inf)
                     for j in range(nv)]
            lines.append(f"| {label} | {f['n_trials']} | {f['n_configurations']} | " + " | ".join(cells)
                         + f" | {f['condition_number']:.3g} | " + ", ".join("yes" if x else "no" for x in f["identifiable"])
                         + " |")
        lines += ["", "| prediction of held-out m* (eq 11) from | trials | median error | 90th percentile | worst |",
                  "|---|---|---|---|---|"]
        for key, label in (("paper", "lambda of the paper design"), ("designed", "lambda of the designed campaign"),
                           ("designed_per_speed", "designed, lambda fitted per speed"),
                           ("designed_coulomb", "designed, lambda + Coulomb impulse per joint"),
                           ("response_model", "the response model (joint impedance over the contact; one fit, "
                            "every gain set)"),
                           ("constant_in_sample", "a constant lambda fitted on designed + held-out trials (in-sample)")):
            e = cls["prediction"][key]
            lines.append(f"| {label} | {len(e['errors'])} | {100 * e['median']:.2f} % | {100 * e['p90']:.2f} % | "
                         f"{100 * e['max']:.2f} % |")
        lines += ["", "| speed [m/s] | " + " | ".join(f"lambda_{j + 1}" for j in range(nv)) + " | condition number |",
                  "|---|" + "---|" * nv + "---|"]
        for v, f in cls["per_speed"].items():
            cells = [_ci_cell(f["lambda"][j], f["lambda_ci"][0][j], f["lambda_ci"][1][j],
                              f["relative_ci"][j] if f["relative_ci"][j] is not None else math.inf)
                     for j in range(nv)]
            lines.append(f"| {v} | " + " | ".join(cells) + f" | {f['condition_number']:.3g} |")
        c = cls["coulomb"]
        lines += ["", "Lambda + Coulomb impulse model on the designed trials: lambda = ["
                  + ", ".join(f"{x:.4g}" for x in c["lambda"]) + "] kg m^2, kappa = ["
                  + ", ".join(f"{x:.3g}" for x in c["kappa"]) + f"] N m s, rms log residual {c['rms_log_residual']:.3g}."]
        lines += ["", f"The response model's 95 % intervals hold {100 * cls['response_model_coverage']:.0f} % of the "
                  "held-out trials' identified m*."]
        lines += ["", f"Per speed: {cls['per_speed'][next(iter(cls['per_speed']))].get('interval', '')} 95 % intervals "
                  "(one trial per pose and speed leaves a stratified bootstrap nothing to resample)."]
        d = cls["drift"]
        lines += ["", f"Drift from {d['from_speed']:g} to {d['to_speed']:g} m/s: "
                  + ", ".join(f"lambda_{j + 1} {100 * c:+.1f} % ({'within' if o else 'beyond'} the intervals)"
                              for j, (c, o) in enumerate(zip(d["relative_change"], d["intervals_overlap"], strict=True))) + ".", ""]
    return "\n".join(lines) + "\n"
