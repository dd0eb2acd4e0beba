"""Where the joints' resistance during the impact comes from, on the designed campaign's trials.

Two tables from a finished designed campaign (``snakemake designed``):

1. **Diagnosis (simulator truth, never an input to a model)** (``diagnosis.csv``). For each
   held-out trial, the joints' resistance impulse ``J_n^T P - H dq`` over the contact (true
   impulse and joint velocities at the contact's edges) as an apparent lambda per joint,
   ``(J_n^T P - H dq)_j / dq_j``, beside the constant lambda the designed trials give
   (``lambda.csv``); joints that never slip during the contact are marked held.
2. **Ablation (measured channels only)** (``ablation.csv``). Held-out m* errors of the joint
   impedance model (:mod:`campaign.joints.impedance`) fitted on the designed trials with
   parts of it removed: Coulomb friction, the servo's gains, the measured pulse shape (a
   half-sine instead).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import h5py
import numpy as np

from ..core.vocabulary import HIGH, LOW, ZERO, ZERO_LOW
from ..core.yamlfile import PROJECT_DIR
from ..design.designed_campaign import impedance_arrays
from ..identify.table import read_identification
from ..joints.impedance import ImpedanceFit, apparent_mass, half_sine_shape, measured_pulse_shape, pulse_compliance
from ..joints.lambda_fit import IdentifiabilityWarning, LambdaFit, design_arrays
from ..model.paper import paper_offset_deg
from ..model.robot import load_robot
from .common import Log, quiet, write_csv

__all__ = ["CLASSES", "diagnosis", "ablation", "run"]

CLASSES = {ZERO_LOW: (ZERO, LOW), HIGH: (HIGH,)}
ABLATION_COLUMNS = ("model", "fitted", "zero_low_median", "zero_low_worst", "high_median", "high_worst")
#: the rig's stick velocity [rad/s] (config/rig.yaml, arm.stick_velocity)
STICK = 1e-4


def _rows(folder, role: str, gains) -> list[dict]:
    """The usable identification rows of one role of the designed campaign, trial paths absolute."""
    rows = [r for g in gains for r in read_identification([Path(folder) / "identification" / f"{role}_{g}.csv"])
            if not r["excluded"]]
    for r in rows:
        r["path"] = str(r["path"] if Path(r["path"]).is_absolute() else PROJECT_DIR / r["path"])
    return rows


def _constant_lambda(robot, rows) -> np.ndarray:
    """The constant lambda (eq 11, 15) of the designed trials ``rows`` (no bootstrap)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        D = np.array([r["impact_direction"] for r in rows], float)
        est = LambdaFit(robot, direction=D[0], random_state=0, n_bootstrap=0)
        return est.fit(np.array([r["q_cmd"] for r in rows], float), np.array([r["m_eff"] for r in rows], float),
                       directions=D).lambda_


def diagnosis(folder, *, limit: int | None = None) -> tuple[list[dict], list[dict]]:
    """(constant lambda rows, one row per held-out trial): the apparent lambda per joint over
    the contact from the truth; ``limit`` held-out trials per gain class at most."""
    robot = load_robot("puma560")
    offset = paper_offset_deg()
    lam_rows, rows = [], []
    for name, gains in CLASSES.items():
        lam = _constant_lambda(robot, _rows(folder, "designed", gains))
        lam_rows += [{"gain_class": name, "joint": j + 1, "lambda_kg_m2": float(x)} for j, x in enumerate(lam)]
        for r in _rows(folder, "heldout", gains)[:limit]:
            with h5py.File(r["path"]) as f:
                t, v = f["truth/t_truth"][:], f["truth/v"][:]
                t0, t1, P = (float(f[f"truth/{k}"][()]) for k in ("contact_start", "contact_end", "impulse"))
            H, Jn = design_arrays(robot, np.array([r["q_cmd"]]), np.array([r["impact_direction"]]))
            dq = np.array([np.interp(t1, t, v[:, j]) - np.interp(t0, t, v[:, j]) for j in range(3)])
            held = np.abs(v[(t >= t0) & (t <= t1)]).max(axis=0) < STICK
            with np.errstate(divide="ignore", invalid="ignore"):
                apparent = (Jn[0] * P - H[0] @ dq) / dq
            q_paper = (np.degrees(np.asarray(r["q_cmd"], float)) - offset).round(6)
            rows.append({"gain_class": name, "gain": r["gain"], "speed_m_s": r["speed"], "m_identified_kg": r["m_eff"],
                         **{f"q{j + 1}_paper_deg": q_paper[j] for j in range(3)},
                         **{f"JnP_{j + 1}_N_m_s": Jn[0][j] * P for j in range(3)},
                         **{f"dq_{j + 1}_rad_s": dq[j] for j in range(3)},
                         **{f"apparent_lambda_{j + 1}": "held" if held[j] else apparent[j] for j in range(3)}})
    return lam_rows, rows


def _no_coulomb(robot, des, shape, servo: bool):
    """Damping only (and the servo's gains if ``servo``), least squares on ln m*: (predict, params)."""
    from scipy.optimize import least_squares  # scipy loads only for the fit

    H, Jn = design_arrays(robot, des["Q"], des["D"])
    sp = np.unique(des["speed"])
    Tm = np.array([des["duration"][des["speed"] == s].mean() for s in sp])
    z = 1.0 if servo else 0.0

    def mass(beta, a):
        Hh, Jh = design_arrays(robot, a["Q"], a["D"]) if a is not des else (H, Jn)
        G = pulse_compliance(Hh, stiffness=z * a["stiffness"], damping=z * a["damping"] + beta,
                             duration=np.interp(a["speed"], sp, Tm), shape=shape)
        return apparent_mass(G, Jh, kappa_pos=np.zeros(3), kappa_neg=np.zeros(3), speed=a["speed"], e=des["e"].mean(),
                             m_b=a["m_b"])

    fit = least_squares(lambda th: np.log(mass(np.exp(th), des)) - np.log(des["m"]), np.log(robot.viscous),
                        diff_step=1e-4)
    return (lambda a: mass(np.exp(fit.x), a)), np.exp(fit.x)


def _full(robot, des, shape, servo: bool):
    """The joint impedance model (with Coulomb friction; the servo's gains if ``servo``)."""
    z = 1.0 if servo else 0.0
    est = ImpedanceFit(robot).fit(des["Q"], des["D"], des["m"], speed=des["speed"], e=des["e"], m_b=des["m_b"],
                                  duration=des["duration"], stiffness=z * des["stiffness"], damping=z * des["damping"],
                                  pulse_shape=shape)
    return (lambda a: est.predict(a["Q"], a["D"], speed=a["speed"], m_b=a["m_b"], stiffness=z * a["stiffness"],
                                  damping=z * a["damping"]),
            np.concatenate([est.damping_, [est.friction_scale_]]))


def ablation(folder) -> list[dict]:
    """Held-out m* errors (median and worst per gain class) of the joint impedance model and
    its ablations, each fitted once on every designed trial."""
    robot = load_robot("puma560")
    des_rows = _rows(folder, "designed", tuple(g for gs in CLASSES.values() for g in gs))
    des = impedance_arrays(robot, des_rows, None)
    measured = measured_pulse_shape([r["path"] for r in des_rows], [r["contact_start"] for r in des_rows],
                                    [r["contact_end"] for r in des_rows])
    held = {name: impedance_arrays(robot, _rows(folder, "heldout", gs), None) for name, gs in CLASSES.items()}
    variants = [("damping only, half-sine pulse", _no_coulomb, half_sine_shape(40), False),
                ("damping + servo, half-sine pulse", _no_coulomb, half_sine_shape(40), True),
                ("damping + servo, measured pulse", _no_coulomb, measured, True),
                ("damping + servo + Coulomb, half-sine pulse", _full, half_sine_shape(40), True),
                ("damping + Coulomb, measured pulse, no servo", _full, measured, False),
                ("damping + servo + Coulomb, measured pulse (the model)", _full, measured, True)]
    rows = []
    for label, make, shape, servo in variants:
        predict, params = make(robot, des, shape, servo)
        row = {"model": label, "fitted": " ".join(f"{x:.3g}" for x in params)}
        for name in CLASSES:
            err = np.abs(predict(held[name]) / held[name]["m"] - 1.0)
            row.update({f"{name}_median": float(np.median(err)), f"{name}_worst": float(err.max())})
        rows.append(row)
    return rows


def run(out_dir, *, designed, quick: bool = False, log: Log = quiet) -> list[str]:
    """Run the study on the designed campaign's results folder ``designed`` and write its CSV
    files into ``out_dir``; ``quick`` diagnoses two held-out trials per class and skips the
    ablation."""
    out = Path(out_dir)
    lam_rows, diag = diagnosis(designed, limit=2 if quick else None)
    log(f"diagnosis: {len(diag)} held-out trials")
    files = [write_csv(out / "lambda.csv", lam_rows, ("gain_class", "joint", "lambda_kg_m2")),
             write_csv(out / "diagnosis.csv", diag, tuple(diag[0]))]
    # a quick run skips the ablation: its file holds only the header
    rows = [] if quick else ablation(designed)
    log("ablation: " + "; ".join(f"{r['model']}: {100 * r['zero_low_median']:.2f} %" for r in rows))
    files.append(write_csv(out / "ablation.csv", rows, ABLATION_COLUMNS))
    return files
