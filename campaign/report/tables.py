"""Tables 2-4 of the paper, regenerated from identified trials, beside the published values.

Input: the per-trial identification records (:class:`campaign.identify.TrialIdentification`,
or their ``to_dict()`` form) of a campaign; each record carries its scene identity (base,
configuration, gain, speed, repeat) and its commanded configuration ``q_cmd``. Excluded
trials never enter a table; the tables count the trials they use.

* :func:`table2`  effective mass per configuration: ``m1`` from eq 11 with lambda = 0,
  ``m2`` the mean identified m* of the Zero+Low fixed-base trials, ``m3`` of the High
  ones, the ratios ``m2/m1`` and ``m3/m1``;
* :func:`table3`  lambda per gain class (eq 11, 15) with its bootstrap confidence
  interval and identifiability (:class:`campaign.joints.lambda_fit.LambdaFit`);
* :func:`table4`  flexible base: m* predicted by eq 8 with the class's identified lambda
  and the trial's emulated base (``base_mass``, ``base_inertia``), against the m*
  identified from the flexible trials; the paper's four cells (configurations 1-2 x
  Low/High) first, every other flexible cell after them (``in_paper`` = no).

Every table has the paper's value (``config/paper.yaml``, passed in as ``paper``) beside ours and the
relative difference ``ours / paper - 1``. :func:`write_tables` writes each as CSV (full
precision) and Markdown; :func:`tables_from_archive` runs identification on an archive
folder first.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..core import vocabulary
from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.vocabulary import FIXED, FLEXIBLE
from ..identify import find_trials, identify_files
from ..identify.results import is_usable
from ..joints.impacts import Impacts
from ..joints.lambda_fit import IdentifiabilityWarning, LambdaFit
from ..model.exiit import effective_mass_batch, effective_mass_from_G, exiit_floating
from ..model.paper import impact_direction, paper_robot
from ..model.robot import Robot, load_robot
from ..model.robot.floating import attach_to_floating_base, base_body_of

__all__ = [
    "Table",
    "TABLE_FILES",
    "as_records",

    "fit_gain_classes",
    "flexible_prediction",
    "table2",
    "table3",
    "table4",
    "structures_table",
    "rig_check_table",
    "tables_from_archive",
    "write_tables",
]

#: the per-trial identification table :func:`write_tables` writes beside Tables 2-4
TRIALS_FILE = "identification.csv"
#: every file :func:`write_tables` writes into its folder
TABLE_FILES = tuple(f"{name}.{ext}" for name in ("table2", "table3", "table4") for ext in ("csv", "md")) + (
    TRIALS_FILE,)


@dataclasses.dataclass
class Table:
    """A generated table: columns ``(key, header)``, rows of dicts, notes."""

    name: str
    title: str
    columns: list[tuple[str, str]]
    rows: list[dict]
    notes: list[str] = dataclasses.field(default_factory=list)

    def to_csv(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([k for k, _ in self.columns])
        for row in self.rows:
            w.writerow([_csv_cell(row.get(k)) for k, _ in self.columns])
        return buf.getvalue()

    def to_markdown(self) -> str:
        lines = [f"### {self.title}", ""]
        lines.append("| " + " | ".join(h for _, h in self.columns) + " |")
        lines.append("|" + "|".join("---" for _ in self.columns) + "|")
        for row in self.rows:
            lines.append("| " + " | ".join(_md_cell(row.get(k)) for k, _ in self.columns) + " |")
        if self.notes:
            lines.append("")
            lines.extend(f"- {n}" for n in self.notes)
        return "\n".join(lines) + "\n"

    def write(self, out_dir) -> dict[str, Path]:
        """Write ``<name>.csv`` and ``<name>.md`` into ``out_dir`` (created), each atomically."""
        out = Path(out_dir)
        return {"csv": write_atomic(out / f"{self.name}.csv", self.to_csv()),
                "md": write_atomic(out / f"{self.name}.md", self.to_markdown())}


def _csv_cell(v):
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return repr(float(v)) if math.isfinite(v) else ""
    return str(v)


def _md_cell(v):
    if v is None:
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return "-"
        return f"{v:.4g}"
    return str(v)


def _rel(ours, paper):
    if ours is None or paper is None or not math.isfinite(ours) or not paper:
        return None
    return float(ours) / float(paper) - 1.0


# ----------------------------------------------------------------------------------------
# records
# ----------------------------------------------------------------------------------------
_FIELDS = ("m_eff", "e", "excluded", "base", "config", "gain", "speed", "repeat", "q_cmd", "base_mass",
           "base_inertia", "base_com", "base_mount", "robot", "impact_direction", "path", "reason", "hammer_mass")


def as_records(records: Iterable) -> list[dict]:
    """Normalise identification records (dataclasses or dicts) to plain dicts, checked."""
    out = []
    for i, r in enumerate(records):
        d = r.to_dict() if hasattr(r, "to_dict") else dict(r)
        missing = [k for k in ("m_eff", "excluded", "base", "config", "gain", "q_cmd") if k not in d]
        if missing:
            raise InputError(f"identification record {i} lacks {missing}")
        d = {k: d.get(k) for k in _FIELDS}
        d["m_eff"] = float("nan") if d["m_eff"] is None else float(d["m_eff"])
        d["e"] = float("nan") if d.get("e") is None else float(d["e"])
        d["excluded"] = bool(d["excluded"])
        d["config"] = int(d["config"]) if d["config"] is not None else -1
        d["q_cmd"] = tuple(float(x) for x in d["q_cmd"])
        out.append(d)
    return out


def _usable(recs, base=None, gains=None):
    out = []
    for r in recs:
        if not is_usable(r):
            continue
        if base is not None and r["base"] != base:
            continue
        if gains is not None and r["gain"] not in gains:
            continue
        out.append(r)
    return out


def _robot(robot, recs):

    if isinstance(robot, Robot):
        return robot
    name = robot or next((r["robot"] for r in recs if r.get("robot")), None) or paper_robot()
    try:
        return load_robot(str(name))
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _direction(recs):

    dirs = {tuple(np.round(r["impact_direction"], 9)) for r in recs if r.get("impact_direction")}
    if len(dirs) > 1:
        raise InputError(f"the trials have different impact directions {sorted(dirs)}; fit them separately")
    return np.array(dirs.pop()) if dirs else impact_direction()


def _directions(recs) -> np.ndarray:
    """Each record's impact direction, shape (N, 3) (the paper's where a record has none)."""

    n0 = impact_direction()
    return np.array([r["impact_direction"] if r.get("impact_direction") else n0 for r in recs], float)


def _class_of(gain: str, classes: Mapping[str, Sequence[str]]) -> str | None:
    for name, members in classes.items():
        if gain in members:
            return name
    return None


# ----------------------------------------------------------------------------------------
# lambda per gain class
# ----------------------------------------------------------------------------------------
def fit_gain_classes(records, *, robot=None, gain_classes: Mapping[str, Sequence[str]] | None = None,
                     structure: str = "diagonal", n_bootstrap: int = 200, random_state=0,
                     warn: bool = True) -> dict:
    """Fit lambda (eq 11, 15) per gain class over the usable fixed-base trials.

    Parameters
    ----------
    records : iterable of TrialIdentification or dict
    robot : Robot or str, optional
        Default: the records' robot.
    gain_classes : mapping, optional
        Class name -> gains; default the paper's (``zero_low``: zero+low, ``high``).
    structure, n_bootstrap, random_state, warn
        Passed to :class:`campaign.joints.lambda_fit.LambdaFit`.

    Returns
    -------
    dict
        Class name -> fitted LambdaFit, for every class that has usable trials.
    """

    recs = as_records(records)
    classes = dict(gain_classes or vocabulary.gain_classes())
    rob = _robot(robot, recs)
    fits = {}
    for name, members in classes.items():
        use = _usable(recs, base=FIXED, gains=set(members))
        if not use:
            continue
        D = _directions(use)
        Q = np.array([r["q_cmd"] for r in use])
        m = np.array([r["m_eff"] for r in use])
        fits[name] = LambdaFit(rob, direction=D[0], structure=structure, n_bootstrap=n_bootstrap,
                               random_state=random_state, warn=warn).fit(Q, m, directions=D)
    return fits


# ----------------------------------------------------------------------------------------
# tables
# ----------------------------------------------------------------------------------------
def _configs(recs):
    """config -> q_cmd of the fixed-base records (one q per configuration)."""
    out: dict[int, tuple] = {}
    for r in recs:
        q = out.setdefault(r["config"], r["q_cmd"])
        if not np.allclose(q, r["q_cmd"], atol=1e-9):
            raise InputError(f"configuration {r['config']} has two commanded poses {q} and {r['q_cmd']}")
    return out


def _stats(vals):
    a = np.asarray(vals, float)
    if a.size == 0:
        return None, None, 0
    return float(a.mean()), (float(a.std(ddof=1)) if a.size > 1 else None), int(a.size)


def table2(records, *, paper: Mapping[str, Any], robot=None, gain_classes=None) -> Table:
    """Table 2: effective mass per configuration, fixed base (eq 11 with lambda = 0 vs trials),
    beside the paper's published values (``paper``: ``config/paper.yaml`` as read by
    :func:`campaign.model.paper.load_paper`)."""
    classes = dict(gain_classes or vocabulary.gain_classes())
    recs = as_records(records)
    fixed = [r for r in recs if r["base"] == FIXED]
    rob = _robot(robot, fixed)
    configs = _configs(fixed)
    n = _direction(fixed) if fixed else None
    p2 = paper["table2"]
    rows = []
    for cfg in sorted(configs):
        q = np.asarray(configs[cfg])[None, :]
        m1 = float(effective_mass_batch(rob, q, n)[0])
        # m2 and m3: the trials of the gain class each column averages (config/paper.yaml)
        means = {column: _stats([r["m_eff"] for r in _usable(fixed, gains=set(classes.get(cls, ())))
                                 if r["config"] == cfg]) for column, cls in vocabulary.table2_columns().items()}
        (m2, sd2, n2), (m3, sd3, n3) = means["m2"], means["m3"]
        pm1, pm2, pm3 = (p2[k].get(cfg) for k in ("m1", "m2", "m3"))
        r21 = m2 / m1 if m2 is not None else None
        r31 = m3 / m1 if m3 is not None else None
        pr21 = pm2 / pm1 if pm2 and pm1 else None
        pr31 = pm3 / pm1 if pm3 and pm1 else None
        rows.append({
            "config": cfg,
            "m1": m1, "m1_paper": pm1, "m1_rel": _rel(m1, pm1),
            "m2": m2, "m2_sd": sd2, "m2_n": n2, "m2_paper": pm2, "m2_rel": _rel(m2, pm2),
            "m3": m3, "m3_sd": sd3, "m3_n": n3, "m3_paper": pm3, "m3_rel": _rel(m3, pm3),
            "m2_m1": r21, "m2_m1_paper": pr21, "m2_m1_rel": _rel(r21, pr21),
            "m3_m1": r31, "m3_m1_paper": pr31, "m3_m1_rel": _rel(r31, pr31),
        })
    cols = [("config", "Config"),
            ("m1", "m1 [kg] (eq 11, lambda=0)"), ("m1_paper", "paper"), ("m1_rel", "rel. diff"),
            ("m2", "m2 [kg] (Zero+Low)"), ("m2_sd", "sd"), ("m2_n", "trials"), ("m2_paper", "paper"), ("m2_rel", "rel. diff"),
            ("m3", "m3 [kg] (High)"), ("m3_sd", "sd"), ("m3_n", "trials"), ("m3_paper", "paper"), ("m3_rel", "rel. diff"),
            ("m2_m1", "m2/m1"), ("m2_m1_paper", "paper"), ("m2_m1_rel", "rel. diff"),
            ("m3_m1", "m3/m1"), ("m3_m1_paper", "paper"), ("m3_m1_rel", "rel. diff")]
    excluded = sum(1 for r in fixed if r["excluded"])
    notes = [f"{len(fixed)} fixed-base trials, {excluded} excluded (flagged by identification).",
             "m2, m3: mean of the identified m* (eq 10) of the trials; sd: sample standard deviation.",
             "rel. diff = ours / paper - 1."]
    return Table("table2", "Table 2: identified effective mass versus joint condition (fixed base)", cols, rows, notes)


def table3(fits: Mapping, *, paper: Mapping[str, Any], ci: float | None = None) -> Table:
    """Table 3: Virtual Rotor Inertia per gain class with bootstrap CIs and identifiability,
    beside the paper's (``paper["table3"]``)."""
    p3 = paper["table3"]
    rows = []
    nv = max((np.asarray(f.lambda_).shape[0] for f in fits.values()), default=0)
    for j in range(nv):
        row = {"component": f"lambda_{j + 1}"}
        for cls, f in fits.items():
            if f.structure != "diagonal":
                raise InputError("table3 needs diagonal lambda fits (eq 15)")
            val = float(f.lambda_[j])
            pv = p3.get(cls, [None] * nv)[j] if cls in p3 else None
            row.update({
                f"{cls}": val, f"{cls}_lo": float(f.lambda_ci_[0, j]), f"{cls}_hi": float(f.lambda_ci_[1, j]),
                f"{cls}_sens": float(np.max(np.abs(f.sensitivity_[:, j]))),
                f"{cls}_identifiable": bool(f.identifiable_[j]),
                f"{cls}_paper": pv, f"{cls}_rel": _rel(val, pv),
            })
        rows.append(row)
    cols = [("component", "component")]
    notes = []
    for cls, f in fits.items():
        lvl = f"{100 * f.ci:.0f} %"
        cols += [(cls, f"{cls} [kg m^2]"), (f"{cls}_lo", f"{lvl} CI low"), (f"{cls}_hi", f"{lvl} CI high"),
                 (f"{cls}_sens", "max dln m*/dln lambda"), (f"{cls}_identifiable", "identifiable"),
                 (f"{cls}_paper", "paper"), (f"{cls}_rel", "rel. diff")]
        notes.append(f"{cls}: {f.n_trials_} trials at {f.n_configurations_} configurations, "
                     f"{f.n_bootstrap} bootstrap resamples (stratified by configuration), sensitivity-matrix "
                     f"condition number {f.condition_number_:.3g}, rms log residual {f.rms_log_residual_:.3g}.")
        notes.extend(f"{cls}: warning: {w}" for w in f.warnings_)
    return Table("table3", "Table 3: identified Virtual Rotor Inertia lambda", cols, rows, notes)




def flexible_prediction(record: Mapping, lam, robot) -> float:
    """Predicted m* of a flexible-base trial: eq 8 with ``lam`` and the trial's base [kg]."""

    frobot = attach_to_floating_base(robot, base_body_of(record))
    G = exiit_floating(frobot, np.asarray(record["q_cmd"], float), lam)
    n = record.get("impact_direction") or None
    if n is None:
        n = impact_direction()
    return effective_mass_from_G(G, n)


def _model_prediction(model, use, structure) -> float | None:
    """The response model's mean m* over a cell's usable trials (their poses, directions,
    speeds, gain sets and hammer), on the flexible base under ``structure``."""
    if model is None or not use:
        return None
    return float(np.mean(model.predict(Impacts.from_records(use, structure=structure))))


def table4(records, fits: Mapping, *, paper: Mapping[str, Any], robot=None, gain_classes=None,
           structure: str | None = None, model=None, model_note: str | None = None) -> Table:
    """Table 4: flexible base, m* predicted by eq 8 (identified lambda) and by the response
    ``model`` (:mod:`campaign.joints`, e.g. the shipped ``config/response_model.json``) vs
    identified m*, beside the paper's (``paper["table4"]``); ``structure`` (the named
    structure the trials emulate) and ``model_note`` (why there is no model column, or which
    model it is) go into the notes."""
    classes = dict(gain_classes or vocabulary.gain_classes())
    recs = as_records(records)
    flex = [r for r in recs if r["base"] == FLEXIBLE]
    rob = _robot(robot, flex or recs)
    p4 = paper["table4"]
    cells: dict[tuple[int, str], list] = {}
    for r in flex:
        cells.setdefault((r["config"], r["gain"]), []).append(r)
    paper_cells = []
    for key in p4:
        c, g = str(key).split("-")
        paper_cells.append((int(c), g))
    order = paper_cells + sorted(k for k in cells if k not in paper_cells)
    rows = []
    for cfg, gain in order:
        cell = cells.get((cfg, gain), [])
        use = _usable(cell)
        cls = _class_of(gain, classes)
        pred = None
        if use and cls in fits:
            preds = [flexible_prediction(r, fits[cls].lambda_matrix_, rob) for r in use]
            pred = float(np.mean(preds))
        ident, sd, k = _stats([r["m_eff"] for r in use])
        pp = p4.get(f"{cfg}-{gain}", {})
        mod = _model_prediction(model, use, structure)
        rows.append({
            "config": cfg, "gain": gain, "in_paper": (cfg, gain) in paper_cells, "lambda_class": cls,
            "predicted": pred, "predicted_paper": pp.get("predicted"), "predicted_rel": _rel(pred, pp.get("predicted")),
            "model": mod,
            "identified": ident, "identified_sd": sd, "trials": k, "excluded": len(cell) - k,
            "identified_paper": pp.get("experiment"), "identified_rel": _rel(ident, pp.get("experiment")),
            "pred_vs_ident": _rel(pred, ident), "model_vs_ident": _rel(mod, ident),
        })
    cols = [("config", "Config"), ("gain", "Gain"), ("in_paper", "in paper"), ("lambda_class", "lambda of"),
            ("predicted", "predicted m* [kg] (eq 8)"), ("predicted_paper", "paper"), ("predicted_rel", "rel. diff"),
            ("model", "response model m* [kg]"),
            ("identified", "identified m* [kg] (eq 10)"), ("identified_sd", "sd"), ("trials", "trials"),
            ("excluded", "excluded"), ("identified_paper", "paper"), ("identified_rel", "rel. diff"),
            ("pred_vs_ident", "predicted / identified - 1"), ("model_vs_ident", "model / identified - 1")]
    notes = [("predicted: eq 8 with the gain class's identified lambda (Table 3) and each trial's emulated base "
              "mass, inertia, centre of mass and mount, averaged over the cell's usable trials."),
             ("response model: the joints' impedance over the contact law's pulse on the structure's modal model "
              "through the VES-II loop (campaign.joints), fitted on the designed campaign's fixed-base trials, at "
              "each trial's pose, direction, speed and gain set, averaged likewise."),
             "rows with 'in paper' = no are the other flexible cells of the campaign (extended table)."]
    if model_note:
        notes.append(model_note)
    if structure:
        notes.append(f"structure of the flexible-base trials: {structure}.")
    if not flex:
        notes.append("the campaign has no flexible-base trials: the cells are empty.")
    return Table("table4", "Table 4: effective mass of the flexible-base manipulator", cols, rows, notes)


def structures_table(path, *, paper: Mapping[str, Any]) -> Table:
    """Table 4 and Figure 9's Low-vs-High reduction under both named structures (stiff mast,
    space class), each beside the paper, from the CSV the study
    :mod:`campaign.studies.space_structure` writes (``table4_structures.csv``: the campaign itself
    runs one structure)."""

    lo, hi = (float(x) for x in paper["figure9_low_vs_high_reduction"])
    with open(path, newline="") as fh:
        src = list(csv.DictReader(fh))
    if not src:
        raise ValueError(f"{path}: no rows; run `snakemake study_space_structure`")
    rows = []
    for r in src:
        f = {k: float(v) for k, v in r.items() if k not in ("structure", "cell")}
        rows.append({"structure": r["structure"], "cell": r["cell"], "f1": f["f1_Hz"], "ratio": f["Tc_over_T1"],
                     "eq8": f["eq8_kg"], "identified": f["identified_kg"],
                     "ident_vs_eq8": f["identified_kg"] / f["eq8_kg"] - 1.0,
                     "paper": f["paper_experiment_kg"],
                     "ident_vs_paper": f["identified_kg"] / f["paper_experiment_kg"] - 1.0,
                     "paper_eq8": f["paper_eq8_kg"], "fig9": f["fig9_reduction"], "fig9_eq8": f["fig9_eq8_reduction"]})
    cols = [("structure", "structure"), ("cell", "cell"), ("f1", "f_1 [Hz]"), ("ratio", "T_c / T_1"),
            ("eq8", "eq 8 [kg]"), ("identified", "identified m* [kg]"), ("ident_vs_eq8", "identified / eq 8 - 1"),
            ("paper", "paper experiment [kg]"), ("ident_vs_paper", "identified / paper - 1"),
            ("paper_eq8", "paper eq 8 [kg]"), ("fig9", "Figure 9 reduction (configuration)"),
            ("fig9_eq8", "eq 8's Figure 9 reduction")]
    notes = [f"from {Path(path).name}, written by the study space_structure (lambda identified on the rig's "
             "fixed base; means over 1.5 and 2.5 m/s); the campaign's own Table 4 and Figure 9 use the structure "
             "its config names (bases.flexible.structure)",
             "f_1: first bending mode with the arm on top; T_c: contact duration",
             f"Figure 9 reduction: 1 - peak |x| Low / High at 2.5 m/s for the cell's configuration (paper "
             f"{100 * lo:.0f}-{100 * hi:.0f} %); eq 8's: the same of the base velocity right after an impulsive "
             "contact with the identified lambda"]
    return Table("table4_structures", "Table 4 and Figure 9 under both structures", cols, rows, notes)


def rig_check_table(path) -> Table:
    """The impact planner checked on the rig: per object, contact point and base, the predicted and
    measured ranges of the planner's quantity over its simulated candidates, Spearman's rank
    correlation of the two and the measured value of the planner's best candidate over the worst,
    from the CSV the study :mod:`campaign.studies.plan_rig_check` writes (``plan_rig_check.csv``)."""
    with open(path, newline="") as fh:
        src = list(csv.DictReader(fh))
    if not src:
        raise ValueError(f"{path}: no rows; run `snakemake study_plan_rig_check`")

    def num(text):
        return float(text) if text not in ("", None) else None

    rows = []
    for r in src:
        # displacements in mm, forces in N: the units the planner's table prints
        scale, unit = (1e3, "mm") if r["unit"] == "m" else (1.0, r["unit"])
        base = r["base"] if not r["structure"] else f"{r['base']} ({r['structure']})"
        rows.append({"object": num(r["object_kg"]), "point": r["point"], "base": base, "f1": num(r["f1_Hz"]),
                     "candidates": f"{r['candidates']} ({r['refused']})", "quantity": f"{r['quantity']} [{unit}]",
                     "predicted": f"{scale * float(r['predicted_min']):.3g}-{scale * float(r['predicted_max']):.3g}",
                     "measured": f"{scale * float(r['measured_min']):.3g}-{scale * float(r['measured_max']):.3g}",
                     "spearman": num(r["spearman"]), "best_over_worst": num(r["best_over_worst"]),
                     "spearman_at_once": num(r.get("spearman_at_once")),
                     "best_over_worst_at_once": num(r.get("best_over_worst_at_once")),
                     "spearman_release": num(r.get("spearman_release")),
                     "best_over_worst_release": num(r.get("best_over_worst_release"))})
    cols = [("object", "object m_b [kg]"), ("point", "contact point"), ("base", "base (structure)"),
            ("f1", "f_1 [Hz]"), ("candidates", "candidates (refused)"), ("quantity", "quantity"),
            ("predicted", "predicted range"), ("measured", "measured range"), ("spearman", "Spearman"),
            ("best_over_worst", "best / worst measured"), ("spearman_at_once", "Spearman, impulse at once"),
            ("best_over_worst_at_once", "best / worst, impulse at once"),
            ("spearman_release", "Spearman, eq 8 release alone"),
            ("best_over_worst_release", "best / worst, eq 8 release alone")]
    notes = [f"from {Path(path).name}, written by the study plan_rig_check: every IK branch x gain set x "
             "horizontal direction the planner returns, simulated on the rig (candidates the rig refuses left out)",
             "measured: the simulator truth's peak contact force (fixed base) and peak translational base "
             "displacement (flexible base); best / worst: the measured value of the planner's best candidate "
             "over the largest measured value",
             "the contact as a pulse of finite duration: the peak force at the arm's apparent mass over the "
             "compression (fixed base); the structure's response to the contact's pulse with the arm's servo PD, "
             "joint friction and gravity acting during it and until the structure's peak (flexible base)",
             "impulse at once: the peak force at eq 7's m* with lambda; eq 8's release with the arm's "
             "post-contact motion; eq 8 release alone: the structure's modes released with eq 8's base velocity "
             "change",
             "targets: Spearman >= 0.9 and best / worst <= 0.5; eq 8 assumes an impulsive contact, which the "
             "stiff mast's first mode is too fast for"]
    return Table("plan_rig_check", "The impact planner checked on the rig", cols, rows, notes)


def write_tables(records, out_dir, *, paper: Mapping[str, Any], robot=None, n_bootstrap: int = 200,
                 random_state=0, gain_classes=None) -> dict[str, dict[str, Path]]:
    """Write Tables 2-4 (CSV + Markdown) and the per-trial identification CSV into ``out_dir``.

    Returns
    -------
    dict
        Table name -> {"csv": path, "md": path}; the fits' warnings are in table3's notes.
    """
    recs = as_records(records)
    if not recs:
        raise InputError("no identification records: nothing to tabulate")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        fits = fit_gain_classes(recs, robot=robot, gain_classes=gain_classes, n_bootstrap=n_bootstrap,
                                random_state=random_state, warn=False)
    out = {}
    for t in (table2(recs, paper=paper, robot=robot, gain_classes=gain_classes), table3(fits, paper=paper),
              table4(recs, fits, paper=paper, robot=robot, gain_classes=gain_classes)):
        out[t.name] = t.write(out_dir)
    out["trials"] = _write_trials(records, out_dir)
    return out


def _write_trials(records, out_dir) -> dict[str, Path]:
    rows = [r.to_dict() if hasattr(r, "to_dict") else dict(r) for r in records]
    keys = list(rows[0].keys())
    path = Path(out_dir) / TRIALS_FILE
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(keys)
    for r in rows:
        w.writerow([json.dumps(v) if isinstance(v, (list, tuple)) else _csv_cell(v) for v in (r.get(k) for k in keys)])
    return {"csv": write_atomic(path, buf.getvalue())}


def tables_from_archive(archive, out_dir, *, paper: Mapping[str, Any], n_bootstrap: int = 200, random_state=0,
                        options=None):
    """Identify every trial under ``archive`` and write the tables into ``out_dir``."""
    records = identify_files(find_trials(archive), options=options)
    return write_tables(records, out_dir, paper=paper, n_bootstrap=n_bootstrap, random_state=random_state)
