"""Where the joints' resistance during the impact comes from, on the designed campaign's trials.

Two tables from a finished ``snakemake designed`` (``results/designed``):

1. **Diagnosis (simulator truth, never an input to a model).** For each held-out trial, the
   joints' resistance impulse ``J_n^T P - H dq`` over the contact (true impulse and joint
   velocities at the contact's edges) as an apparent lambda per joint, ``(J_n^T P - H dq)_j / dq_j``,
   beside the constant lambda the designed trials give; joints that never slip during the
   contact are marked "held".
2. **Ablation (measured channels only).** Held-out m* errors of the joint impedance model
   (:mod:`campaign.joints.impedance`) fitted on the designed trials with parts of it removed:
   Coulomb friction, the servo's gains, the measured pulse shape (a half-sine instead).

Usage::

    python benchmarks/impact_resistance.py [results/designed]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CLASSES = {"zero_low": ("zero", "low"), "high": ("high",)}


def _rows(folder, role, gains):
    from campaign.identify.table import read_identification

    return [r for g in gains for r in read_identification([Path(folder) / "identification" / f"{role}_{g}.csv"])
            if not r["excluded"]]


def diagnosis(folder) -> None:
    import h5py

    from campaign.design.designed_campaign import _fit, _paper_deg
    from campaign.joints.lambda_fit import design_arrays
    from campaign.model.robot import load_robot

    robot = load_robot("puma560")
    stick = 1e-4      # rad/s: the rig's stick velocity (config/rig.yaml, arm.stick_velocity)
    print("## Diagnosis: apparent lambda per joint over the contact (truth)\n")
    for name, gains in CLASSES.items():
        lam = _fit(robot, _rows(folder, "designed", gains), seed=0, options={"n_bootstrap": 0}).lambda_
        print(f"### {name}: constant lambda of the designed trials {np.round(lam, 3).tolist()} kg m^2\n")
        print("| paper angles [deg] | gain | v [m/s] | m* identified [kg] | J_n^T P [N m s] | dq [rad/s] "
              "| apparent lambda [kg m^2] |")
        print("|---|---|---|---|---|---|---|")
        for r in _rows(folder, "heldout", gains):
            path = r["path"] if Path(r["path"]).is_absolute() else ROOT / r["path"]
            with h5py.File(path) as f:
                t, v = f["truth/t_truth"][:], f["truth/v"][:]
                t0, t1, P = (float(f[f"truth/{k}"][()]) for k in ("contact_start", "contact_end", "impulse"))
            H, Jn = design_arrays(robot, np.array([r["q_cmd"]]), np.array([r["impact_direction"]]))
            dq = np.array([np.interp(t1, t, v[:, j]) - np.interp(t0, t, v[:, j]) for j in range(3)])
            held = np.abs(v[(t >= t0) & (t <= t1)]).max(axis=0) < stick
            res = Jn[0] * P - H[0] @ dq
            with np.errstate(divide="ignore", invalid="ignore"):
                app = res / dq
            cells = ["held" if h else f"{a:.3g}" for a, h in zip(app, held)]
            print(f"| {', '.join(f'{x:g}' for x in _paper_deg(r['q_cmd']))} | {r['gain']} | {r['speed']:g} | "
                  f"{r['m_eff']:.1f} | {', '.join(f'{x:.3f}' for x in Jn[0] * P)} | "
                  f"{', '.join(f'{x:.3f}' for x in dq)} | {', '.join(cells)} |")
        print()


def ablation(folder) -> None:
    from scipy.optimize import least_squares

    from campaign.design.designed_campaign import _impedance_arrays
    from campaign.joints.impedance import (
        ImpedanceFit,
        apparent_mass,
        half_sine_shape,
        measured_pulse_shape,
        pulse_compliance,
    )
    from campaign.joints.lambda_fit import design_arrays
    from campaign.model.robot import load_robot

    robot = load_robot("puma560")
    gains_all = tuple(g for gs in CLASSES.values() for g in gs)
    des_rows = _rows(folder, "designed", gains_all)
    for r in des_rows:
        r["path"] = str(r["path"] if Path(r["path"]).is_absolute() else ROOT / r["path"])
    des = _impedance_arrays(robot, des_rows, None)
    measured = measured_pulse_shape([r["path"] for r in des_rows], [r["contact_start"] for r in des_rows],
                                    [r["contact_end"] for r in des_rows])
    ho = {name: _impedance_arrays(robot, _rows(folder, "heldout", gs), None) for name, gs in CLASSES.items()}

    def no_coulomb(shape, servo):
        """Damping only (and the servo's gains if ``servo``), least squares on ln m*."""
        H, Jn = design_arrays(robot, des["Q"], des["D"])
        sp = np.unique(des["speed"])
        Tm = np.array([des["duration"][des["speed"] == s].mean() for s in sp])
        z = 1.0 if servo else 0.0

        def mass(beta, a):
            Hh, Jh = design_arrays(robot, a["Q"], a["D"]) if a is not des else (H, Jn)
            G = pulse_compliance(Hh, stiffness=z * a["stiffness"], damping=z * a["damping"] + beta,
                                 duration=np.interp(a["speed"], sp, Tm), shape=shape)
            return apparent_mass(G, Jh, kappa_pos=np.zeros(3), kappa_neg=np.zeros(3), speed=a["speed"],
                                 e=des["e"].mean(), m_b=a["m_b"])

        fit = least_squares(lambda th: np.log(mass(np.exp(th), des)) - np.log(des["m"]), np.log(robot.viscous),
                            diff_step=1e-4)
        return lambda a: mass(np.exp(fit.x), a), np.exp(fit.x)

    def full(shape, servo):
        z = 1.0 if servo else 0.0
        est = ImpedanceFit(robot).fit(des["Q"], des["D"], des["m"], speed=des["speed"], e=des["e"], m_b=des["m_b"],
                                      duration=des["duration"], stiffness=z * des["stiffness"],
                                      damping=z * des["damping"], pulse_shape=shape)
        return (lambda a: est.predict(a["Q"], a["D"], speed=a["speed"], m_b=a["m_b"], stiffness=z * a["stiffness"],
                                      damping=z * a["damping"]),
                np.concatenate([est.damping_, [est.friction_scale_]]))

    variants = [("damping only, half-sine pulse", no_coulomb, half_sine_shape(40), False),
                ("damping + servo, half-sine pulse", no_coulomb, half_sine_shape(40), True),
                ("damping + servo, measured pulse", no_coulomb, measured, True),
                ("damping + servo + Coulomb, half-sine pulse", full, half_sine_shape(40), True),
                ("damping + Coulomb, measured pulse, no servo", full, measured, False),
                ("damping + servo + Coulomb, measured pulse (the model)", full, measured, True)]
    print("## Ablation: held-out m* error, one fit on every designed trial (measured channels)\n")
    print("| model | fitted beta [N m s/rad] (, c [s]) | zero_low median / worst | high median / worst |")
    print("|---|---|---|---|")
    for label, make, shape, servo in variants:
        predict, params = make(shape, servo)
        cells = []
        for name in CLASSES:
            err = np.abs(predict(ho[name]) / ho[name]["m"] - 1.0)
            cells.append(f"{100 * np.median(err):.2f} % / {100 * err.max():.2f} %")
        print(f"| {label} | {', '.join(f'{x:.3g}' for x in params)} | {cells[0]} | {cells[1]} |")
    print()


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0]) if argv else ROOT / "results" / "designed"
    if not (folder / "identification").is_dir():
        sys.exit(f"{folder}: no identification tables; run `snakemake designed -j2` first")
    diagnosis(folder)
    ablation(folder)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
