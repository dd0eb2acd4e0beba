"""Designed campaign: wall time of ``snakemake designed`` from a clean state, and its CPU by job.

Runs the designed campaign (``config/designed.yaml``) with 2 cores into a fresh temporary
results and archive root, measures the wall time around the command, and sums the jobs' own
``TIMING`` lines (``campaign.pipeline.joblog.job_log``) into CPU seconds per rule (contention from
other work on a shared machine stretches wall times, hardly CPU times). Prints a table.

Usage::

    python benchmarks/bench_designed.py
    python benchmarks/bench_designed.py --repeats 3     # the median wall time of 3 runs

Target: within 2 minutes wall on this 2-core machine.
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from campaign.bench.common import blas_line

ROOT = Path(__file__).resolve().parents[1]


def run_once() -> tuple[float, dict[str, float], dict[str, int]]:
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        r = subprocess.run([snakemake, "designed", "--cores", "2", "-q", "--directory", str(ROOT), "--config",
                            f"results_root={tmp}/results", f"archive_root={tmp}/archive"],
                           cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if r.returncode != 0:
            sys.exit(f"snakemake designed failed:\n{r.stderr[-3000:]}")
        cpu: dict[str, float] = {}
        jobs: dict[str, int] = {}
        for log in Path(tmp, "results").rglob("*.log"):
            for line in log.read_text().splitlines():
                if line.startswith("TIMING "):
                    rec = json.loads(line[7:])
                    rule = rec["job"].split()[0]
                    cpu[rule] = cpu.get(rule, 0.0) + rec["cpu"]["total"]
                    jobs[rule] = jobs.get(rule, 0) + 1
    return wall, cpu, jobs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args(argv)
    print(blas_line())
    runs = [run_once() for _ in range(args.repeats)]
    walls = [r[0] for r in runs]
    med = sorted(runs, key=lambda r: r[0])[len(runs) // 2]
    print(f"snakemake designed, 2 cores: wall {statistics.median(walls):.1f} s (median of {len(walls)}; "
          f"range {min(walls):.1f}-{max(walls):.1f} s); target <= 120 s")
    print(f"{'rule':<18}{'jobs':>6}{'CPU [s]':>10}")
    for rule, c in sorted(med[1].items()):
        print(f"{rule:<18}{med[2][rule]:>6}{c:>10.1f}")
    print(f"{'all jobs':<18}{sum(med[2].values()):>6}{sum(med[1].values()):>10.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
