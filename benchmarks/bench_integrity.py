"""What the archive's integrity checks add to a reader: the manifest check of each trial a
reader opens in a finalized folder (``campaign.archive.check_listed_digests``) and the
start-up check of a reused archive (``campaign.pipeline.paths.check_manifest``), on the
committed reference archive, its files in the page cache as a reader finds them.

Usage::

    python benchmarks/bench_integrity.py               # medians of 7 passes

Targets: the manifest check at most a tenth of an identification (30-60 ms a trial), the
reuse check of the reference archive under 0.5 s. Missing one exits with status 1.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import statistics
import sys
import time
from pathlib import Path

from campaign.archive import check_listed_digests
from campaign.bench.common import blas_line
from campaign.pipeline.paths import check_manifest

REFERENCE = Path(__file__).resolve().parents[1] / "archive" / "reference"


def _median_seconds(fn, passes: int) -> float:
    fn()                                    # the files in the page cache
    times = []
    for _ in range(passes):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--passes", type=int, default=7, help="timed passes of each check (default 7)")
    args = parser.parse_args(argv)
    print(blas_line())
    trials = sorted(REFERENCE.rglob("*.nc"))
    size_mb = sum(p.stat().st_size for p in trials) / 1e6
    per_trial = _median_seconds(lambda: check_listed_digests(trials), args.passes) / len(trials)
    reuse = _median_seconds(lambda: check_manifest(REFERENCE, [str(p) for p in trials]), args.passes)
    rows = [("manifest check per trial read", f"{1e3 * per_trial:.2f} ms", "<= 3 ms", per_trial <= 0.003),
            (f"reuse check of the reference archive ({len(trials)} trials, {size_mb:.1f} MB)",
             f"{1e3 * reuse:.0f} ms", "< 500 ms", reuse < 0.5)]
    print("| check | median | target | met |\n|---|---|---|---|")
    for name, value, target, met in rows:
        print(f"| {name} | {value} | {target} | {'yes' if met else 'MISSED'} |")
    return 0 if all(r[3] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
