"""Per-trial cost outside the integrator: ``build`` (assemble and check the plant) and
``record`` (sample every channel into the DataTree), beside ``integrate_trial`` and the total.

Each case runs one warm-up trial, then ``--repeats`` trials; every trial is built afresh
(the noise streams of a rig are consumed by its recording) and its three stages are timed
separately with ``time.process_time`` (CPU of this process, steadier than wall time when
other jobs share the machine). The table shows the medians [ms].

Usage::

    python benchmarks/bench_record.py               # 10 repeats
    python benchmarks/bench_record.py --repeats 5
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import statistics
import time

from campaign.bench.common import blas_line
from campaign.rig import trial as sim
from campaign.scene.description import make_scene

CASES = (
    ("fixed", 2, "high"),
    ("fixed", 1, "zero"),
    ("flexible", 2, "high"),
    ("flexible", 1, "zero"),
)


def trial_times(scene) -> tuple[float, float, float]:
    """CPU [s] of build, integrate and record for one trial of ``scene``."""
    p = scene.p
    c0 = time.process_time()
    rig = sim.build(scene)
    c1 = time.process_time()
    traj = sim.integrate_trial(
        rig.plant, rig.pid, t_contact=rig.t_contact, speed=scene.speed, servo_period=rig.servo_period,
        min_post=rig.min_post, max_post=rig.max_post, settle_velocity=float(p("trial.settle_velocity")),
        stick_velocity=float(p("arm.stick_velocity")), catch_delay=float(p("pendulum.catch_delay")),
        substeps_contact=rig.substeps_contact, substeps_free=rig.substeps_free)
    c2 = time.process_time()
    sim.record(rig, traj)
    c3 = time.process_time()
    return c1 - c0, c2 - c1, c3 - c2


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--speed", type=float, default=2.0)
    args = ap.parse_args(argv)
    print(blas_line())
    rows = []
    for base, config, gain in CASES:
        scene = make_scene(base=base, config=config, gain=gain, speed=args.speed)
        trial_times(scene)   # warm-up (imports, caches)
        runs = [trial_times(scene) for _ in range(args.repeats)]
        b, i, r = (statistics.median(x[k] for x in runs) * 1e3 for k in range(3))
        tot = statistics.median(sum(x) for x in runs) * 1e3
        rows.append((f"{base} config {config} {gain}", b, r, b + r, i, tot))
    head = ("case", "build", "record", "build+record", "integrate", "total")
    print(f"CPU medians over {args.repeats} trials [ms], speed {args.speed:g} m/s")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name, *vals in rows:
        print(f"| {name} | " + " | ".join(f"{v:.1f}" for v in vals) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
