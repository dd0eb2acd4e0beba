"""Flexible-base validation: why the held-out Table 4 and Figure 9 comparisons miss.

The rig is calibrated on fixed-base observations only; Table 4 (flexible-base m*) and Figure 9
(Low-vs-High reduction of the peak base amplitude) are held out. This study simulates
flexible-base trials on the stiff mast, identifies them and compares the identified m* with
eq 8 (the trial's emulated base) and with the simulator truth. Three parts:

A. Passive arm (Zero gains, no friction, no gravity: lambda = 0 exactly), contact stiffness
   scaled, which scales the contact duration T_c against the structure's first-mode period
   T_1; ideal coupling and the VES-II loop (``passive_contact.csv``). "eq 8 + K, B"
   (:func:`eq8_with_structure`) is eq 8's linear model with the structure's spring and
   damper kept, driven by the trial's measured contact force.
B. Calibrated rig, the Table 4 cells, lambda identified on the rig's fixed base, the beam's
   EI scaled at an unchanged contact and arm (``structure_stiffness.csv``); ``phi`` places
   the flexible m* between eq 8 (0) and the rig's fixed-base m* (1).
C. Figure 9: the impulse (eq 14), how much of it the arm passes to the base before the base
   peaks, and eq 8's impulsive prediction with the identified lambda, the paper's, and free
   against locked joints (``figure9.csv``, ``figure9_bases.csv``, ``figure9_structures.csv``).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import scipy.linalg as sla

from ..core.vocabulary import FIXED, FLEXIBLE, HIGH, LOW, ZERO, table2_column
from ..model import exiit
from ..model.paper import load_paper, paper_offset_deg
from ..model.robot import load_robot
from ..model.robot.floating import attach_to_floating_base, base_body_of
from ..rig.beam import Beam
from ..rig.controller import equivalent_gains
from ..scene.description import load_rig, make_scene
from .closed_forms import eq7, eq8, impulsive_base_velocity
from .common import (
    CELLS,
    FIG9_SPEED,
    PASSIVE,
    SPEEDS,
    STIFF_MAST,
    Log,
    identified_lambda,
    lambda_rows,
    quiet,
    reduction,
    run_trial,
    write_csv,
)

__all__ = ["Settings", "eq8_with_structure", "passive_contact", "structure_stiffness", "figure9", "servo_frequencies",
           "run"]


@dataclasses.dataclass(frozen=True)
class Settings:
    """What the study sweeps; :meth:`quick` is a reduced set for the tests."""

    #: contact stiffness multipliers of part A (contact duration ~ k^(-1/(p+1)))
    contact_scales: tuple = (0.3, 1.0, 10.0, 100.0, 1000.0)
    #: beam EI multipliers of part B (first-mode frequency ~ sqrt(EI)) and the VES mode (EI x 1/4
    #: and 1/8 are refused: the VES loop at its default bandwidth and latency is unstable there)
    beams: tuple = ((1 / 16, "loop"), (1 / 16, "ideal"), (1.0, "loop"), (1.0, "ideal"), (4.0, "loop"), (16.0, "loop"))
    speeds: tuple = SPEEDS
    #: (platform mass, beam mass) [kg] of the emulated bases over which part C checks eq 8's
    #: Low-vs-High reduction (the rig's default first; both are unpublished assumptions)
    bases: tuple = ((50.0, 200.0), (10.0, 50.0), (10.0, 200.0), (200.0, 200.0), (50.0, 800.0))

    @classmethod
    def quick(cls) -> Settings:
        return cls(contact_scales=(1.0,), beams=((1.0, "loop"),), speeds=(FIG9_SPEED,), bases=((50.0, 200.0),))


def eq8_with_structure(robot, trial: dict, lam) -> float:
    """Eq 8's linear model with the structure's spring and damper kept: the free-flyer base +
    arm (lambda added to the arm's inertia) on the beam's tip stiffness K and damping B,
    linearised at the commanded pose and driven along n by the trial's measured contact force;
    m* = impulse / tip velocity along n at the contact end [kg]. For a short contact (or
    K = B = 0) this is eq 8; for a contact long against the structure's periods the spring
    holds the base and it tends to the fixed-base eq 7."""
    rec = trial["record"]
    frobot = attach_to_floating_base(robot, base_body_of(rec))
    model = frobot.model
    data = model.createData()
    q = frobot.q_full(np.asarray(rec["q_cmd"], float))
    M = exiit.inertia(model, data, q)
    M[6:, 6:] += exiit.lambda_matrix(lam, frobot.nv_arm)
    J = exiit.impact_jacobian(model, data, q, frobot.impact_frame_id)
    b = J[:3].T @ exiit.unit_direction(rec["impact_direction"])
    nv = M.shape[0]
    K, B = np.zeros((nv, nv)), np.zeros((nv, nv))
    K[:6, :6] = trial["beam"].stiffness       # the free-flyer's base coordinates at rest are the
    B[:6, :6] = trial["beam"].damping         # beam tip's (u, theta), world-aligned
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((nv, nv)), np.eye(nv)], [-Mi @ K, -Mi @ B]])
    t, f = trial["force"]
    h = float(np.mean(np.diff(t)))
    E = sla.expm(np.block([[A, np.concatenate([np.zeros(nv), Mi @ b])[:, None]],
                           [np.zeros((1, 2 * nv + 1))]]) * h)      # zero-order hold at the piezo step
    Ad, Bd = E[:2 * nv, :2 * nv], E[:2 * nv, -1]
    x = np.zeros(2 * nv)
    for fk in f[:-1]:
        x = Ad @ x + Bd * fk
    return float(h * np.sum(f[:-1]) / (b @ x[nv:]))


def passive_contact(*, scales, log: Log = quiet) -> list[dict]:
    """Part A: passive arm (lambda = 0), 1.5 m/s, contact stiffness scaled: true and identified
    m* on the fixed base, under ideal coupling and under the VES loop, beside eq 7, eq 8 and
    eq 8 + K, B."""
    robot = load_robot()
    k0 = float(load_rig()[0]["contact.stiffness"])
    rows = []
    for c in (1, 2):
        for s in scales:
            p = dict(PASSIVE, **{"contact.stiffness": k0 * s})
            fx = run_trial(base=FIXED, config=c, gain=ZERO, speed=1.5, params=p)
            ideal, loop = (run_trial(base=FLEXIBLE, config=c, gain=ZERO, speed=1.5, params=dict(p, **{"ves.mode": m}))
                           for m in ("ideal", "loop"))
            row = {"config": c, "contact_scale": s, "Tc_s": fx["Tc"], "Tc_over_T1": fx["Tc"] * loop["f1"],
                   "Tc_times_f2": fx["Tc"] * loop["freqs"][2], "f1_Hz": loop["f1"],
                   "eq8_kg": eq8(robot, loop["record"], None), "eq8_KB_kg": eq8_with_structure(robot, ideal, None),
                   "ideal_truth_kg": ideal["m_truth"], "loop_truth_kg": loop["m_truth"],
                   "loop_identified_kg": loop["m_ident"], "eq7_kg": eq7(robot, fx["record"], None),
                   "fixed_truth_kg": fx["m_truth"]}
            rows.append(row)
            log(f"A config {c} contact x{s:g}: Tc {1e3 * row['Tc_s']:.1f} ms, Tc/T1 {row['Tc_over_T1']:.3f}, eq 8 "
                f"{row['eq8_kg']:.3f}, ideal {row['ideal_truth_kg']:.3f}, loop {row['loop_truth_kg']:.3f}, "
                f"fixed {row['fixed_truth_kg']:.3f}, eq 7 {row['eq7_kg']:.3f}")
    return rows


def structure_stiffness(lam: dict, *, beams, speeds, log: Log = quiet) -> tuple[list[dict], dict]:
    """Part B: the Table 4 cells at each beam EI and VES mode with the identified lambda
    (means over ``speeds``). Returns the rows and the trials."""
    robot = load_robot()
    paper = load_paper()
    ei0 = float(load_rig()[0]["flexible.beam_EI"])
    rows, trials = [], {}
    for ei, mode in beams:
        params = {"flexible.beam_EI": ei0 * ei, "ves.mode": mode}
        if (ei, mode) != (1.0, "loop"):
            params["flexible.trial_periods"] = 1.0   # m* needs the contact, not 4 periods
        for c, g in CELLS:
            tt = trials[(ei, mode, c, g)] = [run_trial(base=FLEXIBLE, config=c, gain=g, speed=v, params=params)
                                             for v in speeds]
            row = {"EI_scale": ei, "ves_mode": mode, "cell": f"{c}-{g}", "f1_Hz": tt[0]["f1"],
                   "Tc_s": float(np.mean([t["Tc"] for t in tt])),
                   "eq8_kg": float(np.mean([eq8(robot, t["record"], lam["lam"][g]) for t in tt])),
                   "eq8_KB_kg": float(np.mean([eq8_with_structure(robot, t, lam["lam"][g]) for t in tt])),
                   "eq7_kg": float(np.mean([eq7(robot, t["record"], lam["lam"][g]) for t in tt])),
                   "identified_kg": float(np.mean([t["m_ident"] for t in tt])),
                   "truth_kg": float(np.mean([t["m_truth"] for t in tt])), "fixed_kg": lam["m_fixed"][(c, g)],
                   "paper_experiment_kg": paper["table4"][f"{c}-{g}"]["experiment"]}
            row["Tc_over_T1"] = row["Tc_s"] * row["f1_Hz"]
            row["phi"] = (row["identified_kg"] - row["eq8_kg"]) / (row["fixed_kg"] - row["eq8_kg"])
            rows.append(row)
            log(f"B EI x{ei:g} {mode} {c}-{g}: Tc/T1 {row['Tc_over_T1']:.3f}, eq 8 {row['eq8_kg']:.2f}, eq 8 + K "
                f"{row['eq8_KB_kg']:.2f}, identified {row['identified_kg']:.2f}, phi {row['phi']:.2f}")
    return rows, trials


def figure9(lam: dict, trials: dict, *, speeds, bases) -> dict:
    """Part C: at the campaign's structure and 2.5 m/s, per configuration: the rig's reduction,
    the impulse's, the momentum passed by the peak, and eq 8's impulsive reduction with the
    rig's lambda, the paper's and free vs locked joints; eq 8's reduction with the paper's
    lambda over other emulated bases; and the rig's reduction at each structure of part B."""
    robot = load_robot()
    paper = load_paper()
    lam_paper = {g: paper["table3"][cls] for cls, members in paper["gain_classes"].items() for g in members}
    iv = list(speeds).index(FIG9_SPEED)
    configs = []
    for c in (1, 2):
        tr = {g: trials[(1.0, "loop", c, g)][iv] for g in (LOW, HIGH)}
        m_b = tr[HIGH]["m_b"]

        def eq8_red(lo, hi, rec_lo=tr[LOW]["record"], rec_hi=tr[HIGH]["record"], m_b=m_b):
            return reduction(impulsive_base_velocity(robot, rec_lo, lo, m_b), impulsive_base_velocity(robot, rec_hi, hi, m_b))

        configs.append({
            "config": c, "peak_low_m": tr[LOW]["peak_base_x"], "peak_high_m": tr[HIGH]["peak_base_x"],
            "reduction": reduction(tr[LOW]["peak_base_x"], tr[HIGH]["peak_base_x"]),
            "impulse_reduction": reduction(tr[LOW]["impulse"], tr[HIGH]["impulse"]),
            **{f"passed_{w}_{g}": tr[g][f"passed_{w}"] for w in ("end", "peak") for g in (LOW, HIGH)},
            "passed_reduction": reduction(tr[LOW]["passed_peak"] * tr[LOW]["impulse"],
                                          tr[HIGH]["passed_peak"] * tr[HIGH]["impulse"]),
            "t_peak_high_s": tr[HIGH]["t_peak"], "Tc_s": tr[HIGH]["Tc"], "f1_Hz": tr[HIGH]["f1"],
            "eq8_rig_lambda": eq8_red(lam["lam"][LOW], lam["lam"][HIGH]),
            "eq8_paper_lambda": eq8_red(lam_paper[LOW], lam_paper[HIGH]),
            "eq8_free_vs_locked": eq8_red(None, np.full(3, 1e6), tr[HIGH]["record"], tr[HIGH]["record"])})
    out_bases = []
    for pm, bm in bases:
        body = Beam.from_scene(make_scene(base=FLEXIBLE, params=dict(STIFF_MAST, **{
            "flexible.platform_mass": pm, "flexible.beam_mass": bm}))).base_body()
        row = {"platform_kg": pm, "beam_kg": bm, "base_mass_kg": float(body.mass)}
        for c in (1, 2):
            rec = dict(trials[(1.0, "loop", c, HIGH)][iv]["record"], base_mass=float(body.mass),
                       base_inertia=np.asarray(body.inertia).ravel().tolist(), base_com=np.asarray(body.com).tolist(),
                       base_mount=[0.0, 0.0, 0.0])
            m_b = trials[(1.0, "loop", c, HIGH)][iv]["m_b"]
            row[f"reduction_config{c}"] = reduction(*(impulsive_base_velocity(robot, rec, lam_paper[g], m_b)
                                                      for g in (LOW, HIGH)))
        out_bases.append(row)
    variants = [{"EI_scale": ei, "ves_mode": mode, "config": c,
                 "reduction": reduction(tt[iv]["peak_base_x"], trials[(ei, mode, c, HIGH)][iv]["peak_base_x"])}
                for (ei, mode, c, g), tt in trials.items() if g == LOW]
    return {"configs": configs, "bases": out_bases, "variants": variants, "paper_lambda": _paper_lambda(trials, iv)}


def _paper_lambda(trials: dict, iv: int) -> list[dict]:
    """Eq 7 and eq 8 with the paper's Table 3 lambda on the rig's trials (eq 8 on the rig's
    base), beside the paper's eq 8, experiment and fixed-base columns."""
    robot = load_robot()
    paper = load_paper()
    lam_paper = {g: paper["table3"][cls] for cls, members in paper["gain_classes"].items() for g in members}
    rows = []
    for c, g in CELLS:
        rec = trials[(1.0, "loop", c, g)][iv]["record"]
        rows.append({"cell": f"{c}-{g}", "eq7_kg": eq7(robot, rec, lam_paper[g]), "eq8_kg": eq8(robot, rec, lam_paper[g]),
                     "paper_eq8_kg": paper["table4"][f"{c}-{g}"]["predicted"],
                     "paper_experiment_kg": paper["table4"][f"{c}-{g}"]["experiment"],
                     "paper_fixed_kg": paper["table2"][table2_column(g)][c]})
    return rows


def servo_frequencies() -> list[dict]:
    """High-gain servo natural frequency sqrt(Kp / H_jj) per joint [Hz], configurations 1-2."""
    robot = load_robot()
    paper = load_paper()
    sc = make_scene(gain=HIGH)
    g = paper["gains"][HIGH]
    Kp = equivalent_gains(g["P"], g["D"], g["I"], scale=sc.p("controller.torque_per_unit"),
                          resolution=robot.encoder_resolution, period=1.0 / sc.p("controller.servo_rate"))[0]
    rows = []
    for c in (1, 2):
        q = np.radians(np.asarray(paper["configurations"][c]) + paper_offset_deg())
        H = np.diag(pin.crba(robot.model, robot.model.createData(), q))
        rows += [{"config": c, "joint": j + 1, "f_Hz": f}
                 for j, f in enumerate(np.sqrt(np.asarray(Kp) / H) / (2 * math.pi))]
    return rows


def run(out_dir, *, quick: bool = False, log: Log = quiet) -> list[str]:
    """Run the study and write its CSV files into ``out_dir``; returns their paths."""
    settings = Settings.quick() if quick else Settings()
    out = Path(out_dir)
    a = passive_contact(scales=settings.contact_scales, log=log)
    lam = identified_lambda(speeds=settings.speeds, log=log)
    b, trials = structure_stiffness(lam, beams=settings.beams, speeds=settings.speeds, log=log)
    c = figure9(lam, trials, speeds=settings.speeds, bases=settings.bases)
    error = [{"cell": f"{k[0]}-{k[1]}", "speed_m_s": v, "identified_over_eq7_minus_1": e}
             for k, errs in lam["error"].items() for v, e in zip(settings.speeds, errs, strict=True)]
    files = [write_csv(out / "lambda.csv", lambda_rows(lam["fits"]), ("gain_class", "joint", "lambda_kg_m2")),
             write_csv(out / "lambda_error.csv", error, ("cell", "speed_m_s", "identified_over_eq7_minus_1")),
             write_csv(out / "servo_frequencies.csv", servo_frequencies(), ("config", "joint", "f_Hz"))]
    for name, rows in (("passive_contact", a), ("structure_stiffness", b), ("figure9", c["configs"]),
                       ("figure9_bases", c["bases"]), ("figure9_structures", c["variants"]),
                       ("paper_lambda", c["paper_lambda"])):
        files.append(write_csv(out / f"{name}.csv", rows, tuple(rows[0])))
    return files
