"""Throughput of the batch effective-mass evaluation (eq 11), configurations per second.

Runs :func:`campaign.model.exiit.effective_mass_batch` on uniformly drawn configurations inside
the joint limits, several repeats per size, on one core (BLAS threads limited to one and,
where the OS allows it, the process pinned to one CPU), and prints a table of the median.
The scalar :func:`campaign.model.exiit.effective_mass` is timed too, for comparison.

Usage::

    python benchmarks/bench_exiit.py                       # print the table
    python benchmarks/bench_exiit.py --readme benchmarks/out/summary.md   # also record it there

The target is at least 100,000 configurations per second on one core; the
script exits with status 1 if the PUMA 560 batch at the largest size misses it.
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

from campaign import __version__
from campaign.bench.common import blas_line, cpu_name, pin_to_one_cpu, time_call  # noqa: E402
from campaign.model import exiit  # noqa: E402
from campaign.model.robot import load_robot  # noqa: E402

HEADING = "## Ex-IIT batch evaluation"
TARGET = 100_000.0  # configurations per second, one core









def measure(robot, n_configs: int, repeats: int, *, seed: int, scalar: bool = False) -> dict:
    """Median throughput of eq 11 over ``n_configs`` random configurations.

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    n_configs : int
        Configurations per call.
    repeats : int
        Timed calls (the median is reported).
    seed : int
        Seed of the configurations.
    scalar : bool
        Time a Python loop over :func:`campaign.model.exiit.effective_mass` instead of the batch.
    """
    rng = np.random.default_rng(seed)
    Q = rng.uniform(robot.q_lower, robot.q_upper, size=(n_configs, robot.nv))
    n = (-1.0, 0.0, 0.0)
    if scalar:
        data = robot.model.createData()

        def fn():
            return [exiit.effective_mass(robot, q, n, data=data) for q in Q]
    else:
        def fn():
            return exiit.effective_mass_batch(robot, Q, n)
    times = time_call(fn, repeats)
    med = statistics.median(times)
    return {
        "robot": robot.name, "method": "scalar loop" if scalar else "batch", "N": n_configs,
        "repeats": repeats, "median_s": med, "min_s": min(times), "max_s": max(times),
        "rate": n_configs / med,
    }


def format_table(rows: list[dict]) -> str:
    head = (f"| {'robot':<8} | {'method':<11} | {'N':>7} | {'repeats':>7} | {'median [ms]':>11} | "
            f"{'min-max [ms]':>15} | {'configs/s (median)':>18} |")
    sep = "|" + "|".join("-" * (len(c)) for c in head.split("|")[1:-1]) + "|"
    lines = [head, sep]
    for r in rows:
        spread = f"{1e3 * r['min_s']:.1f}-{1e3 * r['max_s']:.1f}"
        lines.append(f"| {r['robot']:<8} | {r['method']:<11} | {r['N']:>7,d} | {r['repeats']:>7d} | "
                     f"{1e3 * r['median_s']:>11.1f} | {spread:>15} | {r['rate']:>18,.0f} |")
    return "\n".join(lines)


def write_section(readme: Path, body: str) -> None:
    """Replace (or append) this script's section of ``readme`` (campaign.bench.write_section)."""
    from campaign.bench import write_section as _write_section

    _write_section(readme, HEADING, body)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="1000,10000,100000",
                        help="configurations per batch call, comma-separated (default: %(default)s)")
    parser.add_argument("--repeats", type=int, default=7, help="timed calls per size (default: %(default)s)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    print(blas_line())
    sizes = [int(s) for s in args.sizes.split(",")]
    if args.repeats < 1 or any(s < 1 for s in sizes):
        parser.error("--sizes and --repeats must be positive")

    pinning = pin_to_one_cpu()
    puma, planar = load_robot("puma560"), load_robot("planar2")
    rows = [measure(puma, n, args.repeats, seed=i) for i, n in enumerate(sizes)]
    rows.append(measure(planar, sizes[-1], args.repeats, seed=99))
    rows.append(measure(puma, min(2000, sizes[-1]), args.repeats, seed=98, scalar=True))

    best = rows[len(sizes) - 1]
    verdict = "meets" if best["rate"] >= TARGET else "MISSES"
    summary = "\n".join([
        "Throughput of `campaign.model.exiit.effective_mass_batch` (eq 11, fixed base, n = -x, lambda = 0) "
        "on configurations drawn uniformly inside the joint limits; median of the timed repeats after "
        "one warm-up call, one core (BLAS threads = 1, process " + pinning + "). "
        "The scalar loop over `effective_mass` is shown for comparison.",
        "",
        format_table(rows),
        "",
        f"PUMA 560 batch at N = {best['N']:,d}: **{best['rate']:,.0f} configurations/s**, which {verdict} "
        f"the target of {TARGET:,.0f}/s.",
        "",
        f"Machine: {cpu_name()}; Python {platform.python_version()}, numpy {np.__version__}, "
        f"pin {pin.__version__}, campaign {__version__}; {datetime.date.today().isoformat()}. "
        "Rerun: `make bench`; record: `.venv/bin/python benchmarks/bench_exiit.py --readme benchmarks/out/summary.md`.",
    ])
    print(summary)
    if args.readme is not None:
        write_section(args.readme, summary)
        print(f"\nwrote the section '{HEADING}' of {args.readme}")
    return 0 if best["rate"] >= TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
