"""Re-analysing the committed reference archive: ``snakemake --cores 2 --config simulate=false``.

The command the README documents, run as a new user runs it: the default configuration
(``config/config.yaml``), in a fresh folder laid out like a clone of the repository
(``config/`` and the committed ``archive/reference``, read only), nothing simulated. Every
product the archive's cells can make is made into ``results/reuse-reference/``:
identification, the lambda fits, Tables 2-4, Figures 4-9 and the calibration report; the
archive is verified. Measured around the
command: the wall time and the CPU time of Snakemake and all its jobs, split with the
jobs' ``TIMING`` lines (``campaign.pipeline.joblog.job_log``); the machine's load average beside
it, since other work on the machine stretches the wall time, not the CPU time.

Usage::

    python benchmarks/bench_reuse.py                         # one run
    python benchmarks/bench_reuse.py --repeats 3             # the median of 3 runs
    python benchmarks/bench_reuse.py --readme benchmarks/out/summary.md   # also record the summary

Target: at most 25 s of wall time on 2 cores. Missing it is reported, not an error.
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from bench_campaign import REPO, SNAKEMAKE, machine, run, stage_split, timings

from campaign.bench.common import blas_line

HEADING = "## Reuse of the reference archive"
TARGET = 25.0  # seconds, 2 cores


def bench_once(cores: int) -> dict:
    """One run from a clean clone-like folder; the measurements."""
    work = Path(tempfile.mkdtemp(prefix="bench-reuse-"))
    try:
        (work / "config").symlink_to(REPO / "config")
        (work / "archive").mkdir()
        (work / "archive" / "reference").symlink_to(REPO / "archive" / "reference")
        cmd = [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(work), "--cores", str(cores),
               "--config", "simulate=false"]
        wall, cpu = run(cmd, work)
        load = os.getloadavg()[0]
        recs = timings(work / "results" / "reuse-reference")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    stages = {k: v for k, v in stage_split(recs, cpu).items() if k != "simulation"}
    return {"wall": wall, "cpu": cpu, "load": load, "jobs": sum("part_of" not in r for r in recs), "stages": stages}


def table(runs: list[dict], cores: int) -> str:
    walls = [r["wall"] for r in runs]
    mid = sorted(runs, key=lambda r: r["wall"])[len(runs) // 2]
    wall = statistics.median(walls)
    verdict = "met" if wall <= TARGET else "missed"
    range_ = f" ({min(walls):.1f}-{max(walls):.1f}, median of {len(walls)})" if len(walls) > 1 else ""
    head = "| jobs | wall [s] | target [s] | load | CPU [s] | CPU / cores [s] | " + \
        " | ".join(sorted(mid["stages"])) + " |"
    row = (f"| {mid['jobs']} | {wall:.1f}{range_} | {TARGET:.0f} ({verdict}) | {mid['load']:.1f} | {mid['cpu']:.1f} | "
           f"{mid['cpu'] / cores:.1f} | " + " | ".join(f"{mid['stages'][k]:.1f}" for k in sorted(mid["stages"])) + " |")
    return "\n".join([head, "|" + "---|" * (head.count("|") - 1), row])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=1, help="runs, one after the other (default: %(default)s)")
    parser.add_argument("--cores", type=int, default=2, help="snakemake --cores (default: %(default)s)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    print(blas_line())
    runs = [bench_once(args.cores) for _ in range(max(1, args.repeats))]
    body = table(runs, args.cores)
    print(body)
    if args.readme:
        from campaign.bench import write_section

        text = ("`snakemake --cores 2 --config simulate=false` with the default configuration on the committed "
                "`archive/reference`, from a clean clone-like folder (`benchmarks/bench_reuse.py`): every product "
                "its 26 trials can make, the archive verified, nothing simulated. CPU [s] is Snakemake and all its "
                "jobs (user + system); the stage columns split it by the jobs' `TIMING` lines (CPU seconds), "
                "`Snakemake` being what no job spent. `load` is the 1-minute load average when the run ended: "
                "other work on the machine stretches the wall time, not the CPU time. `CPU / cores` is what the "
                "run needs of an otherwise idle 2-core machine if both cores stay busy, the floor of its wall "
                "time there.\n\n"
                f"{body}\n\n{machine()}")
        write_section(args.readme, HEADING, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
