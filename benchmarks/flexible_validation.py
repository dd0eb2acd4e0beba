"""Flexible-base validation: why the held-out Table 4 and Figure 9 comparisons miss.

The rig is calibrated on fixed-base observations only; Table 4 (flexible-base m*) and
Figure 9 (Low-vs-High reduction of the peak base amplitude) are held out. This diagnostic
simulates flexible-base trials, identifies them (``campaign.identify.identify_trial``) and
compares the identified m* with eq 8 (``campaign.report.tables.flexible_prediction``, the base's
M from the trial's emulated base body) and with the simulator truth (``m_b (v_b - v'_b) /
(v'_a - v_a)`` from the truth group's exact edge velocities). Three parts:

A. Passive arm (Zero gains, no friction, no gravity: lambda = 0 exactly). The contact
   stiffness is scaled 0.3x-1000x, which scales the contact duration T_c against the
   period T_1 of the structure's first mode (arm locked on top). Eq 8 assumes an impulsive
   contact (T_c short against every mode of the structure: the beam's spring transmits no
   impulse); eq 7 (fixed base) is the opposite, quasi-static limit. Both ideal coupling
   (arm + structure integrated as one system) and the VES-II emulation loop are run. "eq 8
   + K, B" (:func:`eq8_with_structure`) is eq 8's linear model with the structure's spring
   and damper kept, driven by the trial's measured contact force.
B. Calibrated rig, the paper's four Table 4 cells at the reference campaign's speeds.
   lambda is identified per gain class from the rig's own fixed-base trials (as Tables 3-4
   do); the beam's EI is scaled (1/16x-16x: every mode by 1/4x-4x) at an unchanged contact
   and arm, so lambda stays what was identified. ``phi = (m* - eq 8) / (m*_fixed - eq 8)`` places
   the flexible m* between eq 8 (phi = 0, impulsive) and the rig's fixed-base m* (phi = 1).
C. Figure 9: what sets the Low-vs-High reduction of the peak base displacement: the
   impulse (eq 14), how much of it the arm passes to the base before the base peaks
   (F/T sensor, the force of the arm on the platform), and the base velocity eq 8 predicts
   right after an impulsive contact with the identified lambda, with the paper's Table 3
   lambda and with the joints free (lambda = 0) against locked (lambda -> inf).

Prints the tables; ``--readme benchmarks/README.md`` writes them as a section of that file.
Rerun: ``.venv/bin/python benchmarks/flexible_validation.py --readme benchmarks/README.md``
(about 1 min on one core; ``--quick`` runs fewer variants).
"""

from __future__ import annotations

import argparse
import datetime
import math
import platform
import time
import warnings

import numpy as np

HEADING = "## Flexible-base validation (held-out diagnosis)"

#: the structure this diagnosis is about (the space-class one: benchmarks/space_structure.py)
STRUCTURE = {"flexible.structure": "stiff_mast"}
#: Zero gains and these overrides make the arm passive and frictionless: lambda = 0 exactly
#: (the rotor inertia is in H), so eq 8 needs no identified lambda.
PASSIVE = {"gravity": 0.0, "arm.coulomb_scale": 0.0, "arm.viscous_scale": 0.0}
#: contact stiffness multipliers of part A (contact duration ~ k^(-1/(p+1)))
CONTACT_SCALES = (0.3, 1.0, 10.0, 100.0, 1000.0)
#: beam EI multipliers of part B (first-mode frequency ~ sqrt(EI)) and the VES mode
#: (EI x 1/4 and 1/8 are refused: the VES loop at its default bandwidth and latency is unstable there)
BEAM_VARIANTS = ((1 / 16, "loop"), (1 / 16, "ideal"), (1.0, "loop"), (1.0, "ideal"), (4.0, "loop"), (16.0, "loop"))
CELLS = ((1, "low"), (1, "high"), (2, "low"), (2, "high"))
SPEEDS = (1.5, 2.5)          # the reference campaign's speeds
FIG9_SPEED = 2.5             # the campaign's Figure 9 trials (config/*.yaml figures.fig9)
#: (platform mass, beam mass) [kg] of the emulated bases over which part C checks eq 8's
#: Low-vs-High reduction (the rig's default first; both are unpublished assumptions)
BASE_VARIANTS = ((50.0, 200.0), (10.0, 50.0), (10.0, 200.0), (200.0, 200.0), (50.0, 800.0))


# ----------------------------------------------------------------------------------------
# one trial
# ----------------------------------------------------------------------------------------
def modes(scene) -> np.ndarray:
    """Natural frequencies [Hz] of the structure with the arm (locked) on top, ascending:
    the first bending pair (T_1 = 1/f_1 sets the rig's recording length), the second bending
    pair, torsion, axial."""
    import pinocchio as pin

    from campaign.model.paper import load_paper
    from campaign.model.robot import load_robot
    from campaign.rig.beam import Beam

    robot = load_robot(scene.p("robot"))
    beam = Beam.from_scene(scene)
    q0 = np.radians(np.asarray(scene.q_paper_deg) + np.asarray(load_paper()["offset_deg"]))
    data = robot.model.createData()
    pin.ccrba(robot.model, data, q0, np.zeros(robot.nv))
    return np.asarray(beam.modes(tip=beam.base_body().mount.act(data.oYcrb[0]))[0], float)


def run_trial(*, base: str, config: int, gain: str, speed: float, params: dict | None = None) -> dict:
    """Simulate and identify one trial; truth and identified m*, contact, base motion."""
    from campaign.identify import identify_trial
    from campaign.rig import simulate
    from campaign.scene.description import make_scene

    scene = make_scene(base=base, config=config, gain=gain, speed=speed, params=dict(STRUCTURE, **(params or {})))
    tree = simulate(scene)
    tr, m = tree["truth"], tree["measured"]
    vb, vbp, va, vap = (float(tr[k]) for k in ("v_b_pre", "v_b_post", "v_a_pre", "v_a_post"))
    m_b = float(m.hammer_mass_eff)
    ident = identify_trial(m.to_dataset(), meta=dict(tree.attrs))
    t0, t1 = float(tr.contact_start), float(tr.contact_end)
    out = {"base": base, "config": config, "gain": gain, "speed": speed, "record": ident.to_dict(),
           "m_truth": m_b * (vb - vbp) / (vap - va), "m_ident": float(ident.m_eff), "excluded": bool(ident.excluded),
           "e_truth": (vap - vbp) / (vb - va), "m_b": m_b, "impulse": float(tr.impulse), "Tc": t1 - t0}
    if base == "flexible":
        out["freqs"] = modes(scene)
        out["f1"] = float(out["freqs"][0])
        tb = m.t_base.values
        xb = m.base_position.sel(axis="x").values
        k = int(np.argmax(np.abs(xb)))
        out["peak_base_x"], out["t_peak"] = float(abs(xb[k])), float(tb[k] - t0)
        out["t_base"], out["x_base"], out["y_base"], out["t0"] = tb, xb, m.base_position.sel(axis="y").values, t0
        # momentum the arm has passed to the platform: the F/T force along the impact
        # direction (the arm's push on the platform), rest load removed, integrated
        t = m.t_ft.values
        n = np.asarray(m.impact_direction.values, float)
        f = m.ft_force.values @ n
        f = f - f[t < t0].mean()
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))])
        out["passed_end"] = float(np.interp(t1, t, cum)) / out["impulse"]
        out["passed_peak"] = float(np.interp(tb[k], t, cum)) / out["impulse"]
        # the measured contact force (piezo) over the contact, for eq8_with_structure
        tf = m.t_force.values
        sel = (tf >= t0) & (tf <= t1)
        out["force"] = (tf[sel], np.clip(m.f_piezo.values[sel], 0.0, None))
        from campaign.rig.beam import Beam
        out["beam"] = Beam.from_scene(scene)
    return out


# ----------------------------------------------------------------------------------------
# Ex-IIT helpers
# ----------------------------------------------------------------------------------------
def eq7(robot, record, lam) -> float:
    from campaign.model import exiit
    return float(exiit.effective_mass(robot, np.asarray(record["q_cmd"], float), record["impact_direction"], lam))


def eq8(robot, record, lam) -> float:
    from campaign.report.tables import flexible_prediction
    return float(flexible_prediction(record, lam, robot))


def eq8_with_structure(robot, trial: dict, lam) -> float:
    """Eq 8's linear model with the structure's spring and damper kept: the free-flyer
    base + arm (lambda added to the arm's inertia) on the beam's tip stiffness K and
    damping B, linearised at the commanded pose and driven along n by the trial's measured
    contact force; m* = impulse / tip velocity along n at the contact end [kg]. For a short
    contact (or K = B = 0) this is eq 8; for a contact long against the structure's periods
    the spring holds the base and it tends to the fixed-base eq 7."""
    import scipy.linalg as sla

    from campaign.model import exiit
    from campaign.model.robot.floating import attach_to_floating_base, base_body_of

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
    K = np.zeros((nv, nv))
    B = np.zeros((nv, nv))
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


def impulsive_base_velocity(robot, record, lam, m_b: float) -> float:
    """Eq 8's base velocity along n right after an impulsive contact (per unit hammer
    momentum) on a trial's emulated base: :func:`campaign.pipeline.calibration_report.impulsive_base_speed`."""
    from campaign.model.robot.floating import base_body_of
    from campaign.pipeline.calibration_report import impulsive_base_speed

    return impulsive_base_speed(robot, record["q_cmd"], base_body_of(record), lam, m_b, record["impact_direction"])


# ----------------------------------------------------------------------------------------
# the three parts
# ----------------------------------------------------------------------------------------
def part_a(log, *, quick: bool = False) -> list[dict]:
    """Passive arm (lambda = 0): m* against eq 8 and eq 7 as the contact shortens."""
    from campaign.model.robot import load_robot
    from campaign.scene.description import load_rig

    robot = load_robot()
    k0 = float(load_rig()[0]["contact.stiffness"])
    scales = (1.0, 10.0, 1000.0) if quick else CONTACT_SCALES
    rows = []
    for c in (1, 2):
        for s in scales:
            p = dict(PASSIVE, **{"contact.stiffness": k0 * s})
            fx = run_trial(base="fixed", config=c, gain="zero", speed=1.5, params=p)
            rec = fx["record"]
            row = {"config": c, "scale": s, "Tc": fx["Tc"], "m7": eq7(robot, rec, None), "fixed": fx["m_truth"]}
            for mode in ("ideal", "loop"):
                fl = run_trial(base="flexible", config=c, gain="zero", speed=1.5, params=dict(p, **{"ves.mode": mode}))
                row[mode] = fl["m_truth"]
                row[f"{mode}_ident"] = fl["m_ident"]
                if mode == "ideal":
                    row["m8K"] = eq8_with_structure(robot, fl, None)
                row["f1"], row["freqs"] = fl["f1"], fl["freqs"]
                row["m8"] = eq8(robot, fl["record"], None)
            row["ratio"] = row["Tc"] * row["f1"]
            rows.append(row)
            log(f"A config {c} contact x{s:g}: Tc {1e3 * row['Tc']:.1f} ms, Tc/T1 {row['ratio']:.3f}, eq 8 "
                f"{row['m8']:.3f}, ideal {row['ideal']:.3f}, loop {row['loop']:.3f}, fixed {row['fixed']:.3f}, "
                f"eq 7 {row['m7']:.3f}")
    return rows


def part_b(log, *, quick: bool = False) -> dict:
    """Calibrated rig: lambda from the rig's fixed-base trials; Table 4 cells vs the beam's EI."""
    from campaign.joints.lambda_fit import IdentifiabilityWarning
    from campaign.model.paper import load_paper
    from campaign.model.robot import load_robot
    from campaign.report.tables import fit_gain_classes
    from campaign.scene.description import load_rig

    robot = load_robot()
    paper = load_paper()
    ei0 = float(load_rig()[0]["flexible.beam_EI"])
    fixed = [run_trial(base="fixed", config=c, gain=g, speed=v)
             for c in (1, 2, 3) for g in ("zero", "low", "high") for v in SPEEDS]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        fits = fit_gain_classes([f["record"] for f in fixed if not f["excluded"]], robot=robot, n_bootstrap=20,
                                random_state=0, warn=False)
    lam = {g: fits[cls].lambda_matrix_ for cls, members in paper["gain_classes"].items() for g in members}
    log("B lambda " + "; ".join(f"{cls} {np.round(f.lambda_, 3).tolist()}" for cls, f in fits.items()))
    m_fixed = {(c, g): float(np.mean([f["m_ident"] for f in fixed if f["config"] == c and f["gain"] == g]))
               for c, g in CELLS}
    # the lambda model's own error on the fixed base, per trial: identified / eq 7 - 1
    lam_error = {(c, g): [f["m_ident"] / eq7(robot, f["record"], lam[g]) - 1.0
                          for f in fixed if f["config"] == c and f["gain"] == g] for c, g in CELLS}
    variants = ((1 / 16, "loop"), (1.0, "loop"), (16.0, "loop")) if quick else BEAM_VARIANTS
    rows, trials = [], {}
    for ei, mode in variants:
        params = {"flexible.beam_EI": ei0 * ei, "ves.mode": mode}
        if (ei, mode) != (1.0, "loop"):
            params["flexible.trial_periods"] = 1.0   # m* needs the contact, not 4 periods
        for c, g in CELLS:
            tt = [run_trial(base="flexible", config=c, gain=g, speed=v, params=params) for v in SPEEDS]
            trials[(ei, mode, c, g)] = tt
            m8 = float(np.mean([eq8(robot, t["record"], lam[g]) for t in tt]))
            m7 = float(np.mean([eq7(robot, t["record"], lam[g]) for t in tt]))
            ident = float(np.mean([t["m_ident"] for t in tt]))
            truth = float(np.mean([t["m_truth"] for t in tt]))
            m8K = float(np.mean([eq8_with_structure(robot, t, lam[g]) for t in tt]))
            Tc = float(np.mean([t["Tc"] for t in tt]))
            row = {"m8K": m8K, "lam_error": lam_error[(c, g)], "EI": ei, "mode": mode, "config": c, "gain": g,
                   "f1": tt[0]["f1"], "freqs": tt[0]["freqs"], "Tc": Tc, "ratio": Tc * tt[0]["f1"], "m8": m8, "m7": m7,
                   "fixed": m_fixed[(c, g)], "ident": ident, "truth": truth,
                   "paper": paper["table4"][f"{c}-{g}"]["experiment"],
                   "phi": (ident - m8) / (m_fixed[(c, g)] - m8)}
            rows.append(row)
            log(f"B EI x{ei:g} {mode} {c}-{g}: Tc/T1 {row['ratio']:.3f}, eq 8 {m8:.2f}, eq 8 + K {m8K:.2f}, identified {ident:.2f} "
                f"(truth {truth:.2f}), fixed {row['fixed']:.2f}, phi {row['phi']:.2f}")
    return {"rows": rows, "trials": trials, "lam": lam, "fits": fits, "m_fixed": m_fixed, "fixed": fixed,
            "lam_error": lam_error}


def part_c(b: dict) -> dict:
    """Figure 9: Low-vs-High reduction of the peak base displacement and what sets it."""
    from campaign.model.paper import load_paper
    from campaign.model.robot import load_robot

    robot = load_robot()
    paper = load_paper()
    t3 = paper["table3"]
    lam_paper = {g: t3[cls] for cls, members in paper["gain_classes"].items() for g in members}
    iv = SPEEDS.index(FIG9_SPEED)
    out: dict = {"configs": {}, "variants": {}}
    for c in (1, 2):
        tr = {g: b["trials"][(1.0, "loop", c, g)][iv] for g in ("low", "high")}
        rec = tr["high"]["record"]
        m_b = tr["high"]["m_b"]

        def red(lo, hi):
            return 1.0 - lo / hi

        vb = {name: red(impulsive_base_velocity(robot, tr["low"]["record"], L["low"], m_b),
                        impulsive_base_velocity(robot, tr["high"]["record"], L["high"], m_b))
              for name, L in (("rig", b["lam"]), ("paper", lam_paper))}
        vb["bounds"] = red(impulsive_base_velocity(robot, rec, None, m_b),
                           impulsive_base_velocity(robot, rec, np.full(3, 1e6), m_b))
        out["configs"][c] = {
            "peak_low": tr["low"]["peak_base_x"], "peak_high": tr["high"]["peak_base_x"],
            "reduction": red(tr["low"]["peak_base_x"], tr["high"]["peak_base_x"]),
            "impulse_low": tr["low"]["impulse"], "impulse_high": tr["high"]["impulse"],
            "impulse_reduction": red(tr["low"]["impulse"], tr["high"]["impulse"]),
            "passed_end": (tr["low"]["passed_end"], tr["high"]["passed_end"]),
            "passed_peak": (tr["low"]["passed_peak"], tr["high"]["passed_peak"]),
            "passed_reduction": red(tr["low"]["passed_peak"] * tr["low"]["impulse"],
                                    tr["high"]["passed_peak"] * tr["high"]["impulse"]),
            "t_peak": (tr["low"]["t_peak"], tr["high"]["t_peak"]), "Tc": tr["high"]["Tc"], "f1": tr["high"]["f1"],
            "eq8_rig": vb["rig"], "eq8_paper": vb["paper"], "eq8_bounds": vb["bounds"],
        }
    # eq 8's impulsive reduction with the paper's lambda over other emulated bases (the base
    # is an assumption of the rig): platform and beam mass scaled
    from campaign.rig.beam import Beam
    from campaign.scene.description import make_scene
    out["bases"] = []
    for pm, bm in BASE_VARIANTS:
        scene = make_scene(base="flexible", params=dict(STRUCTURE, **{"flexible.platform_mass": pm,
                                                                     "flexible.beam_mass": bm}))
        body = Beam.from_scene(scene).base_body()
        red = {}
        for cfg in (1, 2):
            rec = dict(b["trials"][(1.0, "loop", cfg, "high")][iv]["record"])
            rec.update(base_mass=float(body.mass), base_inertia=np.asarray(body.inertia).ravel().tolist(),
                       base_com=np.asarray(body.com).tolist(), base_mount=[0.0, 0.0, 0.0])
            v = {g: impulsive_base_velocity(robot, rec, lam_paper[g], m_b) for g in ("low", "high")}
            red[cfg] = 1.0 - v["low"] / v["high"]
        out["bases"].append({"platform": pm, "beam": bm, "mass": float(body.mass), "reduction": red})
    # the paper's own numbers: eq 7 and eq 8 with its Table 3 lambda (eq 8 on the rig's base)
    out["paper_lambda"] = {}
    for cfg in (1, 2):
        for g in ("low", "high"):
            rec = b["trials"][(1.0, "loop", cfg, g)][iv]["record"]
            out["paper_lambda"][f"{cfg}-{g}"] = {
                "eq7": eq7(robot, rec, lam_paper[g]), "eq8": eq8(robot, rec, lam_paper[g]),
                "paper_eq8": paper["table4"][f"{cfg}-{g}"]["predicted"],
                "paper_exp": paper["table4"][f"{cfg}-{g}"]["experiment"],
                "paper_fixed": paper["table2"]["m3" if g == "high" else "m2"][cfg]}
    for (ei, mode, c, g), tt in b["trials"].items():
        if g == "low":
            lo, hi = tt[iv]["peak_base_x"], b["trials"][(ei, mode, c, "high")][iv]["peak_base_x"]
            out["variants"].setdefault((ei, mode), {})[c] = 1.0 - lo / hi
    return out


def servo_frequencies() -> dict:
    """High-gain servo natural frequency sqrt(Kp / H_jj) per joint [Hz], configurations 1-2."""
    import pinocchio as pin

    from campaign.model.paper import load_paper
    from campaign.model.robot import load_robot
    from campaign.rig.controller import equivalent_gains
    from campaign.scene.description import make_scene

    robot = load_robot()
    paper = load_paper()
    sc = make_scene(gain="high")
    g = paper["gains"]["high"]
    Kp = equivalent_gains(g["P"], g["D"], g["I"], scale=sc.p("controller.torque_per_unit"),
                          resolution=robot.encoder_resolution, period=1.0 / sc.p("controller.servo_rate"))[0]
    out = {}
    for c in (1, 2):
        q = np.radians(np.asarray(paper["configurations"][c]) + np.asarray(paper["offset_deg"]))
        H = np.diag(pin.crba(robot.model, robot.model.createData(), q))
        out[c] = np.sqrt(np.asarray(Kp) / H) / (2 * math.pi)
    return out


# ----------------------------------------------------------------------------------------
# report
# ----------------------------------------------------------------------------------------
def _pct(x: float) -> str:
    return f"{100 * x:+.1f} %"


def _rng(vals, fmt=_pct) -> str:
    """'lo to hi' of a list of numbers (or the one number)."""
    lo, hi = min(vals), max(vals)
    return fmt(lo) if fmt(lo) == fmt(hi) else f"{fmt(lo)} to {fmt(hi)}"


def _f(x: float, d: int = 2) -> str:
    return f"{x:.{d}f}"


def format_report(a: list[dict], b: dict, c: dict, servo: dict, seconds: float) -> str:
    from campaign.bench.common import _md
    from campaign.model.paper import load_paper
    from campaign.pipeline.calibration_report import (
        FIGURE9_REDUCTION_BAND,
        TABLE4_TOLERANCE,
    )

    paper = load_paper()
    rows_b = b["rows"]
    base = [r for r in rows_b if r["EI"] == 1.0 and r["mode"] == "loop"]
    ideal = [r for r in rows_b if r["EI"] == 1.0 and r["mode"] == "ideal"]
    soft_ei = min(r["EI"] for r in rows_b)
    soft = [r for r in rows_b if r["EI"] == soft_ei]
    stiff_ei = max(r["EI"] for r in rows_b)
    stiff = [r for r in rows_b if r["EI"] == stiff_ei]
    fq = base[0]["freqs"]
    Tc = [r["Tc"] for r in base]
    a1 = [r for r in a if r["scale"] == 1.0]
    ashort = [r for r in a if r["scale"] == max(x["scale"] for x in a)]
    lo_t, hi_t = FIGURE9_REDUCTION_BAND
    pl = c["paper_lambda"]
    from campaign.scene.description import load_rig
    rig = load_rig()[0]
    lo_f, hi_f = paper["impact_force_range_N"]
    lo_v, hi_v = paper["impact_speed_range_m_s"]

    L = ["Held-out comparisons of the calibration: why the rig's flexible-base m* misses the paper's "
         "Table 4 and why its Low-vs-High reduction misses Figure 9. Script: `benchmarks/flexible_validation.py` "
         "(its docstring describes the parts). m* *truth*: `m_b (v_b - v'_b) / (v'_a - v_a)` from the simulator's "
         "exact edge velocities; *identified*: `campaign.identify` on the measured channels; *eq 8*: "
         "`campaign.report.tables.flexible_prediction` with the trial's emulated base; *eq 8 + K, B*: the same linear "
         "model with the structure's tip stiffness K and damping B kept, driven by the trial's measured contact "
         "force (`eq8_with_structure`); T_c the contact duration; f_1 the structure's first mode with the arm on "
         "top (T_1 = 1/f_1).", "",
         "### Findings", ""]
    L += [f"1. **Table 4: the contact is not impulsive.** At the campaign's structure the modes with the arm on top "
          f"are {', '.join(f'{x:.1f}' for x in fq)} Hz (two bending pairs, torsion, axial); the ~{1e3 * np.mean(Tc):.0f} "
          f"ms contact lasts {_f(np.mean(Tc) * fq[0])} periods of the first pair, {_f(np.mean(Tc) * fq[2], 1)} of the "
          f"second and {_f(np.mean(Tc) * fq[4], 1)} of torsion. Eq 8 assumes the beam's spring transmits no impulse "
          "during the contact (only M enters); here it does, and the identified m* sits "
          f"{_rng([r['ident'] / r['m8'] - 1 for r in base])} above eq 8 with the identified lambda (phi = "
          f"{_rng([r['phi'] for r in base], lambda x: _f(x))} of the way to the rig's fixed-base m*). Keeping K and B "
          f"in the same linear model (eq 8 + K, B) accounts for it: identified / (eq 8 + K, B) - 1 = "
          f"{_rng([r['ident'] / r['m8K'] - 1 for r in base])}.",
          "2. **Convergence to eq 8 needs T_c short against every mode, not only T_1.** Passive arm (lambda = 0 "
          "exactly), ideal coupling: m* - eq 8 = "
          + ", ".join(f"{_pct(r['ideal'] / r['m8'] - 1)} at T_c/T_1 = {r['ratio']:.3f}" for r in a if r["config"] == 2)
          + f" (configuration 2); eq 8 + K, B is within {100 * max(abs(r['ideal'] / r['m8K'] - 1) for r in a):.1f} % "
          "of the ideally coupled simulation at every contact. With the calibrated contact and "
          f"a {1 / soft_ei:g}x softer beam (T_c/T_1 = {_rng([r['ratio'] for r in soft], lambda x: _f(x, 3))}, but the "
          f"second pair still at {_f(soft[0]['freqs'][2], 1)} Hz) the identified m* is still "
          f"{_rng([r['ident'] / r['m8'] - 1 for r in soft])} above eq 8; with a {stiff_ei:g}x stiffer beam it is at the "
          f"fixed-base value (phi = {_rng([r['phi'] for r in stiff], lambda x: _f(x))}).",
          "3. **The VES loop adds a lag that only matters for short contacts.** Its platform (bandwidth "
          f"{rig['ves.bandwidth']:g} Hz, latency {1e3 * rig['ves.latency']:g} ms) cannot follow a contact that is "
          "short against its response: there the base looks fixed and m* goes to eq 7 instead of eq 8 ("
          + ", ".join(f"configuration {r['config']}: {_pct(r['loop'] / r['m8'] - 1)} vs eq 8, "
                      f"{_pct(r['loop'] / r['fixed'] - 1)} vs the fixed base at T_c = {1e3 * r['Tc']:.1f} ms" for r in ashort)
          + "). At the calibrated contact loop and ideal coupling agree within "
          f"{100 * max(abs(r['loop'] / r['ideal'] - 1) for r in a1):.1f} % (passive)"
          + (f" and {100 * max(abs(x['ident'] / y['ident'] - 1) for x, y in zip(base, ideal)):.1f} % (calibrated, "
             "identified)" if ideal else "") + ".",
          f"4. **The paper's VES-II behaved impulsively, the rig does not.** The paper's experiment column is within "
          f"{100 * max(abs(v['paper_exp'] / v['paper_eq8'] - 1) for v in pl.values()):.1f} % of its eq 8 column; the "
          "rig's base (an assumption: beam length, beam mass, platform) is comparably mobile in eq 8 (eq 8 with "
          "the paper's Table 3 lambda on the rig's base: "
          + ", ".join(f"{k} {v['eq8']:.2f} vs the paper's {v['paper_eq8']:.2f} kg" for k, v in pl.items())
          + "). Identified against the paper's experiment: "
          + ", ".join(f"{r['config']}-{r['gain']} {_pct(r['ident'] / r['paper'] - 1)}" for r in base)
          + f"; the cells above the paper miss the {100 * TABLE4_TOLERANCE:.0f} % target by the non-impulsive "
          "contact, and they are those where eq 8 gives the base the largest share (eq 8 / eq 7: "
          + ", ".join(f"{r['config']}-{r['gain']} {r['m8'] / r['m7']:.2f}" for r in base)
          + f"). The contact duration is pinned by the fitted force law ({lo_f:g}-{hi_f:g} N at {lo_v:g}-{hi_v:g} m/s) "
          "and the structure is unpublished; Table 4 is held out, so nothing is refitted on it.",
          f"5. **Configuration 1 Low.** The paper's experiment ({pl['1-low']['paper_exp']:.2f} kg) exceeds its "
          f"fixed-base m2 ({pl['1-low']['paper_fixed']:.2f} kg) and its own eq 8 column "
          f"({pl['1-low']['paper_eq8']:.2f} kg) exceeds eq 7 with its own Table 3 lambda "
          f"({pl['1-low']['eq7']:.2f} kg); eq 8 <= eq 7 for any lambda and base (a free base only adds mobility), "
          "so neither is eq 8 with one lambda. The rig's identified m* ("
          f"{base[0]['ident']:.2f} kg) lies between its eq 8 ({base[0]['m8']:.2f} kg) and its fixed-base Low m* "
          f"({base[0]['fixed']:.2f} kg), {_pct(base[0]['ident'] / base[0]['paper'] - 1)} from the paper (within the "
          f"{100 * TABLE4_TOLERANCE:.0f} %). A flexible base reads more than the fixed one only when the contact "
          "lasts long enough for the spring to push the base back toward the hammer before it ends (eq 10 then sees "
          "a slower tip): "
          + "; ".join([f"part A at T_c/T_1 = {r['ratio']:.2f} (configuration {r['config']}, ideal "
                       f"{_pct(r['ideal'] / r['fixed'] - 1)}, loop {_pct(r['loop'] / r['fixed'] - 1)})"
                       for r in a if max(r["ideal"], r["loop"]) > r["fixed"]]
                      + [f"part B at EI x{r['EI']:g} {r['mode']}, {r['config']}-{r['gain']} (T_c/T_1 = "
                         f"{r['ratio']:.2f}, phi {r['phi']:.2f})" for r in rows_b if r["phi"] > 1.0])
          + (f"; at the calibrated structure phi is at most {max(r['phi'] for r in base):.2f}. The paper's pattern, "
             "configuration 1 Low above its fixed-base value while the other cells lie far below theirs "
             "(experiment / fixed-base m2 or m3: "
             + ", ".join(f"{k} {v['paper_exp'] / v['paper_fixed']:.2f}" for k, v in pl.items())
             + "), is not what one contact-to-period ratio gives in the rig, where all cells move together "
             "(part B, phi per structure).")
          + "",
          "6. **Figure 9: the gains barely change the momentum the base gets.** "
          + "; ".join(f"configuration {k}: rig {100 * v['reduction']:.1f} %, eq 8 with the rig's lambda "
                      f"{100 * v['eq8_rig']:.1f} %, with the paper's lambda {100 * v['eq8_paper']:.1f} %, "
                      f"free vs locked joints {100 * v['eq8_bounds']:.1f} %" for k, v in c["configs"].items())
          + f" (target {100 * lo_t:.0f}-{100 * hi_t:.0f} %). The hammer (m_b = {b['fixed'][0]['m_b']:.2f} kg) is much "
          "lighter than m*, so the impulse differs by "
          + ", ".join(f"{100 * v['impulse_reduction']:.1f} %" for v in c["configs"].values())
          + " (eq 14); the base peaks at "
          + ", ".join(f"{v['t_peak'][1] * v['f1']:.2f} T_1" for v in c["configs"].values())
          + ", before the arm has passed it all the momentum, and the Low arm keeps more of it in its backdriven "
          "joints. The rig is within "
          + f"{100 * max(abs(v['reduction'] - v['eq8_rig']) for v in c['configs'].values()):.1f} points of eq 8's "
          "impulsive prediction with its own lambda; with the paper's own lambda eq 8 gives "
          + _rng([x["reduction"][k] for x in c["bases"] for k in (1, 2)], lambda x: f"{100 * x:.1f} %")
          + " over emulated bases of "
          + _rng([x["mass"] for x in c["bases"]], lambda x: f"{x:.0f}").replace(" to ", "-")
          + f" kg, short of {100 * paper['figure9_low_vs_high_reduction'][0]:.0f}-"
          f"{100 * paper['figure9_low_vs_high_reduction'][1]:.0f} %. The paper's reduction needs more than eq 8 and eq 14 give with its lambda and a light "
          "hammer, e.g. a hammer comparable to m* (eq 14's factor m*/(m* + m_b) then differs between the gains), "
          "different impact speeds in the compared trials, or another measure than the peak along x; none is "
          "published, and Figure 9 is held out, so nothing is refitted.", ""]

    L += ["### A. Passive arm (lambda = 0 exactly): m* against the contact duration", "",
          "Zero gains, no friction, no gravity, 1.5 m/s; contact stiffness scaled. Relative differences against eq 8 "
          "(impulsive free base), the fixed-base column against eq 7.", ""]
    L.append(_md(["config", "contact k x", "T_c [ms]", "T_c / T_1", "T_c x f (2nd pair)", "eq 8 [kg]", "eq 8 + K, B",
                  "ideal coupling, truth", "VES loop, truth", "VES loop, identified", "eq 7 [kg]", "fixed base, truth"],
                 [[r["config"], f"{r['scale']:g}", f"{1e3 * r['Tc']:.1f}", f"{r['ratio']:.3f}",
                   f"{r['Tc'] * r['freqs'][2]:.2f}", f"{r['m8']:.3f}", f"{r['m8K']:.3f} ({_pct(r['m8K'] / r['m8'] - 1)})",
                   f"{r['ideal']:.3f} ({_pct(r['ideal'] / r['m8'] - 1)})",
                   f"{r['loop']:.3f} ({_pct(r['loop'] / r['m8'] - 1)})",
                   f"{r['loop_ident']:.3f} ({_pct(r['loop_ident'] / r['m8'] - 1)})", f"{r['m7']:.3f}",
                   f"{r['fixed']:.3f} ({_pct(r['fixed'] / r['m7'] - 1)})"] for r in a]))
    L += ["", "### B. Calibrated rig, Table 4 cells: m* against the structure's stiffness", "",
          "lambda identified per gain class from the rig's own fixed-base trials (configurations 1-3, "
          f"{', '.join(f'{v:g}' for v in SPEEDS)} m/s), as Tables 3-4 do: "
          + "; ".join(f"{cls} {np.round(f.lambda_, 3).tolist()} kg m^2" for cls, f in b["fits"].items())
          + ". Beam EI scaled at the same contact and arm (lambda unchanged; every mode scales by sqrt(EI)); the "
          "campaign's structure is EI x1 under the VES loop. Means over the speeds. phi = (identified - eq 8) / "
          "(fixed - eq 8): 0 at eq 8, 1 at the rig's fixed-base m* of the cell (mean identified, same speeds).", ""]
    L.append(_md(["EI x", "VES", "cell", "f_1 [Hz]", "T_c / T_1", "eq 8 [kg]", "eq 8 + K, B [kg]", "identified [kg]",
                  "identified / eq 8 - 1", "identified / (eq 8 + K, B) - 1", "truth [kg]", "fixed base [kg]", "phi",
                  "paper experiment [kg]", "identified / paper - 1"],
                 [[f"{r['EI']:g}", r["mode"], f"{r['config']}-{r['gain']}", f"{r['f1']:.2f}", f"{r['ratio']:.3f}",
                   f"{r['m8']:.2f}", f"{r['m8K']:.2f}", f"{r['ident']:.2f}", _pct(r["ident"] / r["m8"] - 1),
                   _pct(r["ident"] / r["m8K"] - 1), f"{r['truth']:.2f}", f"{r['fixed']:.2f}", f"{r['phi']:.2f}",
                   f"{r['paper']:.2f}", _pct(r["ident"] / r["paper"] - 1)] for r in rows_b]))
    L += ["", "The lambda model's own error on the fixed base (identified / eq 7 with the identified lambda - 1, per "
          "speed " + ", ".join(f"{v:g}" for v in SPEEDS) + " m/s): "
          + "; ".join(f"{cg[0]}-{cg[1]} " + ", ".join(_pct(x) for x in errs) for cg, errs in b["lam_error"].items())
          + ". The residual of identified against eq 8 + K, B on the other structures ("
          f"{_rng([r['ident'] / r['m8K'] - 1 for r in rows_b])}; largest near T_c/T_1 ~ 0.6, where the base's "
          "rebound makes m* steep in the contact's shape) is mostly of that size: lambda is a speed- and "
          "duration-dependent summary of friction and servo torques identified on the fixed base, not an inertia, "
          "and it carries over to a moving base only approximately.", ""]

    L += ["### C. Figure 9: what sets the Low-vs-High reduction of the peak base displacement", "",
          f"Campaign structure, VES loop, {FIG9_SPEED:g} m/s (the campaign's Figure 9 trials). *passed*: the share of "
          "the contact impulse P the arm has pushed into the platform (F/T force along n, integrated) by the contact "
          "end and by the base's peak. *eq 8 impulsive*: reduction of the base velocity right after an impulsive "
          "contact, `(M + lambda)^-1 J^T n P` with P from eq 14 (`campaign.pipeline.calibration_report.impulsive_base_speed`), for the "
          "rig's identified lambda, the paper's Table 3 lambda, and free (lambda = 0) against locked joints.", ""]
    rows = []
    for cfg, v in c["configs"].items():
        rows.append([cfg, f"{1e3 * v['peak_low']:.4f} / {1e3 * v['peak_high']:.4f}", f"{100 * v['reduction']:.1f} %",
                     f"{100 * v['impulse_reduction']:.1f} %",
                     f"{v['passed_end'][0]:.2f} / {v['passed_end'][1]:.2f}",
                     f"{v['passed_peak'][0]:.2f} / {v['passed_peak'][1]:.2f}", f"{100 * v['passed_reduction']:.1f} %",
                     f"{1e3 * v['t_peak'][1]:.0f} ms = {v['t_peak'][1] * v['f1']:.2f} T_1 (T_c {1e3 * v['Tc']:.0f} ms)",
                     f"{100 * v['eq8_rig']:.1f} %", f"{100 * v['eq8_paper']:.1f} %", f"{100 * v['eq8_bounds']:.1f} %"])
    L.append(_md(["config", "peak base x, Low / High [mm]", "rig reduction", "impulse reduction (eq 14)",
                  "passed by contact end, Low / High", "passed by the peak, Low / High",
                  "reduction of the momentum passed by the peak", "base peak (High) after contact start",
                  "eq 8 impulsive, rig lambda", "eq 8 impulsive, paper lambda", "eq 8 impulsive, free vs locked joints"],
                 rows))
    L += ["", "Eq 8's impulsive reduction with the paper's Table 3 lambda on other emulated bases (platform and beam "
          "mass scaled; both are assumptions of the rig):", ""]
    L.append(_md(["platform [kg]", "beam [kg]", "base mass M [kg]", "configuration 1", "configuration 2"],
                 [[f"{x['platform']:g}", f"{x['beam']:g}", f"{x['mass']:.1f}", f"{100 * x['reduction'][1]:.1f} %",
                   f"{100 * x['reduction'][2]:.1f} %"] for x in c["bases"]]))
    L += ["", "Rig reduction of the peak over the structures of part B: "
          + "; ".join(f"EI x{ei:g} {mode}: " + ", ".join(f"configuration {k} {100 * x:.1f} %" for k, x in sorted(d.items()))
                      for (ei, mode), d in c["variants"].items()) + ".",
          "", "High-gain servo natural frequencies sqrt(Kp / H_jj), joints 1-3: "
          + "; ".join(f"configuration {k}: " + ", ".join(f"{x:.1f}" for x in v) + " Hz" for k, v in servo.items())
          + f", below f_1 = {c['configs'][1]['f1']:.2f} Hz: until the base peaks the gains act through their share "
          "of lambda (damping and friction during the contact), not through servo stiffness.", ""]
    L += [f"Machine: {platform.machine()}; Python {platform.python_version()}; {datetime.date.today().isoformat()}; "
          f"{seconds:.0f} s on one core. Rerun: see the script's docstring."]
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--readme", default=None, help="write the section into this markdown file")
    parser.add_argument("--quick", action="store_true", help="fewer contact and beam variants")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()

    def log(line):
        print(f"[{time.perf_counter() - t0:6.1f} s] {line}", flush=True)

    a = part_a(log, quick=args.quick)
    b = part_b(log, quick=args.quick)
    c = part_c(b)
    text = format_report(a, b, c, servo_frequencies(), time.perf_counter() - t0)
    print(text)
    if args.readme:
        from campaign.bench import write_section
        write_section(args.readme, HEADING, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
