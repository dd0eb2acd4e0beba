"""The flexible base as a space long-reach structure: Table 4, Figure 9 and where eq 8 holds.

The rig names two structures (``config/rig.yaml`` ``structures:``): ``stiff_mast`` (20 m,
first mode ~4.4 Hz with the arm on top) and ``space_class`` (68.5 m under the same EI, 0.70 Hz,
inside the Shuttle RMS's published unloaded 0.35-0.71 Hz). This benchmark runs both:

A. Table 4 under both structures. lambda is identified per gain class from the rig's own
   fixed-base trials (configurations 1-3, 1.5 and 2.5 m/s), as Tables 3-4 do; each Table 4
   cell is simulated at the same speeds and identified from its measured channels
   (``campaign.identify``); eq 8 (``campaign.report.tables.flexible_prediction``, the trial's
   emulated base) uses that lambda. Beside: the paper's experiment and eq 8 columns.
B. Figure 9's Low-vs-High reduction of the peak base displacement (2.5 m/s), per structure,
   with eq 8's own prediction of it (base velocity right after an impulsive contact,
   ``campaign.pipeline.calibration_report.impulsive_base_speed``, identified lambda); then, on the space-class
   structure, what in the paper's set-up could give 20-30 %: a heavier hammer, other impact
   speeds, and other ways of reading the peak.
C. Validity map of eq 8: identified m* / eq 8 against the contact duration over the
   first-mode period, over beam stiffnesses (EI scaled on both structures), for the four
   Table 4 cells (calibrated rig) and a passive arm (Zero gains, no friction, no gravity:
   lambda = 0 exactly, so eq 8 needs no identified lambda). Writes the CSV and the figure.
D. CPU per flexible trial, stiff mast against space class (and the space class with its frozen-arm ticks
   per tick instead of in closed form), interleaved in the same run; the closed form's share of the record.
E. The base the paper's eq 8 column implies: the emulated base's inertial parameters fitted
   to that column (the paper's model output, not its held-out experiment column), with
   residuals; configuration 1 Low left out (its eq 8 value exceeds its own eq 7).

Prints the tables; ``--readme benchmarks/README.md`` writes them as a section of that file,
``--csv`` and ``--png`` the validity map's data and figure.
Rerun: ``.venv/bin/python benchmarks/space_structure.py --readme benchmarks/README.md
--csv benchmarks/eq8_validity.csv --png benchmarks/eq8_validity.png --structures-csv
benchmarks/table4_structures.csv`` (a few minutes on one core).
"""

from __future__ import annotations

import argparse
import csv
import datetime
import os
import platform
import sys
import tempfile
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import flexible_validation as fv  # noqa: E402  (the one-trial runner and the eq 7/8 helpers)

HEADING = "## Space-class structure: Table 4, Figure 9 and the validity of eq 8"
STRUCTURES = ("stiff_mast", "space_class")
#: the space class with its frozen-arm ticks per tick (flexible.linear_phases off)
PER_TICK = "space_class_per_tick"
CELLS = fv.CELLS
SPEEDS = fv.SPEEDS
FIG9_SPEED = fv.FIG9_SPEED
#: beam EI multipliers of the validity map, per structure: the space-class structure from
#: T_c/T_1 ~ 0.005 up to where its VES loop stays stable, the stiff mast for the upper end
MAP_EI = {"space_class": (1 / 64, 1 / 16, 1 / 4, 1.0, 4.0, 16.0), "stiff_mast": (1 / 16, 1.0, 4.0)}
#: a validity-map trial needs the contact and the identification windows, not the periods
SHORT = {"flexible.trial_periods": 0.01}
#: eq 8 holds where identified m* / eq 8 is within this
TOLERANCE = 0.05
#: Figure 9 variations on the space-class structure: hammer head mass multipliers (the
#: hammer must stay lighter than the arm's free m*), speeds, and peak readings
HEAD_SCALES = (1.0, 3.0, 6.0)
FIG9_SPEEDS = (1.0, 2.5)


def structure(name: str, **more) -> dict:
    return dict({"flexible.structure": name}, **more)


# ----------------------------------------------------------------------------------------
# lambda from the rig's fixed base
# ----------------------------------------------------------------------------------------
def identified_lambda(log) -> dict:
    from campaign.joints.lambda_fit import IdentifiabilityWarning
    from campaign.model.paper import load_paper
    from campaign.model.robot import load_robot
    from campaign.report.tables import fit_gain_classes

    paper = load_paper()
    fixed = [fv.run_trial(base="fixed", config=c, gain=g, speed=v)
             for c in (1, 2, 3) for g in ("zero", "low", "high") for v in SPEEDS]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        fits = fit_gain_classes([f["record"] for f in fixed if not f["excluded"]], robot=load_robot(),
                                n_bootstrap=20, random_state=0, warn=False)
    lam = {g: fits[cls].lambda_matrix_ for cls, members in paper["gain_classes"].items() for g in members}
    log("lambda " + "; ".join(f"{cls} {np.round(f.lambda_, 3).tolist()}" for cls, f in fits.items()))
    # the lambda model's own error on the fixed base: identified / eq 7 - 1, per speed
    robot = load_robot()
    error = {(c, g): [f["m_ident"] / fv.eq7(robot, f["record"], lam[g]) - 1.0
                      for f in fixed if f["config"] == c and f["gain"] == g] for c, g in CELLS}
    return {"lam": lam, "fits": fits, "error": error}


def _run(structure_name: str, config: int, gain: str, speed: float, **params) -> dict:
    return fv.run_trial(base="flexible", config=config, gain=gain, speed=speed,
                        params=structure(structure_name, **params))


# ----------------------------------------------------------------------------------------
# A, B: Table 4 and Figure 9 under both structures
# ----------------------------------------------------------------------------------------
def table4(lam: dict, log) -> dict:
    from campaign.model.paper import load_paper
    from campaign.model.robot import load_robot

    robot = load_robot()
    paper = load_paper()
    rows, trials = [], {}
    for s in STRUCTURES:
        for c, g in CELLS:
            tt = [_run(s, c, g, v) for v in SPEEDS]
            trials[(s, c, g)] = tt
            m8 = float(np.mean([fv.eq8(robot, t["record"], lam[g]) for t in tt]))
            m7 = float(np.mean([fv.eq7(robot, t["record"], lam[g]) for t in tt]))
            ident = float(np.mean([t["m_ident"] for t in tt]))
            truth = float(np.mean([t["m_truth"] for t in tt]))
            Tc = float(np.mean([t["Tc"] for t in tt]))
            p4 = paper["table4"][f"{c}-{g}"]
            row = {"structure": s, "config": c, "gain": g, "f1": tt[0]["f1"], "freqs": tt[0]["freqs"], "Tc": Tc,
                   "ratio": Tc * tt[0]["f1"], "m8": m8, "m7": m7, "ident": ident, "truth": truth,
                   "paper": p4["experiment"], "paper_eq8": p4["predicted"]}
            rows.append(row)
            log(f"A {s} {c}-{g}: f1 {row['f1']:.3f} Hz, Tc/T1 {row['ratio']:.3f}, eq 8 {m8:.2f}, identified "
                f"{ident:.2f} (truth {truth:.2f}), paper {row['paper']:.2f}")
    return {"rows": rows, "trials": trials}


def _peak_readings(trial: dict) -> dict:
    """Ways of reading Figure 9's peak from the measured base position (x along the
    impact, y across it): the largest |x| over the record (the campaign's Figure 9), the
    first extremum of x after the contact (within half a first-mode period), the largest
    horizontal excursion sqrt(x^2 + y^2), and the peak-to-peak x."""
    tb, xb, yb, t0, f1 = trial["t_base"], trial["x_base"], trial["y_base"], trial["t0"], trial["f1"]
    after = tb >= t0
    first = after & (tb <= t0 + 0.5 / f1)
    return {"max abs x": float(np.max(np.abs(xb[after]))),
            "first peak of x": float(np.max(np.abs(xb[first]))),
            "max horizontal sqrt(x^2 + y^2)": float(np.max(np.hypot(xb[after], yb[after]))),
            "peak-to-peak x": float(np.ptp(xb[after]))}


def figure9(lam: dict, a: dict, log) -> dict:
    from campaign.model.robot import load_robot

    robot = load_robot()
    iv = SPEEDS.index(FIG9_SPEED)
    out = {"structures": {}, "variants": []}

    def red(lo, hi):
        return 1.0 - lo / hi

    for s in STRUCTURES:
        for c in (1, 2):
            tr = {g: a["trials"][(s, c, g)][iv] for g in ("low", "high")}
            m_b = tr["high"]["m_b"]
            v = {g: fv.impulsive_base_velocity(robot, tr[g]["record"], lam[g], m_b) for g in ("low", "high")}
            out["structures"][(s, c)] = {
                "peak_low": tr["low"]["peak_base_x"], "peak_high": tr["high"]["peak_base_x"],
                "reduction": red(tr["low"]["peak_base_x"], tr["high"]["peak_base_x"]),
                "eq8": red(v["low"], v["high"]), "t_peak": tr["high"]["t_peak"], "f1": tr["high"]["f1"]}
            log(f"B {s} config {c}: reduction {100 * out['structures'][(s, c)]['reduction']:.1f} %, eq 8 "
                f"{100 * out['structures'][(s, c)]['eq8']:.1f} %")
    # what in the set-up could give 20-30 %: hammer mass, speed, peak reading (space class)
    from campaign.scene.description import load_rig
    head0 = float(load_rig()[0]["pendulum.head_mass"])
    for head in HEAD_SCALES:
        for speed in FIG9_SPEEDS:
            for c in (1, 2):
                tr = {g: _run("space_class", c, g, speed, **{"pendulum.head_mass": head0 * head})
                      for g in ("low", "high")}
                m_b = tr["high"]["m_b"]
                v = {g: fv.impulsive_base_velocity(robot, tr[g]["record"], lam[g], m_b) for g in ("low", "high")}
                pk = {g: _peak_readings(tr[g]) for g in ("low", "high")}
                row = {"head": head, "m_b": m_b, "speed": speed, "config": c, "Tc": tr["high"]["Tc"],
                       "eq8": red(v["low"], v["high"]),
                       "impulse": red(tr["low"]["impulse"], tr["high"]["impulse"]),
                       "m_truth": (tr["low"]["m_truth"], tr["high"]["m_truth"]),
                       "readings": {k: red(pk["low"][k], pk["high"][k]) for k in pk["high"]}}
                out["variants"].append(row)
                log(f"B space_class head x{head:g} (m_b {m_b:.2f} kg) {speed} m/s config {c}: "
                    + ", ".join(f"{k} {100 * x:.1f} %" for k, x in row["readings"].items())
                    + f"; eq 8 {100 * row['eq8']:.1f} %")
    return out


# ----------------------------------------------------------------------------------------
# E: the base the paper's eq 8 column implies
# ----------------------------------------------------------------------------------------
#: the paper's configuration 1 Low eq 8 value (13.90 kg) exceeds its eq 7 with the same lambda
#: (12.93 kg), which no base can give (a free base only adds mobility): left out of the fit
FIT_CELLS = ((1, "high"), (2, "low"), (2, "high"))


def base_fit() -> dict:
    """Fit the emulated base's inertial parameters to the paper's eq 8 column of Table 4
    (its model's output with its Table 3 lambda; not the held-out experiment column), in
    log ratio over FIT_CELLS: (a) mass and bending inertia with the space-class base's centre
    of mass, torsional inertia and mount; (b) mass, bending and torsional inertia and the
    centre-of-mass height free. Returns the fits, their residuals per cell (configuration 1
    Low included, unweighted) and the space-class base's own residuals."""
    from scipy.optimize import least_squares

    from campaign.model.exiit import effective_mass_from_G, exiit_floating
    from campaign.model.paper import configuration_q, impact_direction, load_paper
    from campaign.model.robot import load_robot
    from campaign.model.robot.floating import BaseBody, attach_to_floating_base
    from campaign.rig.beam import Beam
    from campaign.scene.description import make_scene

    paper = load_paper()
    robot = load_robot()
    t3 = paper["table3"]
    lam = {g: t3[cls] for cls, members in paper["gain_classes"].items() for g in members}
    body = Beam.from_scene(make_scene(base="flexible", params=structure("space_class"))).base_body()
    target = {(c, g): float(paper["table4"][f"{c}-{g}"]["predicted"]) for c, g in CELLS}

    def eq8(mass, ixy, iz, h, c, g):
        b = BaseBody(mass=mass, inertia=np.diag([ixy, ixy, iz]), com=np.array([0.0, 0.0, h]), mount=body.mount)
        return effective_mass_from_G(exiit_floating(attach_to_floating_base(robot, b), configuration_q(c), lam[g]),
                                     impact_direction())

    own = (float(body.mass), float(body.inertia[0, 0]), float(body.inertia[2, 2]), float(body.com[2]))

    def unpack_a(p):
        return float(np.exp(p[0])), float(np.exp(p[1])), own[2], own[3]

    def unpack_b(p):
        return float(np.exp(p[0])), float(np.exp(p[1])), float(np.exp(p[2])), float(p[3])

    def residuals(params):
        return {(c, g): eq8(*params, c, g) / target[(c, g)] - 1.0 for c, g in CELLS}

    out = {"space_class": {"params": own, "res": residuals(own)}}
    fa = least_squares(lambda p: [np.log(eq8(*unpack_a(p), c, g) / target[(c, g)]) for c, g in FIT_CELLS],
                       np.log(own[:2]), bounds=(np.log([1.0, 1.0]), np.log([1e5, 1e10])))
    out["mass, bending inertia"] = {"params": unpack_a(fa.x), "res": residuals(unpack_a(fa.x))}
    best = None
    for h0 in (own[3], -1.0, 0.0, 0.5):
        fb = least_squares(lambda p: [np.log(eq8(*unpack_b(p), c, g) / target[(c, g)]) for c, g in FIT_CELLS],
                           np.r_[np.log([own[0], 100.0, 20.0]), h0],
                           bounds=(np.r_[np.log([1.0, 1.0, 1.0]), -20.0], np.r_[np.log([1e5, 1e5, 1e5]), 5.0]))
        best = fb if best is None or fb.cost < best.cost else best
    out["mass, bending and torsional inertia, centre of mass"] = {"params": unpack_b(best.x),
                                                                  "res": residuals(unpack_b(best.x))}
    return out


# ----------------------------------------------------------------------------------------
# C: validity map
# ----------------------------------------------------------------------------------------
def validity_map(lam: dict, log) -> list[dict]:
    from campaign.core.errors import InputError
    from campaign.model.robot import load_robot
    from campaign.scene.description import load_rig

    robot = load_robot()
    ei0 = float(load_rig()[0]["flexible.beam_EI"])
    rows = []
    for s, scales in MAP_EI.items():
        for ei in scales:
            p = dict(SHORT, **{"flexible.beam_EI": ei0 * ei})
            runs = [(f"{c}-{g}", c, g, v, {}) for c, g in CELLS for v in SPEEDS]
            runs += [(f"passive {c}", c, "zero", 1.5, fv.PASSIVE) for c in (1, 2)]
            for label, c, g, v, extra in runs:
                try:
                    t = _run(s, c, g, v, **p, **extra)
                except InputError as err:
                    log(f"C {s} EI x{ei:g} {label}: refused ({str(err)[:90]}...)")
                    continue
                lam_g = None if label.startswith("passive") else lam[g]
                m8 = fv.eq8(robot, t["record"], lam_g)
                row = {"structure": s, "EI_scale": ei, "cell": label, "speed": v, "f1": t["f1"],
                       "f2": float(t["freqs"][2]), "Tc": t["Tc"], "ratio": t["Tc"] * t["f1"], "eq8": m8,
                       "identified": t["m_ident"], "truth": t["m_truth"]}
                rows.append(row)
            got = [r for r in rows if r["structure"] == s and r["EI_scale"] == ei]
            if got:
                log(f"C {s} EI x{ei:g}: Tc/T1 {np.mean([r['ratio'] for r in got]):.4f}, identified / eq 8 - 1 "
                    + ", ".join(f"{r['cell']}@{r['speed']:g} {100 * (r['identified'] / r['eq8'] - 1):+.1f}%"
                                for r in got))
    return rows


def holds_below(rows, key: str = "identified") -> float:
    """Largest T_c/T_1 below which every point's ``key`` / eq 8 is within TOLERANCE."""
    from campaign.report.figures.validity import holds_below as _holds

    return _holds(rows, key=key, tolerance=TOLERANCE)


def write_csv(rows, path) -> None:
    cols = ["structure", "EI_scale", "cell", "speed", "f1", "f2", "Tc", "ratio", "eq8", "identified", "truth"]
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), suffix=".csv")
    with os.fdopen(fd, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["structure", "EI_scale", "cell", "speed_m_s", "f1_Hz", "f2_Hz", "Tc_s", "Tc_over_T1",
                    "eq8_kg", "identified_kg", "truth_kg"])
        for r in rows:
            w.writerow([r[c] if isinstance(r[c], str) else f"{r[c]:.6g}" for c in cols])
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def write_structures_csv(a: dict, b: dict, path) -> None:
    """Table 4 and Figure 9's reduction under both structures (the report's table of them)."""
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), suffix=".csv")
    with os.fdopen(fd, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["structure", "cell", "f1_Hz", "Tc_over_T1", "eq8_kg", "identified_kg", "truth_kg",
                    "paper_experiment_kg", "paper_eq8_kg", "fig9_reduction", "fig9_eq8_reduction"])
        for r in a["rows"]:
            f9 = b["structures"][(r["structure"], r["config"])]
            w.writerow([r["structure"], f"{r['config']}-{r['gain']}"]
                       + [f"{x:.6g}" for x in (r["f1"], r["ratio"], r["m8"], r["ident"], r["truth"], r["paper"],
                                               r["paper_eq8"], f9["reduction"], f9["eq8"])])
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def draw_map(rows, png) -> None:
    from campaign.report.figures import style
    from campaign.report.figures.validity import draw_validity

    style.save(draw_validity(rows, tolerance=TOLERANCE), png)


# ----------------------------------------------------------------------------------------
# D: CPU per trial
# ----------------------------------------------------------------------------------------
def trial_cost(log, repeats: int = 3) -> dict:
    from campaign.rig import simulate_arrays
    from campaign.scene.description import make_scene

    out = {}
    for c, g in CELLS:
        # the space class with the frozen arm's ticks per tick (PER_TICK) and in closed form
        # (its default): the closed form's saving in the same run
        scenes = {s: make_scene(base="flexible", config=c, gain=g, speed=FIG9_SPEED, params=structure(s))
                  for s in STRUCTURES}
        scenes[PER_TICK] = make_scene(base="flexible", config=c, gain=g, speed=FIG9_SPEED,
                                      params=structure("space_class", **{"flexible.linear_phases": False}))
        times = {s: [] for s in scenes}
        for s in scenes:
            simulate_arrays(scenes[s])        # warm
        for _ in range(repeats):             # interleaved: all see the same machine load
            for s in scenes:
                t0 = time.process_time()
                simulate_arrays(scenes[s])
                times[s].append(time.process_time() - t0)
        out[(c, g)] = {s: float(np.median(v)) for s, v in times.items()}
        out[(c, g)]["linear_fraction"] = linear_fraction(scenes["space_class"])
        log(f"D {c}-{g}: " + ", ".join(f"{s} {1e3 * v:.0f} ms" for s, v in out[(c, g)].items()
                                      if s != "linear_fraction")
            + f"; closed-form share of the record {100 * out[(c, g)]['linear_fraction']:.0f} %")
    return out


def linear_fraction(scene) -> float:
    """Share of a trial's recording after the touch that the frozen arm's closed form covers
    (``campaign.rig.linear_phase``): its emulator ticks over all of them."""
    from campaign.rig import linear_phase
    from campaign.rig.integrate import integrate_trial
    from campaign.rig.simulate import build, integration_args

    rig = build(scene)
    done = []
    run = linear_phase.run_frozen

    def counted(*args):
        m, taus = run(*args)
        done.append(m)
        return m, taus

    import campaign.rig.integrate as integrate
    integrate.run_frozen = counted
    try:
        integrate_trial(rig.plant, rig.pid, **integration_args(rig))
    finally:
        integrate.run_frozen = run
    return sum(done) / max(1, len(rig.plant.history))


# ----------------------------------------------------------------------------------------
# report
# ----------------------------------------------------------------------------------------
def _pct(x: float) -> str:
    return f"{100 * x:+.1f} %"


def format_report(lam, a, b, vmap, cost, fit, seconds) -> str:
    from campaign.bench.common import _md
    from campaign.model.paper import load_paper

    paper = load_paper()
    lo_p, hi_p = (float(x) for x in paper["figure9_low_vs_high_reduction"])
    rows = a["rows"]
    sp = [r for r in rows if r["structure"] == "space_class"]
    st = [r for r in rows if r["structure"] == "stiff_mast"]
    ok15 = [abs(r["ident"] / r["paper"] - 1) <= 0.15 for r in sp]
    ok5 = [abs(r["ident"] / r["m8"] - 1) <= TOLERANCE for r in sp]
    byc = {(r["config"], r["gain"]): r["ident"] for r in sp}
    order = byc[2, "low"] > byc[1, "low"] and byc[2, "high"] > byc[1, "high"] and \
        byc[1, "high"] > byc[1, "low"] and byc[2, "high"] > byc[2, "low"]
    passive = [r for r in vmap if r["cell"].startswith("passive")]
    calib = [r for r in vmap if not r["cell"].startswith("passive")]
    r_pass_t, r_pass_i, r_cal = holds_below(passive, "truth"), holds_below(passive), holds_below(calib)
    tot = {s: sum(v[s] for v in cost.values()) for s in STRUCTURES + (PER_TICK,)}
    fq = {s: [r for r in rows if r["structure"] == s][0]["freqs"] for s in STRUCTURES}

    L = ["Script: `benchmarks/space_structure.py` (its docstring describes the parts). The two named structures of "
         "`config/rig.yaml`: `stiff_mast` (20 m, 200 kg) and `space_class` (68.5 m, 200 kg, same EI = 2.5e8 N m^2; "
         "first mode inside the Shuttle RMS's published 0.35-0.71 Hz). Modes with the arm on top: stiff mast "
         + ", ".join(f"{x:.2f}" for x in fq["stiff_mast"]) + " Hz; space class "
         + ", ".join(f"{x:.2f}" for x in fq["space_class"]) + " Hz (bending pair, second bending pair or torsion, "
         "axial). lambda identified per gain class from the rig's own fixed-base trials (configurations 1-3, "
         f"{', '.join(f'{v:g}' for v in SPEEDS)} m/s): "
         + "; ".join(f"{cls} {np.round(f.lambda_, 3).tolist()} kg m^2" for cls, f in lam["fits"].items()) + ".", ""]
    L += ["### Findings", ""]
    L += ["1. **Table 4, space class against the paper's experiment:** "
          + ", ".join(f"{r['config']}-{r['gain']} {_pct(r['ident'] / r['paper'] - 1)}" for r in sp)
          + f" ({sum(ok15)} of 4 within 15 %; ordering configuration 2 above 1 and High above Low "
          + ("kept" if order else "not kept") + "). Stiff mast: "
          + ", ".join(f"{r['config']}-{r['gain']} {_pct(r['ident'] / r['paper'] - 1)}" for r in st) + ".",
          "2. **Eq 8 against the identified m*:** space class "
          + ", ".join(f"{r['config']}-{r['gain']} {_pct(r['ident'] / r['m8'] - 1)}" for r in sp)
          + f" ({sum(ok5)} of 4 within 5 %) at T_c/T_1 = {min(r['ratio'] for r in sp):.3f}-"
          f"{max(r['ratio'] for r in sp):.3f}; stiff mast "
          + ", ".join(f"{r['config']}-{r['gain']} {_pct(r['ident'] / r['m8'] - 1)}" for r in st)
          + f" at T_c/T_1 = {min(r['ratio'] for r in st):.2f}-{max(r['ratio'] for r in st):.2f}. The space-class "
          "structure moves the first mode out of the contact, but the contact still spans "
          f"{np.mean([r['Tc'] for r in sp]) * fq['space_class'][2]:.2f} periods of its second bending pair "
          f"({fq['space_class'][2]:.1f} Hz) and {np.mean([r['Tc'] for r in sp]) * fq['space_class'][4]:.1f} of "
          f"torsion ({fq['space_class'][4]:.1f} Hz), which hold the base's rotation during it (passive arm: "
          f"+{100 * _passive_at(vmap, 'space_class', 1.0)[0]:.1f} % and +{100 * _passive_at(vmap, 'space_class', 1.0)[1]:.1f} % "
          "above eq 8 for configurations 1 and 2 at this structure, C); the larger part is lambda: identified on "
          "the fixed base it is a speed- and duration-dependent summary of friction and servo torques, and on the "
          "fixed base itself the identified m* departs from eq 7 with that lambda by "
          + ", ".join(f"{c}-{g} {_pct(e[0])} / {_pct(e[1])}" for (c, g), e in lam["error"].items())
          + " (1.5 / 2.5 m/s); the same cells' 2.5 m/s departures from eq 8 persist at the smallest T_c/T_1 "
          "of the map (C).",
          f"3. **Where eq 8 holds (validity map, C):** with the passive arm (lambda = 0 exactly) the simulator truth "
          f"is within {100 * TOLERANCE:.0f} % of eq 8 for T_c/T_1 <= {r_pass_t:.3f} and the identified m* for "
          f"T_c/T_1 <= {r_pass_i:.3f}: **eq 8's flexible-base form holds within {100 * TOLERANCE:.0f} % below "
          f"T_c/T_1 ~ {r_pass_i:.2g}** (with the rig's ~10:1 ratio of the second bending pair to the first). With "
          "the calibrated arm and its identified lambda (the four Table 4 cells) "
          + (f"every point is within it only for T_c/T_1 <= {r_cal:.3f}" if r_cal > 0 else "no ratio of the map has "
             "every point within it") + f"; at the smallest ratio ({min(r['ratio'] for r in calib):.4f}) the cells "
          "are " + ", ".join(f"{r['cell']}@{r['speed']:g} {_pct(r['identified'] / r['eq8'] - 1)}"
                             for r in sorted(calib, key=lambda r: r['ratio'])[:8])
          + ": the lambda model's own error, not the structure. Figure: `benchmarks/eq8_validity.png`, data "
          "`benchmarks/eq8_validity.csv`.",
          "4. **Figure 9's Low-vs-High reduction** (2.5 m/s, largest |x| over the record, as the campaign's Figure 9 reads it): "
          + "; ".join(f"{s} configuration {c}: rig {100 * v['reduction']:.1f} %, eq 8 {100 * v['eq8']:.1f} %"
                      for (s, c), v in b["structures"].items())
          + f" (paper {100 * lo_p:.0f}-{100 * hi_p:.0f} %). Varied on the space class (table below): "
          + _fig9_summary(b) + ".",
          f"5. **CPU per flexible trial** (simulation only, median of interleaved repeats, 2.5 m/s): stiff mast "
          f"{1e3 * tot['stiff_mast'] / len(cost):.0f} ms, space class {1e3 * tot['space_class'] / len(cost):.0f} ms "
          f"per trial on average, ratio {tot['space_class'] / tot['stiff_mast']:.2f} (per cell "
          + ", ".join(f"{c}-{g} {v['space_class'] / v['stiff_mast']:.2f}" for (c, g), v in cost.items())
          + f"); with the frozen arm's ticks integrated per tick instead of in closed form, space class "
          f"{1e3 * tot[PER_TICK] / len(cost):.0f} ms, ratio {tot[PER_TICK] / tot['stiff_mast']:.2f} (per cell "
          + ", ".join(f"{c}-{g} {v[PER_TICK] / v['stiff_mast']:.2f}" for (c, g), v in cost.items())
          + "). The closed form (`campaign.rig.linear_phase`, scene option `flexible.linear_phases`, on for the "
          "space class) covers " + ", ".join(f"{c}-{g} {100 * v['linear_fraction']:.0f} %" for (c, g), v in cost.items())
          + f" of the record. Records after the touch: {_records()}. In configuration 1 Low the arm never freezes: "
          "joint 3 keeps creeping back under the Low servo through the whole record (about 0.02 rad, some 180 "
          "encoder counts, in 2 s), and the servo's torque steps at every count it reads (several hundred steps), a "
          "staircase of the state rather than a linear law, so no phase of that trial is linear and the whole "
          "record is integrated.", ""]

    L += ["### A. Table 4 under both structures", "",
          f"Means over {', '.join(f'{v:g}' for v in SPEEDS)} m/s. eq 8 with the identified lambda on the trial's "
          "emulated base; *paper*: the experiment column, *paper eq 8*: its eq 8 column.", ""]
    L.append(_md(["structure", "cell", "f_1 [Hz]", "T_c / T_1", "eq 8 [kg]", "identified [kg]", "truth [kg]",
                  "identified / eq 8 - 1", "paper [kg]", "identified / paper - 1", "paper eq 8 [kg]",
                  "eq 8 / paper eq 8 - 1"],
                 [[r["structure"], f"{r['config']}-{r['gain']}", f"{r['f1']:.3f}", f"{r['ratio']:.3f}",
                   f"{r['m8']:.2f}", f"{r['ident']:.2f}", f"{r['truth']:.2f}", _pct(r["ident"] / r["m8"] - 1),
                   f"{r['paper']:.2f}", _pct(r["ident"] / r["paper"] - 1), f"{r['paper_eq8']:.2f}",
                   _pct(r["m8"] / r["paper_eq8"] - 1)] for r in rows]))
    L += ["", "### B. Figure 9: Low-vs-High reduction of the peak base displacement", "",
          "Per structure at 2.5 m/s (the campaign's Figure 9 trials); *eq 8*: reduction of the base velocity right "
          "after an impulsive contact with the identified lambda.", ""]
    L.append(_md(["structure", "configuration", "f_1 [Hz]", "peak Low / High [mm]", "rig reduction",
                  "eq 8 reduction", "High peak after contact start"],
                 [[s, c, f"{v['f1']:.3f}", f"{1e3 * v['peak_low']:.3f} / {1e3 * v['peak_high']:.3f}",
                   f"{100 * v['reduction']:.1f} %", f"{100 * v['eq8']:.1f} %",
                   f"{1e3 * v['t_peak']:.0f} ms = {v['t_peak'] * v['f1']:.2f} T_1"]
                  for (s, c), v in b["structures"].items()]))
    keys = list(b["variants"][0]["readings"])
    L += ["", "Space class: hammer head mass (x the calibrated head), impact speed and the peak reading varied; "
          "each Low trial against the High trial of the same set-up.", ""]
    L.append(_md(["head x", "m_b [kg]", "speed [m/s]", "config", "T_c [ms]", "m* truth Low / High [kg]",
                  "impulse reduction (eq 14)"] + keys + ["eq 8 reduction"],
                 [[f"{v['head']:g}", f"{v['m_b']:.2f}", f"{v['speed']:g}", v["config"], f"{1e3 * v['Tc']:.0f}",
                   f"{v['m_truth'][0]:.1f} / {v['m_truth'][1]:.1f}", f"{100 * v['impulse']:.1f} %"]
                  + [f"{100 * v['readings'][k]:.1f} %" for k in keys] + [f"{100 * v['eq8']:.1f} %"]
                  for v in b["variants"]]))
    L += ["", "### C. Validity map of eq 8", "",
          "identified m* / eq 8 - 1 against T_c / T_1 (first mode with the arm on top); beam EI scaled on both "
          "structures (the first mode scales with sqrt(EI)); each Table 4 cell at "
          f"{', '.join(f'{v:g}' for v in SPEEDS)} m/s and the passive arm (configurations 1, 2 at 1.5 m/s, "
          "lambda = 0). Records cut to the identification windows. f_2: the second bending pair.", ""]
    groups = {}
    for r in vmap:
        groups.setdefault((r["structure"], r["EI_scale"]), []).append(r)
    cells = sorted({r["cell"] for r in vmap})
    L.append(_md(["structure", "EI x", "f_1 [Hz]", "f_2 [Hz]", "T_c / T_1"] + cells,
                 [[s, f"{ei:g}", f"{g[0]['f1']:.3f}", f"{g[0]['f2']:.2f}",
                   f"{min(r['ratio'] for r in g):.4f}-{max(r['ratio'] for r in g):.4f}"]
                  + [" / ".join(_pct(r["identified"] / r["eq8"] - 1) for r in g if r["cell"] == cell) or "-"
                     for cell in cells] for (s, ei), g in sorted(groups.items(), key=lambda kv: kv[1][0]["ratio"])]))
    L += ["", "### D. CPU per flexible trial", "",
          "`campaign.rig.simulate_arrays` only (no archive write), 2.5 m/s, median of 3 interleaved repeats. "
          "`per tick`: the space class with `flexible.linear_phases=false` (every emulator tick of the frozen arm "
          "through Pinocchio), the path before the closed form; `closed form`: its share of the record's emulator "
          "ticks.", ""]
    L.append(_md(["cell", "stiff mast [ms]", "space class [ms]", "ratio", "space class, per tick [ms]",
                  "ratio, per tick", "closed form"],
                 [[f"{c}-{g}", f"{1e3 * v['stiff_mast']:.0f}", f"{1e3 * v['space_class']:.0f}",
                   f"{v['space_class'] / v['stiff_mast']:.2f}", f"{1e3 * v[PER_TICK]:.0f}",
                   f"{v[PER_TICK] / v['stiff_mast']:.2f}", f"{100 * v['linear_fraction']:.0f} %"]
                  for (c, g), v in cost.items()]
                 + [["all four", f"{1e3 * tot['stiff_mast']:.0f}", f"{1e3 * tot['space_class']:.0f}",
                     f"{tot['space_class'] / tot['stiff_mast']:.2f}", f"{1e3 * tot[PER_TICK]:.0f}",
                     f"{tot[PER_TICK] / tot['stiff_mast']:.2f}", ""]]))
    L += ["", "### E. The base the paper's eq 8 column implies", "",
          "The paper's eq 8 column of Table 4 is its model's output with its Table 3 lambda; fitting the emulated "
          "base's inertial parameters to it (log ratio, cells " + ", ".join(f"{c}-{g}" for c, g in FIT_CELLS)
          + "; configuration 1 Low left out: its 13.90 kg exceeds the paper's own eq 7 with the same lambda, "
          "12.93 kg, which no base can give) shows which base its model had. Residuals: eq 8 on the fitted base / "
          "the paper's eq 8 - 1 (configuration 1 Low shown, not fitted). Parameters: mass [kg], bending and "
          "torsional inertia about the centre of mass [kg m^2], centre-of-mass height above the beam tip [m].", ""]
    L.append(_md(["base", "mass", "I_xx = I_yy", "I_zz", "com height"] + [f"{c}-{g}" for c, g in CELLS],
                 [[name, f"{v['params'][0]:.4g}", f"{v['params'][1]:.4g}", f"{v['params'][2]:.4g}",
                   f"{v['params'][3]:.3g}"] + [_pct(v["res"][cg]) for cg in CELLS] for name, v in fit.items()]))
    worst = {name: max(abs(v["res"][cg]) for cg in FIT_CELLS) for name, v in fit.items()}
    L += ["", "No base of this form (a rigid body at the structure's tip, the arm mounted on it) reproduces the "
          "paper's eq 8 column with its own lambda: the best fits leave "
          + ", ".join(f"{100 * w:.1f} % ({n})" for n, w in worst.items() if n != "space_class")
          + " at worst over the fitted cells and drift to unphysical values (a bound-limited inertia or mass), "
          "because 2-low asks for a less mobile base and 2-high for a more mobile one. The space-class base is "
          "kept as chosen from the published structure, not refitted."]
    L += ["", f"Machine: {platform.machine()}; Python {platform.python_version()}; {datetime.date.today()}; "
          f"{seconds:.0f} s. Rerun: see the script's docstring."]
    return "\n".join(L)


def _passive_at(vmap, s: str, ei: float) -> tuple[float, float]:
    """Passive-arm identified m* / eq 8 - 1 of configurations 1, 2 on one structure."""
    got = {r["cell"]: r["identified"] / r["eq8"] - 1 for r in vmap
           if r["structure"] == s and r["EI_scale"] == ei and r["cell"].startswith("passive")}
    return got.get("passive 1", float("nan")), got.get("passive 2", float("nan"))


def _records() -> str:
    """Each structure's recording after the touch (trial_periods first-mode periods)."""
    from campaign.rig import build
    from campaign.scene.description import make_scene

    out = []
    for s in STRUCTURES:
        scene = make_scene(base="flexible", config=1, gain="low", speed=FIG9_SPEED, params=structure(s))
        out.append(f"{s} {build(scene).max_post:.2f} s ({scene.p('flexible.trial_periods'):g} periods)")
    return ", ".join(out)


def _fig9_summary(b) -> str:
    best = max(b["variants"], key=lambda v: max(v["readings"].values()))
    k = max(best["readings"], key=best["readings"].get)
    return (f"the largest reduction is {100 * best['readings'][k]:.1f} % ({k}, hammer x{best['head']:g}, "
            f"{best['speed']:g} m/s, configuration {best['config']}; eq 8 there {100 * best['eq8']:.1f} %)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--readme", default=None, help="write the section into this markdown file")
    parser.add_argument("--csv", default=None, help="write the validity map's data here")
    parser.add_argument("--png", default=None, help="draw the validity map here")
    parser.add_argument("--structures-csv", default=None,
                        help="write Table 4 and Figure 9's reduction under both structures here")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()

    def log(line):
        print(f"[{time.perf_counter() - t0:6.1f} s] {line}", flush=True)

    lam = identified_lambda(log)
    a = table4(lam["lam"], log)
    b = figure9(lam["lam"], a, log)
    vmap = validity_map(lam["lam"], log)
    cost = trial_cost(log)
    fit = base_fit()
    log("E " + "; ".join(f"{n}: {np.round(v['params'], 3).tolist()}" for n, v in fit.items()))
    if args.csv:
        write_csv(vmap, args.csv)
    if args.png:
        draw_map(vmap, args.png)
    if args.structures_csv:
        write_structures_csv(a, b, args.structures_csv)
    text = format_report(lam, a, b, vmap, cost, fit, time.perf_counter() - t0)
    print(text)
    if args.readme:
        from campaign.bench import write_section
        write_section(args.readme, HEADING, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
