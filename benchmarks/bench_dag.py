"""Planning time against the number of trials: ``snakemake -n`` of campaigns of 1,000 to 108,000 trials.

The full campaign's configuration (``config/config.yaml``: both bases, 3 configurations x 3
gain sets each) with more speeds: ``trials = 18 cells x speeds x repeats`` at 2 repeats, the
speeds 0.100, 0.101, ... m/s (distinct at the trial path's 3 decimals, within the
pendulum's reach). Each size is planned from an empty folder (nothing simulated, so every
job is planned) with the repository's Snakefile; the wall time and the CPU time of the dry
run (Snakemake and everything it starts) are taken, the median of ``--repeats`` runs.

``--before DIR`` plans the same campaigns with the workflow of another source tree (e.g. a
``git worktree`` of the commit before a change), alternating with this one in the same run,
up to ``--before-max`` trials: there every trial file was a declared output of its sweep job
and an input downstream, and planning grew with the square of the trials.

Usage::

    python benchmarks/bench_dag.py                                   # this tree, 3 runs per size
    python benchmarks/bench_dag.py --before /tmp/before --before-max 21600
    python benchmarks/bench_dag.py --readme benchmarks/out/summary.md

Targets: the 21,600-trial campaign (600 speeds) plans in at most 6 s, the 100,008-trial one
in at most 30 s, and the time per trial does not grow with the trials (the table gives the
least-squares line through the points). Missing a target is reported, not an error.
"""

from __future__ import annotations

import os

# one BLAS thread, set before numpy loads (a dry run loads numpy for the configuration checks)
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

import yaml

from campaign.bench.common import blas_line, run_command
from campaign.core.yamlfile import read_yaml

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
HEADING = "## Planning"
CELLS = 18            # the full campaign: 2 bases x 3 configurations x 3 gain sets
REPEATS = 2
SIZES = (1008, 2016, 5004, 10008, 21600, 50004, 100008, 108000)
TARGETS = {21600: 6.0, 100008: 30.0}


def campaign_config(trials: int) -> dict:
    """The full campaign's configuration with ``trials / (18 x 2)`` speeds."""
    cfg = read_yaml(REPO / "config" / "config.yaml")
    n = trials // (CELLS * REPEATS)
    cfg.update(campaign=f"plan{trials}", speeds=[round(0.1 + 0.001 * i, 3) for i in range(n)], repeats=REPEATS,
               figures={})
    return cfg


def dry_run(tree: Path, trials: int) -> tuple[float, float, int]:
    """Plan one campaign with the workflow of ``tree`` in an empty folder: (wall s, CPU s, jobs)."""
    work = Path(tempfile.mkdtemp(prefix=f"bench-dag-{trials}-"))
    try:
        config = work / "config.yaml"
        config.write_text(yaml.safe_dump(campaign_config(trials), sort_keys=False))
        cmd = [SNAKEMAKE, "-s", str(tree / "Snakefile"), "--directory", str(work), "-n", "--quiet", "rules",
               "--configfile", str(config)]
        env = {**os.environ, "PYTHONPATH": str(tree)}
        wall, cpu, stdout = run_command(cmd, cwd=work, env=env)
        jobs = sum(1 for line in stdout.splitlines() if line.strip() and line.split()[-1].isdigit()
                   and not line.startswith(("total", "job")))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return wall, cpu, jobs


def line_fit(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least-squares (intercept, slope) of ys against xs."""
    mx, my = statistics.fmean(xs), statistics.fmean(ys)
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum((x - mx) ** 2 for x in xs)
    return my - slope * mx, slope


def measure(sizes, repeats: int, before: Path | None, before_max: int) -> list[dict]:
    rows = []
    for trials in sizes:
        runs = {"after": []}
        if before is not None and trials <= before_max:
            runs["before"] = []
        for _ in range(repeats):
            for label in runs:   # alternating, so a change in the machine's load hits both alike
                runs[label].append(dry_run(REPO if label == "after" else before, trials))
        row = {"trials": trials, "speeds": trials // (CELLS * REPEATS)}
        for label, got in runs.items():
            row[label] = {"wall": statistics.median(r[0] for r in got), "cpu": statistics.median(r[1] for r in got),
                          "walls": [r[0] for r in got], "jobs": got[0][2]}
        rows.append(row)
        print(f"{trials} trials: " + ", ".join(f"{k} {v['wall']:.1f} s wall, {v['cpu']:.1f} s CPU"
                                               for k, v in row.items() if isinstance(v, dict)),
              file=sys.stderr, flush=True)
    return rows


def table(rows: list[dict], before: bool) -> str:
    head = "| trials | speeds | jobs | wall [s] | CPU [s] | CPU per 1000 trials [s] | target [s] |"
    if before:
        head += " before: wall [s] | before: CPU [s] |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        a = r["after"]
        target = TARGETS.get(r["trials"])
        verdict = "" if target is None else f"{target:.0f} ({'met' if a['wall'] <= target else 'missed'})"
        line = (f"| {r['trials']:,} | {r['speeds']} | {a['jobs']} | {a['wall']:.2f} "
                f"({min(a['walls']):.2f}-{max(a['walls']):.2f}) | {a['cpu']:.2f} | "
                f"{1e3 * a['cpu'] / r['trials']:.3f} | {verdict} |")
        if before:
            b = r.get("before")
            line += (f" {b['wall']:.1f} | {b['cpu']:.1f} |" if b else " - | - |")
        lines.append(line)
    xs = [r["trials"] for r in rows]
    a0, a1 = line_fit(xs, [r["after"]["cpu"] for r in rows])
    fit = (f"Least-squares line through the CPU times: {a0:.2f} s + {1e3 * a1:.4f} s per 1000 trials "
           f"(the intercept is Snakemake's start-up, the configuration checks and the jobs' DAG).")
    old = [r for r in rows if "before" in r]
    if len(old) >= 3:
        # a quadratic law: the time per trial grows with the trials
        per = ", ".join(f"{1e3 * r['before']['cpu'] / r['trials']:.2f}" for r in old)
        sizes = ", ".join(f"{r['trials']:,}" for r in old)
        fit += f" Before: CPU per 1000 trials {per} s at {sizes} trials."
    return "\n".join(lines) + "\n\n" + fit


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default=",".join(map(str, SIZES)),
                        help="campaign sizes in trials, each a multiple of 36 (default: %(default)s)")
    parser.add_argument("--repeats", type=int, default=3, help="dry runs per size; the median is shown (default 3)")
    parser.add_argument("--before", type=Path, help="another source tree to plan the same campaigns with")
    parser.add_argument("--before-max", type=int, default=21600,
                        help="largest campaign planned with --before (default %(default)s)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    print(blas_line())
    sizes = [int(s) for s in args.sizes.split(",")]
    bad = [s for s in sizes if s % (CELLS * REPEATS)]
    if bad:
        parser.error(f"--sizes: {bad} are not multiples of {CELLS * REPEATS} (18 cells x 2 repeats)")
    try:
        rows = measure(sizes, max(1, args.repeats), args.before, args.before_max)
    except RuntimeError as exc:
        print(f"bench_dag: {exc}", file=sys.stderr)
        return 1
    body = (f"`snakemake -n` of the full campaign's configuration with more speeds (18 cells x speeds x "
            f"{REPEATS} repeats), from an empty folder, median of {args.repeats} runs (range in brackets); CPU is "
            "Snakemake's and everything it starts (user + system)."
            + (f" `before`: the workflow of `{args.before}`, planned alternately in the same run." if args.before
               else "") + "\n\n" + table(rows, args.before is not None) + "\n\nRerun: `.venv/bin/python "
            "benchmarks/bench_dag.py" + (" --before <old tree>" if args.before else "") + "`.")
    print(body)
    if args.readme:
        from campaign.bench import write_section

        write_section(args.readme, HEADING, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
