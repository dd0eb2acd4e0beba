"""Identification accuracy against the simulator truth.

Simulates the fixed-base sweep (configurations 1-3 x gain sets zero, low, high x impact
speeds 1.0-2.5 m/s x repeats, default scene) at the paper's 50 Hz joint-encoder rate and at
1 kHz, identifies every trial with several :class:`campaign.identify.IdentifyOptions`
variants, and scores m* (eq 10) and e (eq 12) against eq 10 / 12 on the truth's edge
velocities (``accuracy.csv``: median, 90th percentile and worst absolute relative error per rate,
gain set and variant). The ``impulse`` variant (eq 11's impulsive-limit m*) is scored
against its own truth (:func:`campaign.studies.closed_forms.truth_m_impulse`); ``gap.csv`` gives
how far eq 10's target sits from it on the rig's contacts, and ``ideal.csv`` the worst error
on the ideal scene (the Ex-IIT's assumptions, a ~1 ms contact).

Variants: ``lti`` (joint encoders, straight-line contact edges, cubic pendulum fit: the
simplest encoder method), ``lti_power`` (power-law edges, a 20 ms post-contact joint window),
``tip_lti`` (the defaults with the tip-space model instead of the joint-dynamics model),
``encoders`` (joint encoders, joint-space dynamics), ``ft`` (the arm's momentum from the base
F/T sensor), ``combined`` (encoders and F/T weighted by their variances), ``default``
(``arm_velocity="auto"``) and ``impulse``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..core.vocabulary import FIXED, HIGH, LOW, ZERO
from ..identify import IdentifyOptions, identify_trial
from ..model.robot import load_robot
from ..rig.trial import simulate
from ..scene.description import make_scene
from .closed_forms import truth_m_impulse
from .common import Log, quiet, truth_values, write_csv

__all__ = ["Settings", "VARIANTS", "GAINS", "simulate_sweep", "score", "run"]

GAINS = (ZERO, LOW, HIGH)
VARIANTS = {
    "combined": {"arm_velocity": "combined"},
    "lti": {"arm_velocity": "encoders", "arm_model": "lti", "edge_model": "line", "pendulum_model": "poly",
            "joint_post_window_min": 0.02},
    "lti_power": {"arm_velocity": "encoders", "arm_model": "lti", "pendulum_model": "poly",
                  "joint_post_window_min": 0.02},
    "tip_lti": {"arm_model": "lti"},
    "encoders": {"arm_velocity": "encoders"},
    "ft": {"arm_velocity": "ft"},
    "default": {},
    "impulse": {"m_eff_estimator": "impulse"},
}
COLUMNS = ("joint_rate_Hz", "gain", "variant", "trials", "excluded", "m_median", "m_p90", "m_worst", "m_mean",
           "e_median", "e_p90", "e_worst", "method")


@dataclasses.dataclass(frozen=True)
class Settings:
    """What the study sweeps; :meth:`quick` is a reduced set for the tests."""

    rates: tuple = (50.0, 1000.0)
    speeds: tuple = (1.0, 1.5, 2.0, 2.5)
    repeats: int = 2
    variants: tuple = tuple(VARIANTS)

    @classmethod
    def quick(cls) -> Settings:
        return cls(rates=(50.0,), speeds=(2.5,), repeats=1, variants=("default", "impulse"))


def simulate_sweep(rate: float, *, speeds, repeats: int) -> list:
    """(gain, measured, truth, attrs) of every fixed-base trial of the sweep."""
    out = []
    for config in (1, 2, 3):
        for gain in GAINS:
            for speed in speeds:
                for repeat in range(repeats):
                    scene = make_scene(base=FIXED, config=config, gain=gain, speed=speed, repeat=repeat,
                                       params={"sensors.joint_encoder_rate": rate})
                    tree = simulate(scene)
                    out.append((gain, tree["measured"].to_dataset(), tree["truth"].to_dataset(), dict(tree.attrs)))
    return out


def score(trials, robot, options: IdentifyOptions) -> dict:
    """Per gain set: arrays of relative m* and e errors, excluded count, methods used."""
    res = {g: {"m": [], "e": [], "excluded": 0, "methods": set()} for g in GAINS}
    for gain, measured, truth, attrs in trials:
        r = identify_trial(measured, robot=robot, meta=attrs, options=options)
        cell = res[gain]
        if r.excluded:
            cell["excluded"] += 1
            continue
        m_true, e_true = truth_values(truth, float(measured["hammer_mass_eff"]))
        if options.m_eff_estimator == "impulse":     # each estimator against its own target
            m_true = truth_m_impulse(measured, truth, robot)
        cell["m"].append(r.m_eff / m_true - 1)
        cell["e"].append(r.e / e_true - 1)
        cell["methods"].add(r.arm_velocity)
    return res


def _stats(prefix: str, x) -> dict:
    a = np.abs(np.asarray(x, float))
    if a.size == 0:
        return {}
    return {f"{prefix}_median": float(np.median(a)), f"{prefix}_p90": float(np.quantile(a, 0.9)),
            f"{prefix}_worst": float(a.max())}


def accuracy_rows(rate: float, trials, robot, variants, log: Log) -> list[dict]:
    """One row per gain set and variant of the trials at one joint-encoder rate."""
    rows = []
    for name in variants:
        res = score(trials, robot, IdentifyOptions(**VARIANTS[name]))
        for gain in GAINS:
            c = res[gain]
            rows.append({"joint_rate_Hz": rate, "gain": gain, "variant": name, "trials": len(c["m"]) + c["excluded"],
                         "excluded": c["excluded"], **_stats("m", c["m"]), **_stats("e", c["e"]),
                         "m_mean": float(np.mean(c["m"])) if c["m"] else None, "method": "/".join(sorted(c["methods"]))})
        log(f"{rate:g} Hz {name}: m* median " + ", ".join(f"{r['gain']} {100 * r.get('m_median', np.nan):.2f} %"
                                                         for r in rows[-len(GAINS):]))
    return rows


def ideal_rows(robot) -> list[dict]:
    """The ideal scene (configurations 1-3 at 1.0 and 2.5 m/s), default options: the worst m*
    and e error per arm-velocity method."""
    worst: dict = {}
    for config in (1, 2, 3):
        for speed in (1.0, 2.5):
            tree = simulate(make_scene(base=FIXED, config=config, speed=speed, scene="ideal"))
            measured, truth = tree["measured"].to_dataset(), tree["truth"].to_dataset()
            m_true, e_true = truth_values(truth, float(measured["hammer_mass_eff"]))
            r = identify_trial(measured, robot=robot, meta=dict(tree.attrs))
            w = worst.setdefault(r.arm_velocity, {"method": r.arm_velocity, "trials": 0, "m_worst": 0.0, "e_worst": 0.0})
            w["m_worst"] = max(w["m_worst"], abs(r.m_eff / m_true - 1))
            w["e_worst"] = max(w["e_worst"], abs(r.e / e_true - 1))
            w["trials"] += 1
    return list(worst.values())


def run(out_dir, *, quick: bool = False, log: Log = quiet) -> list[str]:
    """Run the study and write its CSV files into ``out_dir``; returns their paths."""
    s = Settings.quick() if quick else Settings()
    out = Path(out_dir)
    robot = load_robot("puma560")
    rows, gap = [], []
    for rate in s.rates:
        trials = simulate_sweep(rate, speeds=s.speeds, repeats=s.repeats)
        rows += accuracy_rows(rate, trials, robot, s.variants, log)
        if rate == s.rates[0]:
            for gain in GAINS:
                g = np.array([truth_values(t, float(m["hammer_mass_eff"]))[0] / truth_m_impulse(m, t, robot) - 1
                              for gn, m, t, _ in trials if gn == gain])
                gap.append({"gain": gain, "mean": g.mean(), "min": g.min(), "max": g.max()})
    ideal = ideal_rows(robot)
    return [write_csv(out / "accuracy.csv", rows, COLUMNS),
            write_csv(out / "gap.csv", gap, ("gain", "mean", "min", "max")),
            write_csv(out / "ideal.csv", ideal, ("method", "trials", "m_worst", "e_worst"))]
