"""Identification accuracy against the simulator truth.

Simulates the fixed-base sweep -- configurations 1-3 x gains zero/low/high x impact speeds
1.0/1.5/2.0/2.5 m/s x 2 repeats, default scene -- at the paper's 50 Hz joint-encoder rate
and at 1 kHz, identifies every trial with several :class:`campaign.identify.IdentifyOptions`
variants, and prints the median / 90th percentile / worst |relative error| of m* (eq 10)
and e (eq 12) per gain, the errors taken against eq 10/12 on the truth's edge velocities.
Also checks the ideal scene (configurations 1-3 x 1.0/2.5 m/s).

Variants:

* ``old``: joint encoders (``lti``) with straight-line contact edges and the cubic pendulum
  fit (the simplest encoder method, for comparison);
* ``previous``: joint encoders, power-law edges, cubic pendulum fit on 50 ms, 20 ms post-contact
  joint window at 1 kHz (what the pendulum ODE fit and the longer window improve on);
* ``before``: the defaults with the tip-space model instead of the joint-dynamics model
  (``arm_model="lti"``: at 1 kHz the tip-position LTI fit on a 40 ms post-contact window; at
  50 Hz the F/T method, as the default);
* ``encoders``: joint encoders with the default ``arm_model="joint"`` (joint-space dynamics
  driven by the measured servo torque, 60 ms post-contact window at 1 kHz);
* ``ft``: the arm's momentum from the base F/T sensor and the piezo force;
* ``combined``: v'_a - v_a from the encoders and the F/T weighted by their estimated variances;
* ``default``: ``arm_velocity="auto"`` (F/T when the joint samples are coarser than 5 ms);
* ``impulse``: the default with ``m_eff_estimator="impulse"`` (eq 11's impulsive-limit m*,
  the pendulum's contact impulse over the tip's velocity change at the contact-start
  Jacobian), scored against its own truth (:func:`campaign.bench.truth_m_impulse`), not
  eq 10's. A last table gives how far eq 10's target sits from it on the rig's contacts.

Usage::

    .venv/bin/python benchmarks/identification_accuracy.py [--repeats 2] [--rates 50 1000]

Runs ~2 min on one core (144 simulated trials; the joint model's least squares on small
matrices run single-threaded: OMP_NUM_THREADS=1 unless set).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")   # small matrices: BLAS threads only contend

import argparse
import time

import numpy as np

from campaign.bench import truth_m_impulse
from campaign.identify import IdentifyOptions, identify_trial
from campaign.model.robot import load_robot
from campaign.rig.simulate import simulate
from campaign.scene.description import make_scene

GAINS = ("zero", "low", "high")
SPEEDS = (1.0, 1.5, 2.0, 2.5)
VARIANTS = {
    "combined": {"arm_velocity": "combined"},
    "old": {"arm_velocity": "encoders", "arm_model": "lti", "edge_model": "line", "pendulum_model": "poly",
            "joint_post_window_min": 0.02},
    "previous": {"arm_velocity": "encoders", "arm_model": "lti", "pendulum_model": "poly",
                 "joint_post_window_min": 0.02},
    "before": {"arm_model": "lti"},
    "encoders": {"arm_velocity": "encoders"},
    "ft": {"arm_velocity": "ft"},
    "default": {},
    "impulse": {"m_eff_estimator": "impulse"},
}


def truth_values(truth, m_b: float) -> tuple[float, float]:
    """m* and e from eq 10 / eq 12 on the simulator's true edge velocities."""
    va, vap = float(truth["v_a_pre"]), float(truth["v_a_post"])
    vb, vbp = float(truth["v_b_pre"]), float(truth["v_b_post"])
    return m_b * (vb - vbp) / (vap - va), (vap - vbp) / (vb - va)


def simulate_sweep(rate: float, repeats: int) -> list:
    """(gain, measured, truth, attrs) of every fixed-base trial of the sweep."""
    out = []
    for config in (1, 2, 3):
        for gain in GAINS:
            for speed in SPEEDS:
                for repeat in range(repeats):
                    scene = make_scene(base="fixed", config=config, gain=gain, speed=speed, repeat=repeat,
                                       params={"sensors.joint_encoder_rate": rate})
                    tree = simulate(scene)
                    out.append((gain, tree["measured"].to_dataset(), tree["truth"].to_dataset(), dict(tree.attrs)))
    return out


def score(trials, robot, options: IdentifyOptions) -> dict:
    """Per gain: arrays of relative m* and e errors, excluded count, methods used."""
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


def _stats(x) -> str:
    a = 100 * np.abs(np.asarray(x))
    if a.size == 0:
        return "-"
    return f"{np.median(a):.2f} / {np.quantile(a, 0.9):.2f} / {a.max():.2f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--rates", type=float, nargs="+", default=[50.0, 1000.0])
    args = ap.parse_args(argv)
    robot = load_robot("puma560")
    print("| joint rate | gain | variant | m* median / 90th / worst [%] | m* mean [%] "
          "| e median / 90th / worst [%] | method | excluded |")
    print("|---|---|---|---|---|---|---|---|")
    for rate in args.rates:
        t0 = time.perf_counter()
        trials = simulate_sweep(rate, args.repeats)
        sim = time.perf_counter() - t0
        for name, kw in VARIANTS.items():
            res = score(trials, robot, IdentifyOptions(**kw))
            for gain in GAINS:
                c = res[gain]
                mean = f"{100 * np.mean(c['m']):+.2f}" if c["m"] else "-"
                print(f"| {rate:g} Hz | {gain} | {name} | {_stats(c['m'])} | {mean} | {_stats(c['e'])} "
                      f"| {'/'.join(sorted(c['methods']))} | {c['excluded']} |")
        print(f"<!-- {len(trials)} trials at {rate:g} Hz simulated in {sim:.0f} s -->")
        if rate == args.rates[0]:
            gaps = {g: [] for g in GAINS}
            for gain, measured, truth, _ in trials:
                m10 = truth_values(truth, float(measured["hammer_mass_eff"]))[0]
                gaps[gain].append(100 * (m10 / truth_m_impulse(measured, truth, robot) - 1))
    print("\n| gain | eq 10's true m* over the impulsive-limit true m*: mean / min / max [%] |")
    print("|---|---|")
    for gain in GAINS:
        g = np.asarray(gaps[gain])
        print(f"| {gain} | {g.mean():+.2f} / {g.min():+.2f} / {g.max():+.2f} |")
    # ideal scene: the Ex-IIT's assumptions, a ~1 ms contact
    worst = {}
    for config in (1, 2, 3):
        for speed in (1.0, 2.5):
            tree = simulate(make_scene(base="fixed", config=config, speed=speed, scene="ideal"))
            measured, truth = tree["measured"].to_dataset(), tree["truth"].to_dataset()
            m_true, e_true = truth_values(truth, float(measured["hammer_mass_eff"]))
            r = identify_trial(measured, robot=robot, meta=dict(tree.attrs))
            w = worst.setdefault(r.arm_velocity, [0.0, 0.0, 0])
            w[0] = max(w[0], abs(r.m_eff / m_true - 1))
            w[1] = max(w[1], abs(r.e / e_true - 1))
            w[2] += 1
    for method, (wm, we, k) in worst.items():
        print(f"\nideal scene, default options ({k} trials, method {method}): worst m* {100 * wm:.4f} %, "
              f"worst e {100 * we:.4f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
