"""Throughput of the impact planner: (pose, direction, gain class) predictions per second.

Each prediction is everything the planner's default, the shipped response model
(:func:`campaign.plan.model_prediction.predict_model`), returns for one candidate: m* as eq 10
measures it (the arm's response to the contact law's pulse, with friction), the impulse (eq
14), the joint velocities, the contact's duration and peak force (on the fixed base at the
arm's apparent mass over the compression, :mod:`campaign.plan.compression`) and, on the
flexible base, the structure's tip twist and momentum and its peak displacement over one
first-mode period (through the VES-II loop). Timed on one core (BLAS threads limited to one, the process pinned to one CPU
where the OS allows it), median of the repeats after one warm-up call, for:

* ``grid``: random poses inside the joint limits x gain classes x horizontal directions,
  the Pinocchio pass per pose (:func:`campaign.plan.prediction.pose_terms`) included;
* ``one pose per prediction``: 1 gain class x 1 direction per pose, the worst case, where
  the per-pose Pinocchio pass is the whole cost;
* ``plan``: a whole :meth:`campaign.plan.planner.ImpactPlanner.fit` at one point (inverse
  kinematics of every branch included) over 360 horizontal directions.

Usage::

    python benchmarks/bench_plan.py                                   # print the table
    python benchmarks/bench_plan.py --readme benchmarks/out/summary.md     # also record it there

The target is at least 10,000 predictions per second on one core; the script exits with
status 1 if the grid cases miss it.
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import datetime  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

from campaign import __version__  # noqa: E402
from campaign.bench.common import blas_line, cpu_name, pin_to_one_cpu, wall_and_cpu, write_section  # noqa: E402
from campaign.model.robot.ik import impact_point  # noqa: E402
from campaign.plan import RESCORE  # noqa: E402
from campaign.plan.directions import horizontal_directions  # noqa: E402
from campaign.plan.factory import build_planner, planner_model  # noqa: E402
from campaign.plan.model_prediction import predict_model  # noqa: E402
from campaign.plan.prediction import pose_terms, predict  # noqa: E402
from campaign.rig.contact import ContactLaw  # noqa: E402

HEADING = "## Impact planner throughput"
TARGET = 10_000.0  # (pose, direction, gain) predictions per second on one core








def timed(fn, repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU times [s] of ``repeats`` calls of ``fn`` after one warm-up call."""
    return wall_and_cpu(fn, repeats)


def row(case: str, base: str, shape: str, count: int, times) -> dict:
    wall, cpu = times
    med = statistics.median(wall)
    return {"case": case, "base": base, "shape": shape, "count": count, "median_s": med,
            "min_s": min(wall), "max_s": max(wall), "rate": count / med, "cpu_rate": count / min(cpu)}


def measure_grid(planner, *, n_poses: int, n_gains: int, n_dirs: int, repeats: int, seed: int) -> dict:
    robot = planner.robot
    Q = np.random.default_rng(seed).uniform(robot.q_lower, robot.q_upper, size=(n_poses, robot.nv))
    names = list(planner.lambdas)[:n_gains]
    dirs = horizontal_directions(n_dirs)
    e = planner.restitution if planner.contact_restitution is None else planner.contact_restitution
    contact = ContactLaw(planner.contact_stiffness, planner.contact_exponent, e)

    if planner.model is not None:
        def fn():
            return predict_model(robot, Q, planner.model, names, dirs, mass=planner.mass, speed=planner.speed,
                                 restitution=planner.restitution, contact=contact, flexible=planner.beam is not None,
                                 pendulum=planner.pendulum)
    else:
        lams = [planner.lambdas[k] for k in names]

        def fn():
            return predict(pose_terms(robot, Q, beam=planner.beam), lams, dirs, mass=planner.mass,
                           speed=planner.speed, restitution=planner.restitution, contact=contact,
                           arm=planner.arm, gain_names=names)

    case = "grid" if n_gains * n_dirs > 1 else "one pose per prediction"
    return row(case, "flexible" if planner.beam is not None else "fixed",
               f"{n_poses} x {n_gains} x {n_dirs}", n_poses * n_gains * n_dirs, timed(fn, repeats))


def measure_plan(planner, *, n_dirs: int, repeats: int, case: str = "plan (IK included)") -> dict:
    q = np.radians([30.0, 60.0, -60.0])          # a point with four branches
    p = impact_point(planner.robot, q)
    dirs = horizontal_directions(n_dirs)
    planner.fit(p, dirs)
    count = planner.q_.shape[0] * len(planner.lambdas) * n_dirs
    return row(case, "flexible" if planner.beam is not None else "fixed",
               f"{planner.q_.shape[0]} x {len(planner.lambdas)} x {n_dirs}", count,
               timed(lambda: planner.fit(p, dirs), repeats))


def measure_map(planner, *, resolution: float, repeats: int) -> dict:
    """A whole workspace map (:func:`campaign.plan.maps.workspace_map`): IK of every grid point and the
    predictions of every branch x gain class, the paper's n."""
    from campaign.plan.maps import workspace_map

    contact = ContactLaw(planner.contact_stiffness, planner.contact_exponent, planner.restitution)
    kw = dict(lambdas=planner.lambdas, contact=contact, mass=planner.mass, speed=planner.speed,
              restitution=planner.restitution, direction=[-1.0, 0.0, 0.0], y=-0.15005, resolution=resolution,
              beam=planner.beam, model=planner.model, pendulum=planner.pendulum)
    m = workspace_map(planner.robot, **kw)
    points = m["n_branches"].size
    count = int(m["n_branches"].sum()) * len(planner.lambdas)
    r = row("workspace map (IK incl.)", "flexible" if planner.beam is not None else "fixed",
            f"{points} points", count, timed(lambda: workspace_map(planner.robot, **kw), repeats))
    r["points_per_s"] = points / r["median_s"]
    return r


def format_table(rows: list[dict]) -> str:
    head = (f"| {'case':<24} | {'base':<8} | {'poses x gains x dirs':>20} | {'predictions':>11} | "
            f"{'median [ms]':>11} | {'min-max [ms]':>13} | {'predictions/s':>13} | {'per CPU s':>10} |")
    sep = "|" + "|".join("-" * len(c) for c in head.split("|")[1:-1]) + "|"
    lines = [head, sep]
    for r in rows:
        spread = f"{1e3 * r['min_s']:.1f}-{1e3 * r['max_s']:.1f}"
        lines.append(f"| {r['case']:<24} | {r['base']:<8} | {r['shape']:>20} | {r['count']:>11,d} | "
                     f"{1e3 * r['median_s']:>11.1f} | {spread:>13} | {r['rate']:>13,.0f} | {r['cpu_rate']:>10,.0f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=7, help="timed calls per case (default: %(default)s)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    print(blas_line())
    if args.repeats < 1:
        parser.error("--repeats must be positive")
    pinning = pin_to_one_cpu()
    rows = []
    grid = []
    maps = []
    model, _ = planner_model()                     # the default: the shipped response model
    model.samples = 24
    for base in ("fixed", "flexible"):
        planner = build_planner(base=base, model=model, speed=2.0)
        g = measure_grid(planner, n_poses=1000, n_gains=3, n_dirs=8, repeats=args.repeats, seed=1)
        grid.append(g)
        rows += [g, measure_grid(planner, n_poses=1000, n_gains=1, n_dirs=1, repeats=args.repeats, seed=2),
                 measure_plan(planner, n_dirs=360, repeats=args.repeats)]
        if base == "flexible":
            # the same plan ranked ideally coupled only (no candidate rescored through the loop)
            ideal = build_planner(base=base, model=model, speed=2.0)
            ideal.rescore = 0
            rows.append(measure_plan(ideal, n_dirs=360, repeats=args.repeats, case="plan, ideal only"))
        maps.append(measure_map(planner, resolution=0.1, repeats=max(1, args.repeats // 2)))
    rows += maps
    worst = min(grid, key=lambda r: r["cpu_rate"])
    ok = worst["cpu_rate"] >= TARGET
    summary = "\n".join([
        "(pose, direction, gain class) predictions per second of `campaign.plan.prediction` (m*, impulse, joint "
        "velocities, contact duration and peak contact force, on the fixed base at the arm's apparent mass over "
        "the compression, `campaign.plan.compression`; on the flexible base also the base velocity and momentum and the "
        "structure's peak displacement under the contact's pulse with the arm's servo, friction and gravity, "
        "`campaign.plan.post_contact`); median of the timed repeats after one warm-up call, one core "
        f"(BLAS threads = 1, process {pinning}). `grid`: random poses inside the joint limits x 3 gain classes x "
        "8 horizontal directions, Pinocchio pass per pose included; `one pose per prediction`: the worst case; "
        "`plan`: `ImpactPlanner.fit` at a point with four branches, inverse kinematics included, over 360 "
        f"directions (on the flexible base its best {RESCORE} candidates rescored through the VES-II loop; "
        "`plan, ideal only`: none).",
        "",
        format_table(rows),
        "",
        f"Slowest grid case ({worst['base']} base): **{worst['cpu_rate']:,.0f} predictions per CPU second** "
        f"(best of the repeats; {worst['rate']:,.0f}/s of wall time, median), which {'meets' if ok else 'MISSES'} "
        f"the target of {TARGET:,.0f}/s on one core. With one prediction per pose the "
        "Pinocchio pass per pose sets the rate (the `one pose per prediction` rows). A workspace map solves "
        "every point of its grid for all branches (batched damped Newton from 36 starts per point): "
        + ", ".join(f"{m['points_per_s']:,.0f} points/s ({m['base']} base)" for m in maps)
        + "; the predictions count each reachable branch x gain class.",
        "",
        f"Machine: {cpu_name()}; Python {platform.python_version()}, numpy {np.__version__}, "
        f"pin {pin.__version__}, campaign {__version__}; {datetime.date.today().isoformat()}; the machine's "
        "two cores were shared with other jobs, hence the spread. Record: `.venv/bin/python benchmarks/bench_plan.py --readme benchmarks/out/summary.md`.",
    ])
    print(summary)
    if args.readme is not None:
        write_section(args.readme, HEADING, summary)
        print(f"\nwrote the section '{HEADING}' of {args.readme}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
