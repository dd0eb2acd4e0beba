"""Campaign wall time: the full and the reduced campaign through Snakemake from a clean state.

Each campaign runs in a fresh temporary directory with the repository's Snakefile and 2
cores (``snakemake --cores 2``; the workflow profile ``profiles/default`` applies), figures,
tables and the archive's manifest included, then ``snakemake --report`` builds the HTML
report. The wall time of both is measured around the commands; the jobs' own ``TIMING``
lines (``campaign.runner.job_log``) split the busy time of the jobs into

* simulation (``simulate`` + ``write``: integrating the rig, writing the trial files),
* identification (``identify``),
* interpreter start-up + imports (``startup`` + ``imports``: paid by every job),
* other work (figures, fits, tables, archive finalisation),

and what the jobs do not account for, ``wall - busy / 2``, is Snakemake's own time (DAG,
scheduling, job spawning) plus idle cores. Per-job overhead against per-trial cost, the
measurement behind ``job_unit``, is printed from the same lines.

Usage::

    python benchmarks/bench_campaign.py                          # reduced + full, job_unit sweep
    python benchmarks/bench_campaign.py --campaigns ci --units sweep,cell
    python benchmarks/bench_campaign.py --readme benchmarks/README.md   # also record the summary

Targets (issue 7, 2-core machine): full campaign <= 60 s, reduced <= 20 s. The script exits
with status 1 if a run fails; missing a target is reported, not an error.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
HEADING = "## Campaign wall time"
TARGETS = {"full": 60.0, "ci": 20.0}  # seconds, issue 7
CONFIGS = {"full": REPO / "config" / "config.yaml", "ci": REPO / "config" / "ci.yaml"}
README_HEADER = """# Benchmarks

Measurements of the campaign's cost, one script per topic in this folder (`bench_*.py`),
run together with `make bench`. They are not timed tests: numbers depend on the machine, so
each section below records the machine and library versions next to the printed summary.
Each script documents how to rerun it and how to update its section here.
"""


def run(cmd: list[str], cwd: Path) -> float:
    """Run a command, return its wall time [s]; raise with its output tail if it fails."""
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return wall


def timings(results: Path) -> list[dict]:
    """The TIMING record of every job log under ``results``."""
    out = []
    for log in sorted((results / "logs").rglob("*.log")):
        for line in log.read_text(errors="replace").splitlines():
            if line.startswith("TIMING "):
                rec = json.loads(line[len("TIMING "):])
                rec["log"] = str(log.relative_to(results))
                out.append(rec)
    return out


def trials_per_job(results: Path) -> dict[str, int]:
    """Trials each simulation job wrote (progress lines ``[i/n]`` of its log)."""
    out = {}
    for log in (results / "logs").glob("simulate_*/**/*.log"):
        n = len(re.findall(r"^\[\d+/\d+\] ", log.read_text(errors="replace"), re.M))
        out[str(log.relative_to(results))] = n
    return out


def bench_one(name: str, unit: str, cores: int) -> dict:
    """Run one campaign from clean in a temporary directory; return the measurements."""
    cfg = yaml.safe_load(CONFIGS[name].read_text())
    cfg["job_unit"] = unit
    work = Path(tempfile.mkdtemp(prefix=f"bench-{name}-{unit}-"))
    try:
        config = work / "config.yaml"
        config.write_text(yaml.safe_dump(cfg, sort_keys=False))
        base = [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(work), "--configfile", str(config)]
        dag = run(base + ["-n"], work)
        wall = run([*base[:5], "--cores", str(cores), *base[5:]], work)
        report = run(base + ["--report", str(work / "report.html")], work)
        results = work / cfg["results_root"] / cfg["campaign"]
        recs = timings(results)
        trials = trials_per_job(results)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    sim = [r for r in recs if r["job"].startswith("simulate")]
    ident = [r for r in recs if r["job"].startswith("identify")]
    busy = sum(r["total"] for r in recs)
    parts = {
        "simulation": sum(r.get("simulate", 0.0) + r.get("write", 0.0) for r in recs),
        "identification": sum(r.get("identify", 0.0) for r in recs),
        "start-up + imports": sum(r.get("startup", 0.0) + r.get("imports", 0.0) for r in recs),
    }
    parts["other work"] = busy - sum(parts.values())
    n_trials = sum(trials.values())
    per_job = [r.get("startup", 0.0) + r.get("imports", 0.0) for r in sim + ident]
    return {
        "campaign": name, "unit": unit, "cores": cores, "wall": wall, "report": report, "dag": dag,
        "jobs": len(recs), "sim_jobs": len(sim), "trials": n_trials, "busy": busy, "parts": parts,
        "snakemake": max(0.0, wall - busy / cores),
        "job_overhead": sum(per_job) / len(per_job) if per_job else float("nan"),
        "sim_per_trial": sum(r.get("simulate", 0.0) + r.get("write", 0.0) for r in sim) / max(n_trials, 1),
        "ident_per_trial": sum(r.get("identify", 0.0) for r in ident) / max(n_trials, 1),
    }


def table(rows: list[dict]) -> str:
    head = ("| campaign | job unit | trials | jobs | wall [s] | + report [s] | target [s] | simulation | "
            "identification | start-up + imports | other work | Snakemake + idle [s] |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        busy = r["busy"]
        share = {k: f"{v:.1f} s ({100 * v / busy:.0f} %)" for k, v in r["parts"].items()}
        target = TARGETS.get(r["campaign"], float("nan"))
        total = r["wall"] + r["report"]
        mark = "met" if total <= target else "missed"
        lines.append(f"| {r['campaign']} | {r['unit']} | {r['trials']} | {r['jobs']} | {r['wall']:.1f} | "
                     f"{total:.1f} | {target:.0f} ({mark}) | {share['simulation']} | {share['identification']} | "
                     f"{share['start-up + imports']} | {share['other work']} | {r['snakemake']:.1f} |")
    return "\n".join(lines)


def granularity(rows: list[dict]) -> str:
    lines = []
    for r in rows:
        lines.append(f"- {r['campaign']}, job_unit {r['unit']}: {r['sim_jobs']} simulation jobs; interpreter "
                     f"start-up + imports {r['job_overhead']:.2f} s per simulate/identify job against "
                     f"{1e3 * r['sim_per_trial']:.0f} ms simulation + {1e3 * r['ident_per_trial']:.0f} ms "
                     f"identification per trial (DAG build and dry run {r['dag']:.1f} s).")
    return "\n".join(lines)


def machine() -> str:
    from importlib.metadata import version

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"Machine: {platform.machine()}, {os.cpu_count()} CPUs, load average {load:.1f} at the end; "
            f"Python {platform.python_version()}, snakemake {version('snakemake')}, pin {version('pin')}, "
            f"campaign {version('campaign')}; {datetime.date.today().isoformat()}.")


def write_section(readme: Path, body: str) -> None:
    """Replace (or append) this script's section of ``readme``, creating the file if needed."""
    text = readme.read_text() if readme.is_file() else README_HEADER
    section = f"{HEADING}\n\n{body.rstrip()}\n"
    lines = text.splitlines(keepends=True)
    start = next((i for i, line in enumerate(lines) if line.rstrip() == HEADING), None)
    if start is None:
        text = text.rstrip("\n") + "\n\n" + section
    else:
        end = next((j for j in range(start + 1, len(lines)) if lines[j].startswith("## ")), len(lines))
        tail = "".join(lines[end:])
        text = "".join(lines[:start]) + section + ("\n" + tail if tail else "")
    tmp = readme.with_name(readme.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, readme)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--campaigns", default="ci,full", help="ci and/or full, comma-separated (default: %(default)s)")
    parser.add_argument("--units", default="sweep", help="job units to compare: sweep and/or cell (default: %(default)s)")
    parser.add_argument("--cores", type=int, default=2, help="snakemake --cores (default: %(default)s)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    rows = []
    for name in args.campaigns.split(","):
        if name not in CONFIGS:
            parser.error(f"--campaigns: unknown campaign {name!r}; expected ci or full")
        for unit in args.units.split(","):
            if unit not in ("sweep", "cell"):
                parser.error(f"--units: unknown job unit {unit!r}; expected sweep or cell")
            print(f"running campaign {name}, job_unit {unit} ...", file=sys.stderr, flush=True)
            rows.append(bench_one(name, unit, args.cores))
    body = "\n\n".join([
        f"Each campaign from a clean temporary directory with `snakemake --cores {args.cores}` (profile "
        "`profiles/default`), figures, tables and the archive manifest included; `+ report` adds "
        "`snakemake --report`. The shares split the jobs' busy time (sum over jobs, from their `TIMING` log "
        "lines); `Snakemake + idle` is wall time not covered by busy jobs (`wall - busy / cores`).",
        table(rows),
        "Per-job overhead against per-trial cost (the measurement behind `job_unit`):\n\n" + granularity(rows),
        machine() + " Rerun: `.venv/bin/python benchmarks/bench_campaign.py --readme benchmarks/README.md`.",
    ])
    print(body)
    if args.readme:
        write_section(args.readme, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
