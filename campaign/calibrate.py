"""Calibration of the simulated rig to the paper's fixed-base observations.

:func:`calibrate` fits the unpublished rig parameters of ``config/calibration.yaml`` by
bounded least squares so that a reduced fixed-base sweep matches the paper's Table 2 (m2,
m3), Figure 7's mean restitution, section 3's force range and Figure 5, and
:func:`write_back` records them in ``config/rig.yaml``. :func:`validate` then simulates
what was held out (Table 4, Figure 9) and :func:`assess_held_out` marks each comparison
met or missed, without refitting anything. Each evaluation uses the simulator's true edge
velocities, since identification is validated on its own.

The objective, the targets and the measured results: user guide, *Calibration and
validation* (``docs/calibration.rst``).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import re
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from . import __version__
from .errors import InputError
from .paper import config_dir, load_paper, read_yaml, yaml_load

__all__ = ["CalibrationResult", "load_calibration", "sweep_records", "residuals", "residual_terms", "force_band",
           "hinge_log", "calibrate", "validate", "write_back", "assess_held_out", "impulsive_base_speed",
           "TABLE4_TOLERANCE", "TABLE4_ORDER", "FIGURE9_REDUCTION_BAND", "DIAGNOSIS"]

# Targets of the held-out comparisons (the rig is calibrated on fixed-base observations and
# validated on held-out flexible-base results); they are checked, never fitted.
#: each simulated Table 4 cell (flexible-base m*) within this relative distance of the
#: paper's experiment column
TABLE4_TOLERANCE = 0.15
#: the ordering Table 4 must keep (configuration 2 > configuration 1, High > Low):
#: pairs (larger cell, smaller cell)
TABLE4_ORDER = (("2-low", "1-low"), ("2-high", "1-high"), ("1-high", "1-low"), ("2-high", "2-low"))
#: band of the Low-vs-High reduction of the peak base amplitude, configurations 1 and 2
#: (15-35 %, a band around Figure 9's reported 20-30 %)
FIGURE9_REDUCTION_BAND = (0.15, 0.35)
#: where the reasons of a missed held-out comparison are diagnosed with numbers
DIAGNOSIS = "benchmarks/README.md, 'Flexible-base validation (held-out diagnosis)'"


#: The observation kinds of calibration.yaml (each with a ``weight``; ``force_band`` also has a ``margin``).
OBSERVATIONS = ("table2_m2", "table2_m3", "restitution", "force_band", "figure5")


def load_calibration(path: str | Path | None = None) -> dict:
    """The calibration set-up (``config/calibration.yaml``), checked."""
    path = Path(path) if path is not None else config_dir() / "calibration.yaml"
    if not path.is_file():
        raise InputError(f"calibration file {path} does not exist")
    cfg = read_yaml(path)
    if not isinstance(cfg, dict):
        raise InputError(f"calibration file {path}: expected a mapping of sections, got {type(cfg).__name__}")
    for key in ("sweep", "parameters", "observations", "optimizer"):
        if key not in cfg:
            raise InputError(f"{path}: missing section {key!r}")
    if not isinstance(cfg["parameters"], dict) or not isinstance(cfg["observations"], dict):
        raise InputError(f"{path}: sections 'parameters' and 'observations' must be mappings")
    for name, spec in cfg["parameters"].items():
        bounds = spec.get("bounds") if isinstance(spec, dict) else None
        if not (isinstance(bounds, list) and len(bounds) == 2
                and all(isinstance(b, (int, float)) and not isinstance(b, bool) for b in bounds)):
            raise InputError(f"{path}: parameter {name} needs bounds: [low, high], got {bounds!r}")
        lo, hi = bounds
        if not (0 < lo < hi):
            raise InputError(f"{path}: parameter {name} needs bounds 0 < low < high, got {spec['bounds']}")
    missing = set(OBSERVATIONS) - set(cfg["observations"])
    unknown = set(cfg["observations"]) - set(OBSERVATIONS)
    if missing or unknown:
        raise InputError(f"{path}: observations must be {', '.join(OBSERVATIONS)}"
                         + (f"; missing {', '.join(sorted(missing))}" if missing else "")
                         + (f"; unknown {', '.join(sorted(unknown))}" if unknown else ""))
    force_band(cfg["observations"])
    return cfg


def _batch_records(jobs) -> list[dict]:
    """Simulate trials together (the batched rig) and keep what the objective needs; runs
    in a worker process when the sweep is split across workers."""
    from .errors import SimulationError
    from .rig.batch import simulate_batch
    from .scene import make_scene

    scenes = [make_scene(base=base, config=config, gain=gain, speed=speed, repeat=repeat, params=params, rig=rig)
              for base, config, gain, speed, repeat, params, rig in jobs]
    trials = simulate_batch(scenes)
    for scene, trial in zip(scenes, trials):
        if isinstance(trial, SimulationError):
            raise SimulationError(f"{scene.cell}: {trial}")
    return [_record(job, trial) for job, trial in zip(jobs, trials)]


def _record(job, trial) -> dict:
    """The objective's numbers of one simulated trial (campaign.schema.TrialArrays)."""
    base, config, gain, speed, repeat = job[:5]
    tr, m = trial["truth"].data_vars, trial["measured"].data_vars
    vb, vbp, va, vap = (float(tr[k].values) for k in ("v_b_pre", "v_b_post", "v_a_pre", "v_a_post"))
    m_b = float(m["hammer_mass_eff"].values)
    q3 = tr["q"].values[:, -1]
    rec = {
        "base": base, "config": config, "gain": gain, "speed": speed, "repeat": repeat,
        "m_eff": m_b * (vb - vbp) / (vap - va) if vap != va else math.inf,
        "e": (vap - vbp) / (vb - va),
        "peak_force": float(tr["peak_force"].values),
        "joint3_excursion_deg": float(np.degrees(np.max(np.abs(q3 - q3[0])))),
    }
    if base == "flexible":
        x = m["base_position"].values[:, 0]     # axis x
        rec["peak_base_x"] = float(np.max(np.abs(x)))
    return rec


def sweep_records(params: Mapping[str, Any], sweep: Mapping, *, base: str = "fixed", rig=None,
                  configs=None, gains=None, workers: int | None = None) -> list[dict]:
    """Simulate the sweep with rig parameter overrides ``params``; one record per trial.

    The trials run through the batched rig (:func:`campaign.rig.batch.simulate_batch`),
    split into one batch per worker process when ``workers`` > 1."""
    jobs = [(base, int(c), g, float(v), int(r), dict(params), rig)
            for c in (configs or sweep["configurations"]) for g in (gains or sweep["gains"])
            for v in sweep["speeds"] for r in range(int(sweep.get("repeats", 1)))]
    workers = int(workers or sweep.get("workers", 1))
    if workers <= 1:
        return _batch_records(jobs)
    chunks = [jobs[i::workers] for i in range(workers)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        parts = list(pool.map(_batch_records, chunks))
    records: list = [None] * len(jobs)
    for i, part in enumerate(parts):
        records[i::workers] = part      # chunk i holds jobs i, i + workers, ...
    return records


def _summary(records: list[dict]) -> dict:
    """The observations the paper reports, from trial records."""
    paper = load_paper()
    classes = paper["gain_classes"]
    out: dict[str, Any] = {"m2": {}, "m3": {}}
    for c in sorted({r["config"] for r in records}):
        for name, gains in (("m2", classes["zero_low"]), ("m3", classes["high"])):
            vals = [r["m_eff"] for r in records if r["config"] == c and r["gain"] in gains]
            out[name][c] = float(np.mean(vals)) if vals else math.nan
    speeds = sorted({r["speed"] for r in records})
    out["e_mean"] = float(np.mean([r["e"] for r in records]))
    out["e_by"] = {f"{c}-{g}": float(np.mean([r["e"] for r in records if r["config"] == c and r["gain"] == g]))
                   for c in sorted({r["config"] for r in records}) for g in sorted({r["gain"] for r in records})}
    # the paper's forces "vary between 30-70 N": every trial must lie inside, so the band
    # residual reads the extremes over the whole sweep (force_min/force_max); force_low and
    # force_high are the same extremes at the lowest/highest speed, kept for the reports
    forces = [r["peak_force"] for r in records]
    out["force_min"] = float(np.min(forces))
    out["force_max"] = float(np.max(forces))
    out["force_low"] = float(np.min([r["peak_force"] for r in records if r["speed"] == speeds[0]]))
    out["force_high"] = float(np.max([r["peak_force"] for r in records if r["speed"] == speeds[-1]]))
    mid = speeds[len(speeds) // 2]
    fig5 = [r["joint3_excursion_deg"] for r in records if r["config"] == 1 and r["gain"] == "zero"
            and r["speed"] == mid]
    out["figure5_deg"] = float(np.mean(fig5)) if fig5 else math.nan
    out["figure5_speed"] = mid
    return out


def force_band(observations: Mapping) -> tuple[float, float]:
    """The band [N] the peak forces are fitted into: the paper's 30-70 N narrowed by the
    ``force_band`` observation's relative ``margin`` on each side."""
    lo, hi = load_paper()["impact_force_range_N"]
    margin = float(observations["force_band"].get("margin", 0.0))
    if not 0.0 <= margin < 0.5 * (hi - lo) / hi:
        raise InputError(f"force_band margin must be in [0, {0.5 * (hi - lo) / hi:.3f}), got {margin}")
    return lo * (1.0 + margin), hi * (1.0 - margin)


def hinge_log(value: float, low: float = -math.inf, high: float = math.inf) -> float:
    """One-sided log residual: 0 for ``low <= value <= high``, ``log(low/value)`` below the
    band and ``log(value/high)`` above it (continuous, kinked at the edges; >= 0)."""
    if value < low:
        return math.log(low / value)
    if value > high:
        return math.log(value / high)
    return 0.0


def residual_terms(summary: Mapping, observations: Mapping) -> dict[str, float]:
    """Named, weighted residuals of a sweep summary against the paper (see calibration.yaml).

    Names: ``table2_m2[c]``, ``table2_m3[c]`` per configuration ``c``, ``restitution``,
    ``force_band_low``, ``force_band_high`` (hinges: zero while every trial's peak force
    lies inside the band of :func:`force_band`) and ``figure5``.
    """
    paper = load_paper()
    t2 = paper["table2"]
    w = {k: math.sqrt(float(v["weight"])) for k, v in observations.items()}
    band_lo, band_hi = force_band(observations)
    res: dict[str, float] = {}
    for c in sorted(summary["m2"]):
        res[f"table2_m2[{c}]"] = w["table2_m2"] * math.log(summary["m2"][c] / t2["m2"][int(c)])
        res[f"table2_m3[{c}]"] = w["table2_m3"] * math.log(summary["m3"][c] / t2["m3"][int(c)])
    res["restitution"] = w["restitution"] * (summary["e_mean"] - paper["restitution_mean"]) / 0.05
    res["force_band_low"] = w["force_band"] * hinge_log(summary["force_min"], low=band_lo)
    res["force_band_high"] = w["force_band"] * hinge_log(summary["force_max"], high=band_hi)
    res["figure5"] = w["figure5"] * math.log(summary["figure5_deg"] / paper["figure5_joint3_displacement_deg"])
    if not all(math.isfinite(v) for v in res.values()):
        raise FloatingPointError(f"non-finite calibration residuals {res} for {dict(summary)}")
    return res


def residuals(summary: Mapping, observations: Mapping) -> np.ndarray:
    """Weighted residual vector of a sweep summary against the paper, in the order of
    :func:`residual_terms` (whose keys name the entries)."""
    return np.asarray(list(residual_terms(summary, observations).values()))


@dataclasses.dataclass
class CalibrationResult:
    """Outcome of :func:`calibrate`. Fitted values end in ``_`` (scikit-learn style)."""

    params_: dict
    objective_: float
    residuals_: np.ndarray
    residual_names_: list
    summary_: dict
    sensitivity_: dict       # d residual / d log(parameter) at the solution
    n_evaluations_: int
    start_: dict
    success_: bool
    message_: str

    def to_dict(self) -> dict:
        return {"params": self.params_, "objective": self.objective_, "residuals": self.residuals_.tolist(),
                "residual_names": list(self.residual_names_),
                "summary": self.summary_, "sensitivity": self.sensitivity_, "n_evaluations": self.n_evaluations_,
                "start": self.start_, "success": self.success_, "message": self.message_}


def calibrate(*, calibration=None, rig=None, progress=print, max_nfev: int | None = None) -> CalibrationResult:
    """Fit the unpublished rig parameters to the paper's fixed-base observations.

    Parameters
    ----------
    calibration : path, optional
        Calibration set-up (default ``config/calibration.yaml``).
    rig : path, optional
        Rig parameter file the start values come from (default ``config/rig.yaml``).
    progress : callable
        Receives one line per evaluation.
    max_nfev : int, optional
        Overrides the optimizer's evaluation budget.
    """
    from .scene import load_rig

    cfg = load_calibration(calibration)
    values, _ = load_rig(rig)
    names = list(cfg["parameters"])
    for n in names:
        if n not in values:
            raise InputError(f"calibration parameter {n!r} is not a rig parameter")
    lo = np.log([cfg["parameters"][n]["bounds"][0] for n in names])
    hi = np.log([cfg["parameters"][n]["bounds"][1] for n in names])
    x0 = np.clip(np.log([float(values[n]) for n in names]), lo + 1e-9, hi - 1e-9)
    sweep, obs = cfg["sweep"], cfg["observations"]
    cache: dict[tuple, tuple[np.ndarray, dict]] = {}
    count = [0]

    def fun(x):
        key = tuple(np.round(x, 12))
        if key not in cache:
            params = {n: float(math.exp(v)) for n, v in zip(names, x)}
            summary = _summary(sweep_records(params, sweep, rig=rig))
            r = residuals(summary, obs)
            count[0] += 1
            cache[key] = (r, summary)
            progress(f"calibrate: evaluation {count[0]:3d}  objective {0.5 * float(r @ r):.5f}  "
                     f"F {summary['force_min']:.2f}-{summary['force_max']:.2f} N  "
                     + "  ".join(f"{n.split('.')[-1]}={v:.4g}" for n, v in params.items()))
        return cache[key][0]

    opt = cfg["optimizer"]
    h = float(opt.get("diff_step", 0.05))

    def jac(x):
        # forward differences with a fixed step in log space (a 5 % change of each
        # parameter): stick-slip and encoder quantisation make the objective rough below
        # that, and least_squares' own diff_step is relative to |x|, i.e. to |log p|
        r0 = fun(x)
        J = np.empty((r0.size, x.size))
        for i in range(x.size):
            step = h if x[i] + h <= hi[i] else -h
            xi = x.copy()
            xi[i] += step
            J[:, i] = (fun(xi) - r0) / step
        return J

    from scipy.optimize import least_squares   # lazily: the campaign's report job never fits (~0.6 s import)

    sol = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method=opt.get("method", "trf"),
                        max_nfev=int(max_nfev or opt.get("max_nfev", 60)))
    r, summary = cache[tuple(np.round(sol.x, 12))]
    J = jac(sol.x)
    names_r = list(residual_terms(summary, obs))
    summary = dict(summary, force_band_N=list(force_band(obs)))
    sens = {n: [float(v) for v in J[:, i]] for i, n in enumerate(names)}
    return CalibrationResult(
        params_={n: float(math.exp(v)) for n, v in zip(names, sol.x)}, objective_=0.5 * float(r @ r),
        residuals_=r, residual_names_=names_r, summary_=summary, sensitivity_=sens, n_evaluations_=count[0],
        start_={n: float(values[n]) for n in names}, success_=bool(sol.success), message_=str(sol.message))


def write_back(result: CalibrationResult, rig: str | Path | None = None) -> Path:
    """Write the fitted values into the rig file in place (keeping its comments and notes)
    and record the fit under ``calibration:``; atomic."""
    import os
    import tempfile

    path = Path(rig) if rig is not None else config_dir() / "rig.yaml"
    text = path.read_text()
    for key, value in result.params_.items():
        section, leaf = key.split(".", 1)
        m = re.search(rf"(?m)^{re.escape(section)}:\n((?:[ \t].*\n|\n)*)", text)
        if not m:
            raise InputError(f"{path}: no section {section!r} for {key}")
        block = m.group(1)
        new_block, n = re.subn(rf"(?m)^(\s+{re.escape(leaf)}: \{{value: )([^,}}]+)", rf"\g<1>{value:.6g}", block, 1)
        if n != 1:
            raise InputError(f"{path}: no line for {key}")
        text = text[:m.start(1)] + new_block + text[m.end(1):]
    stamp = {
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d"),
        "package_version": __version__,
        "objective": round(result.objective_, 8),
        "residuals": {n: round(float(v), 6) for n, v in zip(result.residual_names_, result.residuals_)},
        "evaluations": result.n_evaluations_,
        "values": {k: float(f"{v:.6g}") for k, v in result.params_.items()},
        "sensitivity_norm": {k: round(float(np.linalg.norm(v)), 4) for k, v in result.sensitivity_.items()},
        "summary": json.loads(json.dumps(result.summary_, default=float)),
    }
    import yaml
    body = yaml.safe_dump(stamp, sort_keys=True, default_flow_style=False, width=100)
    block = "calibration:  # written by `campaign calibrate`; reproduce with that one command\n" + \
        "".join("  " + line + "\n" for line in body.splitlines())
    text = re.sub(r"(?ms)^calibration:.*?(?=^\S|\Z)", "", text).rstrip("\n") + "\n\n" + block
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".rig.", suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)
    return path


def validate(*, rig=None, speeds=(1.0, 1.75, 2.5), workers: int = 2, fixed: Mapping | None = None) -> dict:
    """Held-out comparison (never fitted): flexible-base m* (Table 4) and the Low-vs-High
    reduction of the peak base amplitude (Figure 9), configurations 1-2.

    ``fixed`` (optional) is a fixed-base sweep summary (``m2``, ``m3`` per configuration, as
    :func:`calibrate` records it): it only enters the reasons of the verdicts. The result's
    ``assessment`` holds the rows of :func:`assess_held_out`.
    """
    from .rig.beam import Beam
    from .rig.pendulum import Pendulum
    from .robot import load_robot
    from .scene import make_scene

    sweep = {"speeds": list(speeds), "repeats": 1, "workers": workers}
    recs = sweep_records({}, sweep, base="flexible", rig=rig, configs=[1, 2], gains=["low", "high"])
    paper = load_paper()
    out = {"table4": {}, "figure9": {}}
    for c in (1, 2):
        for g in ("low", "high"):
            sel = [r for r in recs if r["config"] == c and r["gain"] == g]
            out["table4"][f"{c}-{g}"] = {"simulated": float(np.mean([r["m_eff"] for r in sel])),
                                         "paper_experiment": paper["table4"][f"{c}-{g}"]["experiment"]}
        peaks = {g: float(np.mean([r["peak_base_x"] for r in recs if r["config"] == c and r["gain"] == g]))
                 for g in ("low", "high")}
        # eq 8's own answer with the paper's lambda on this base (the reason of a miss)
        scene = make_scene(base="flexible", config=c, rig=rig)
        p = scene.p
        m_b = Pendulum(float(p("pendulum.head_mass")), float(p("pendulum.rod_mass")), float(p("pendulum.radius")),
                       float(p("gravity")), float(p("pendulum.max_release_deg"))).m_b
        q = np.radians(np.asarray(scene.q_paper_deg) + np.asarray(paper["offset_deg"]))
        speed = {g: impulsive_base_speed(load_robot(p("robot")), q, Beam.from_scene(scene).base_body(),
                                         _paper_lambda(g), m_b, paper["impact_direction"]) for g in ("low", "high")}
        out["figure9"][c] = {"peak_low_m": peaks["low"], "peak_high_m": peaks["high"],
                             "reduction": 1.0 - peaks["low"] / peaks["high"],
                             "eq8_paper_lambda": 1.0 - speed["low"] / speed["high"]}
    table4 = {k: {"paper": v["paper_experiment"], "simulated": v["simulated"]} for k, v in out["table4"].items()}
    if fixed:
        for k, v in table4.items():
            c, g = k.split("-")
            group = fixed["m3" if g == "high" else "m2"]
            v["fixed"] = float(group[c] if c in group else group[int(c)])
    out["assessment"] = assess_held_out(
        table4, {c: {"reduction": v["reduction"], "eq8_paper_lambda": v["eq8_paper_lambda"]}
                 for c, v in out["figure9"].items()})
    return out


def _paper_lambda(gain: str) -> list[float]:
    """The paper's Table 3 lambda of a gain set's class."""
    paper = load_paper()
    cls = next(name for name, members in paper["gain_classes"].items() if gain in members)
    return list(paper["table3"][cls])


def impulsive_base_speed(robot, q_arm, base, lam, m_b: float, n) -> float:
    """Eq 8's base velocity along ``n`` right after an impulsive contact, per unit hammer
    momentum ``(1 + e) m_b v_b`` [m/s per N s].

    The arm (``lam`` added to its joint inertia) stands on the free base ``base`` (a
    :class:`~campaign.robot.floating.BaseBody`); the impulse on the tip is ``P n`` with
    ``P = m*/(m* + m_b)`` per unit hammer momentum (eq 14, m* from eq 8), and the
    generalised velocity jump is ``(M + lambda)^-1 J^T n P``. The ratio of its Low and High
    values is the Ex-IIT's answer to Figure 9's Low-vs-High reduction of the base motion
    (the spring and damper of the structure transmit no impulse).
    """
    from . import exiit
    from .robot.floating import attach_to_floating_base

    frobot = attach_to_floating_base(robot, base)
    model = frobot.model
    data = model.createData()
    q_arm = np.asarray(q_arm, float)
    q = frobot.q_full(q_arm)
    M = exiit.inertia(model, data, q)
    M[6:, 6:] += exiit.lambda_matrix(lam, frobot.nv_arm)
    J = exiit.impact_jacobian(model, data, q, frobot.impact_frame_id)
    n = exiit.unit_direction(n)
    jump = np.linalg.solve(M, J[:3].T @ n)
    m8 = exiit.effective_mass_from_G(exiit.exiit_floating(frobot, q_arm, lam, data=data), n)
    return float(n @ jump[:3]) * m8 / (m8 + m_b)


def _pct(x: float) -> str:
    return f"{100 * x:+.1f} %"


def assess_held_out(table4: Mapping[str, Mapping], figure9: Mapping[Any, Mapping]) -> list[dict]:
    """Mark each held-out comparison met or missed against the validation targets, with the
    reason of a miss (pointing to :data:`DIAGNOSIS` for its numbers).

    Parameters
    ----------
    table4 : mapping
        ``"<config>-<gain>"`` -> ``{"paper": experiment column, "simulated": m*}`` and
        optionally ``"eq8"`` (the rig's own eq 8 prediction of that cell) and ``"fixed"``
        (the rig's fixed-base m* of that configuration and gain class) [kg].
    figure9 : mapping
        configuration -> ``{"reduction": Low-vs-High reduction of the peak base amplitude}``
        and optionally ``"eq8_paper_lambda"`` (the reduction :func:`impulsive_base_speed`
        gives with the paper's Table 3 lambda).

    Returns
    -------
    list of dict
        One row per Table 4 cell, one for the ordering, one per Figure 9 configuration:
        ``kind`` ("held-out"), ``observation``, ``paper``, ``simulated``,
        ``relative_difference``, ``target``, ``verdict`` ("met" | "missed"), ``reason``
        (why it missed; empty when met) and ``note`` (what the rig does where the paper's
        own numbers are inconsistent with eq 8, met or not).
    """
    paper = load_paper()
    t2, p4 = paper["table2"], paper["table4"]
    see = f"See {DIAGNOSIS}."
    gap = max(abs(v["experiment"] / v["predicted"] - 1.0) for v in p4.values())
    rows: list[dict] = []
    for key, cell in table4.items():
        c, g = str(key).split("-")
        ref, sim = float(cell["paper"]), float(cell["simulated"])
        eq8, fixed = cell.get("eq8"), cell.get("fixed")
        rel = sim / ref - 1.0
        met = abs(rel) <= TABLE4_TOLERANCE
        name = "m3" if g == "high" else "m2"
        paper_fixed = t2[name].get(int(c))
        note = ""
        if paper_fixed is not None and ref > paper_fixed:
            note = (f"the paper's flexible-base value ({ref:.4g} kg) exceeds its own fixed-base {name} "
                    f"({paper_fixed:.4g} kg), which eq 8 cannot give with one lambda (a free base only adds mobility: "
                    "eq 8 <= eq 7); the rig's flexible-base m* (" + f"{sim:.4g} kg) stays "
                    + (f"above its eq 8 prediction ({eq8:.4g} kg) and " if eq8 else "")
                    + (f"below its fixed-base m* ({fixed:.4g} kg)" if fixed else "below its fixed-base m*")
                    + ", hence under the paper there. " + see)
        reason = ""
        if not met:
            if sim > ref:
                reason = (("the rig's m* is "
                           + (f"{_pct(sim / eq8 - 1)} above its own eq 8 prediction ({eq8:.4g} kg)" if eq8
                              else "above the paper's")
                           + (f", toward its fixed-base m* ({fixed:.4g} kg)" if fixed else ""))
                          + ": the contact is not short against the periods of the structure's modes (first bending, "
                          "rocking, torsion), so the beam's spring holds the base during it, while eq 8 assumes an "
                          "impulsive contact (inertias only); the paper's experiment column lies within "
                          f"{100 * gap:.1f} % of its eq 8 column. " + see)
            else:
                reason = note or see
        rows.append({"kind": "held-out", "observation": f"Table 4 experiment, configuration {c} {g} [kg]",
                     "paper": ref, "simulated": sim, "relative_difference": rel,
                     "target": f"within {100 * TABLE4_TOLERANCE:.0f} %", "verdict": "met" if met else "missed",
                     "reason": reason, "note": note})
    checked = [(hi, lo) for hi, lo in TABLE4_ORDER if hi in table4 and lo in table4]
    broken = [f"{hi} ({float(table4[hi]['simulated']):.4g} kg) <= {lo} ({float(table4[lo]['simulated']):.4g} kg)"
              for hi, lo in checked if not float(table4[hi]["simulated"]) > float(table4[lo]["simulated"])]
    if checked:
        rows.append({"kind": "held-out", "observation": "Table 4 ordering (configuration 2 > 1, High > Low)",
                     "paper": math.nan, "simulated": math.nan, "relative_difference": math.nan,
                     "target": ", ".join(f"{hi} > {lo}" for hi, lo in checked),
                     "verdict": "missed" if broken else "met",
                     "reason": ("order not kept: " + "; ".join(broken) + ". " + see) if broken else "", "note": ""})
    lo_t, hi_t = FIGURE9_REDUCTION_BAND
    mid = 0.5 * sum(paper["figure9_low_vs_high_reduction"])
    for c, v in figure9.items():
        red = float(v["reduction"])
        met = lo_t <= red <= hi_t
        eq8 = v.get("eq8_paper_lambda")
        reason = ""
        if not met:
            reason = see
            if red < lo_t:
                reason = ("the hammer is much lighter than m*, so the impulse (eq 14) barely depends on the gains, and "
                          "the base peaks while the arm is still passing it the momentum"
                          + (f"; eq 8 with the paper's own Table 3 lambda gives only a {100 * eq8:.1f} % lower base "
                             f"velocity for Low than for High after an impulsive contact on this base (rig: "
                             f"{100 * red:.1f} %)" if eq8 is not None else "")
                          + ". " + see)
        rows.append({"kind": "held-out",
                     "observation": f"Figure 9 Low-vs-High reduction of the peak base amplitude, configuration {c}",
                     "paper": mid, "simulated": red, "relative_difference": red / mid - 1.0,
                     "target": f"{100 * lo_t:.0f}-{100 * hi_t:.0f} %", "verdict": "met" if met else "missed",
                     "reason": reason, "note": ""})
    return rows


def campaign_report(*, rig=None, table4_csv, fig9_trials: Mapping[str, str | Path]) -> tuple[str, list[dict]]:
    """The calibration report of a campaign, without simulating anything.

    Fitted observations, parameter values and their sensitivities come from the
    calibration record in the rig file (written by :func:`write_back`); the held-out
    comparisons come from the campaign's own Table 4 (identified flexible-base m*, and the
    eq 8 prediction with the identified lambda) and its Figure 9 trials (``{"1-low": path,
    "1-high": ..., "2-low": ..., "2-high": ...}``), each marked met or missed against
    the validation targets (:func:`assess_held_out`) with the reason of a miss.

    Returns
    -------
    markdown : str
    rows : list of dict
        One row per comparison: ``kind`` (fitted|held-out), ``observation``, ``paper``,
        ``simulated``, ``relative_difference``, ``target``, ``verdict`` (met|missed; empty
        for fitted rows), ``reason`` (why a held-out comparison missed), ``note``.
    """
    import csv

    from .archive import open_trial_arrays   # plain arrays: the report job never imports xarray
    from .robot import load_robot
    from .tables import base_body_of

    path = Path(rig) if rig is not None else config_dir() / "rig.yaml"
    with open(path) as fh:
        tree = yaml_load(fh)
    record = tree.get("calibration")
    if not record:
        raise InputError(f"{path} has no calibration record: run `campaign calibrate` first")
    paper = load_paper()
    t2 = paper["table2"]
    summary = record["summary"]
    rows: list[dict] = []

    def fixed_value(name, c):
        group = summary[name]
        return float(group[str(c)] if str(c) in group else group[c])

    def row(kind, observation, ref, sim):
        rows.append({"kind": kind, "observation": observation, "paper": ref, "simulated": sim,
                     "relative_difference": sim / ref - 1.0, "target": "", "verdict": "", "reason": "", "note": ""})

    for name in ("m2", "m3"):
        for c in (1, 2, 3):
            row("fitted", f"Table 2 {name}, configuration {c} [kg]", t2[name][c], fixed_value(name, c))
    row("fitted", "mean restitution e (Figure 7)", paper["restitution_mean"], float(summary["e_mean"]))
    lo, hi = paper["impact_force_range_N"]
    row("fitted", "smallest peak force over the sweep [N]", lo, float(summary.get("force_min", summary["force_low"])))
    row("fitted", "largest peak force over the sweep [N]", hi, float(summary.get("force_max", summary["force_high"])))
    row("fitted", f"joint 3 excursion, configuration 1, zero gains, {summary['figure5_speed']} m/s [deg]",
        paper["figure5_joint3_displacement_deg"], float(summary["figure5_deg"]))

    table4 = {}
    with open(table4_csv) as fh:
        for r in csv.DictReader(fh):
            if r.get("in_paper") in ("yes", "True", "true"):
                cell = {"paper": float(r["identified_paper"]), "simulated": float(r["identified"]),
                        "fixed": fixed_value("m3" if r["gain"] == "high" else "m2", int(r["config"]))}
                if r.get("predicted") not in (None, ""):
                    cell["eq8"] = float(r["predicted"])
                table4[f"{r['config']}-{r['gain']}"] = cell
    peaks, speeds = {}, {}
    robot = None
    for key, trial in fig9_trials.items():
        ds = open_trial_arrays(trial)
        x = list(ds["axis"].values).index("x")
        peaks[key] = float(np.max(np.abs(ds["base_position"].values[:, x])))
        # eq 8's impulsive answer with the paper's lambda on this trial's base (a miss's reason)
        robot = robot or load_robot(str(ds.attrs.get("robot") or paper["robot"]))
        base = base_body_of({"base_mass": float(ds["base_mass"].values),
                             "base_inertia": ds["base_inertia"].values.ravel().tolist(),
                             "base_com": ds["base_com"].values.tolist(), "base_mount": ds["base_mount"].values.tolist()})
        speeds[key] = impulsive_base_speed(robot, ds["q_cmd"].values, base, _paper_lambda(key.split("-")[1]),
                                           float(ds["hammer_mass_eff"].values), ds["impact_direction"].values)
    figure9 = {c: {"reduction": 1.0 - peaks[f"{c}-low"] / peaks[f"{c}-high"],
                   "eq8_paper_lambda": 1.0 - speeds[f"{c}-low"] / speeds[f"{c}-high"]} for c in (1, 2)}
    held = assess_held_out(table4, figure9)
    rows.extend(held)

    def num(x, fmt):
        return "" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)

    red_lo, red_hi = paper["figure9_low_vs_high_reduction"]
    n_met = sum(r["verdict"] == "met" for r in held)
    lines = ["# Calibration report", "",
             f"Fit of {', '.join(record['values'])} on the paper's fixed-base observations "
             f"(`campaign calibrate`, {record['date']}, package {record['package_version']}, objective "
             f"{record['objective']}, {record['evaluations']} sweeps). Held-out rows are never fitted: they "
             "come from this campaign's flexible-base trials, and are marked against the validation targets "
             f"(each Table 4 cell within {100 * TABLE4_TOLERANCE:.0f} % of the paper's experiment column with "
             f"its ordering kept; a Low-vs-High reduction of {100 * FIGURE9_REDUCTION_BAND[0]:.0f}-"
             f"{100 * FIGURE9_REDUCTION_BAND[1]:.0f} % for Figure 9). Held out: {n_met} of {len(held)} "
             "comparisons meet their target.", "",
             "| kind | observation | paper | simulated | relative difference | target | verdict |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        rel = r["relative_difference"]
        lines.append(f"| {r['kind']} | {r['observation']} | {num(r['paper'], '.4g')} | {num(r['simulated'], '.4g')} | "
                     f"{'' if math.isnan(rel) else _pct(rel)} | {r['target']} | {r['verdict']} |")
    lines += ["", f"The paper reports a {100 * red_lo:.0f}-{100 * red_hi:.0f} % reduction for Figure 9 (shown as its "
              f"midpoint, {100 * 0.5 * (red_lo + red_hi):.0f} %)."]
    missed = [r for r in held if r["verdict"] == "missed"]
    if missed:
        lines += ["", "## Why held-out comparisons miss", "",
                  "Nothing is refitted on them (they are held out); the reasons found:", ""]
        lines += [f"- **{r['observation']}** ({r['target']}): {r['reason']}" for r in missed]
    notes = [r for r in held if r["note"] and r["note"] != r["reason"]]
    if notes:
        lines += ["", "## Notes on the held-out comparisons", ""]
        lines += [f"- **{r['observation']}** ({r['verdict']}): {r['note']}" for r in notes]
    lines += ["", "## Calibrated parameters", "",
              "| parameter | calibrated value | sensitivity: norm of d(residuals)/d ln(p) |", "|---|---|---|"]
    sens = record.get("sensitivity_norm", {})
    for k, v in record["values"].items():
        lines.append(f"| {k} | {v:.6g} | {sens.get(k, float('nan')):.3g} |")
    lines += ["", "A small sensitivity means the observations barely constrain that parameter; a large one "
              "means it is pinned down (the restitution and the contact exponent most of all)."]
    return "\n".join(lines) + "\n", rows
