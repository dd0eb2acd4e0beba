"""What the studies share: one simulated and identified trial, lambda identified on the rig's
own fixed base, and the CSV files the studies write (the closed forms they set beside the
rig: :mod:`campaign.studies.closed_forms`).
"""

from __future__ import annotations

import csv
import io
import os
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np
import pinocchio as pin

from ..core import vocabulary
from ..core.files import write_atomic
from ..identify import identify_trial
from ..identify.results import is_usable
from ..joints.lambda_fit import IdentifiabilityWarning, LambdaFit
from ..model.paper import impact_direction, load_paper, paper_offset_deg
from ..model.robot import load_robot
from ..rig import simulate
from ..rig.beam import Beam
from ..scene.description import make_scene
from .closed_forms import eq7

__all__ = ["STIFF_MAST", "PASSIVE", "CELLS", "SPEEDS", "FIG9_SPEED", "Log", "quiet", "modes", "run_trial",
           "truth_values", "identified_lambda", "lambda_rows", "reduction", "write_csv"]

#: the rig's stiff mast, the structure a study's flexible trials emulate unless it names another
STIFF_MAST = {"flexible.structure": vocabulary.STIFF_MAST}
#: Zero gains and these overrides make the arm passive and frictionless: lambda = 0 exactly
#: (the rotor inertia is in H), so eq 8 needs no identified lambda
PASSIVE = {"gravity": 0.0, "arm.coulomb_scale": 0.0, "arm.viscous_scale": 0.0}
#: the paper's Table 4 cells (configuration, gain set)
CELLS = ((1, vocabulary.LOW), (1, vocabulary.HIGH), (2, vocabulary.LOW), (2, vocabulary.HIGH))
#: the reference campaign's impact speeds [m/s]
SPEEDS = (1.5, 2.5)
#: the campaign's Figure 9 trials (``figures.fig9`` of the configuration) [m/s]
FIG9_SPEED = 2.5

#: a study's progress line printer (the workflow's job log collects what it prints)
Log = Callable[[str], None]


def quiet(line: str) -> None:
    """A :data:`Log` that prints nothing."""


# ----------------------------------------------------------------------------------------
# one trial
# ----------------------------------------------------------------------------------------
def modes(scene) -> np.ndarray:
    """Natural frequencies [Hz] of the structure with the arm (locked) on top, ascending:
    the first bending pair (T_1 = 1/f_1 sets the rig's recording length), the second bending
    pair, torsion, axial."""
    robot = load_robot(scene.p("robot"))
    beam = Beam.from_scene(scene)
    q0 = np.radians(np.asarray(scene.q_paper_deg) + paper_offset_deg())
    data = robot.model.createData()
    pin.ccrba(robot.model, data, q0, np.zeros(robot.nv))
    return np.asarray(beam.modes(tip=beam.base_body().mount.act(data.oYcrb[0]))[0], float)


def truth_values(truth, m_b: float) -> tuple[float, float]:
    """m* and e from eq 10 / eq 12 on the simulator's true edge velocities."""
    va, vap = float(truth["v_a_pre"]), float(truth["v_a_post"])
    vb, vbp = float(truth["v_b_pre"]), float(truth["v_b_post"])
    return m_b * (vb - vbp) / (vap - va), (vap - vbp) / (vb - va)


def run_trial(*, base: str, config: int, gain: str, speed: float, params: Mapping | None = None) -> dict:
    """Simulate and identify one trial (the stiff mast unless ``params`` names a structure):
    its identification record, the true and identified m* (eq 10), the contact and, on the
    flexible base, the structure's modes, the measured base motion and the momentum the arm
    passed to the platform."""
    scene = make_scene(base=base, config=config, gain=gain, speed=speed, params=dict(STIFF_MAST, **(params or {})))
    tree = simulate(scene)
    tr, m = tree["truth"], tree["measured"]
    m_b = float(m.hammer_mass_eff)
    ident = identify_trial(m.to_dataset(), meta=dict(tree.attrs))
    t0, t1 = float(tr.contact_start), float(tr.contact_end)
    m_truth, e_truth = truth_values(tr, m_b)
    out = {"base": base, "config": config, "gain": gain, "speed": speed, "record": ident.to_dict(),
           "m_truth": m_truth, "m_ident": float(ident.m_eff), "excluded": bool(ident.excluded),
           "e_truth": e_truth, "m_b": m_b, "impulse": float(tr.impulse), "Tc": t1 - t0}
    if base == vocabulary.FLEXIBLE:
        out.update(_base_motion(m, t0, t1, out["impulse"]))
        out["freqs"] = modes(scene)
        out["f1"] = float(out["freqs"][0])
        out["beam"] = Beam.from_scene(scene)
    return out


def _base_motion(m, t0: float, t1: float, impulse: float) -> dict:
    """A flexible trial's measured base motion along the impact (x) and across it (y), its
    peak, the share of the impulse the arm has pushed into the platform (F/T force along n,
    rest load removed, integrated) by the contact's end and by the peak, and the piezo's
    contact force over the contact."""
    tb = m.t_base.values
    xb = m.base_position.sel(axis="x").values
    k = int(np.argmax(np.abs(xb)))
    t = m.t_ft.values
    f = m.ft_force.values @ np.asarray(m.impact_direction.values, float)
    f = f - f[t < t0].mean()
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))])
    tf = m.t_force.values
    sel = (tf >= t0) & (tf <= t1)
    return {"peak_base_x": float(abs(xb[k])), "t_peak": float(tb[k] - t0), "t_base": tb, "x_base": xb,
            "y_base": m.base_position.sel(axis="y").values, "t0": t0,
            "passed_end": float(np.interp(t1, t, cum)) / impulse, "passed_peak": float(np.interp(tb[k], t, cum)) / impulse,
            "force": (tf[sel], np.clip(m.f_piezo.values[sel], 0.0, None))}


def reduction(low: float, high: float) -> float:
    """Figure 9's Low-vs-High reduction ``1 - low / high``."""
    return 1.0 - low / high


# ----------------------------------------------------------------------------------------
# lambda from the rig's fixed base
# ----------------------------------------------------------------------------------------
def _usable(trials, members) -> list[dict]:
    return [t["record"] for t in trials if t["gain"] in members and is_usable(t["record"])]


def identified_lambda(*, speeds: Sequence[float] = SPEEDS, log: Log = quiet) -> dict:
    """lambda per gain class (eq 11, 15) identified from the rig's own fixed-base trials
    (configurations 1-3, every gain set, ``speeds``), as Tables 3-4 do (20 bootstrap
    resamples). Returns ``lam`` (gain set -> lambda matrix), ``fits`` (class -> LambdaFit),
    ``fixed`` (the trials), ``m_fixed`` and ``error`` per Table 4 cell: the mean identified m*
    and the lambda model's own error on the fixed base (identified / eq 7 - 1, per speed)."""
    paper = load_paper()
    robot = load_robot()
    fixed = [run_trial(base=vocabulary.FIXED, config=c, gain=g, speed=v)
             for c in (1, 2, 3) for g in (vocabulary.ZERO, vocabulary.LOW, vocabulary.HIGH) for v in speeds]
    fits = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        for cls, members in paper["gain_classes"].items():
            use = _usable(fixed, set(members))
            if use:
                D = np.array([r["impact_direction"] or impact_direction() for r in use], float)
                fits[cls] = LambdaFit(robot, direction=D[0], n_bootstrap=20, random_state=0, warn=False).fit(
                    np.array([r["q_cmd"] for r in use]), np.array([r["m_eff"] for r in use]), directions=D)
    lam = {g: fits[cls].lambda_matrix_ for cls, members in paper["gain_classes"].items() for g in members}
    log("lambda " + "; ".join(f"{cls} {np.round(f.lambda_, 3).tolist()}" for cls, f in fits.items()))
    cell = {(c, g): [f for f in fixed if f["config"] == c and f["gain"] == g] for c, g in CELLS}
    return {"lam": lam, "fits": fits, vocabulary.FIXED: fixed,
            "m_fixed": {k: float(np.mean([f["m_ident"] for f in v])) for k, v in cell.items()},
            "error": {k: [f["m_ident"] / eq7(robot, f["record"], lam[k[1]]) - 1.0 for f in v] for k, v in cell.items()}}


def lambda_rows(fits: Mapping) -> list[dict]:
    """The identified lambda as rows of a CSV: gain class, joint, value [kg m^2]."""
    return [{"gain_class": cls, "joint": j + 1, "lambda_kg_m2": float(x)}
            for cls, f in fits.items() for j, x in enumerate(np.asarray(f.lambda_, float))]


# ----------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------
def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.6g}"
    return str(v)


def write_csv(path: str | os.PathLike, rows: Iterable[Mapping], columns: Sequence[str]) -> str:
    """Write ``rows`` (dicts) as a CSV of ``columns`` atomically, numbers to 6 significant
    digits; returns the path."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in columns])
    write_atomic(path, buf.getvalue())
    return str(path)
