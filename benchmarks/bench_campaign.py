"""Campaign wall time: the full and the reduced campaign through Snakemake from a clean state.

Each campaign runs in a fresh temporary directory with the repository's Snakefile and 2
cores (``snakemake --cores 2``; the workflow profile ``profiles/default`` applies), figures,
tables and the archive's manifest included, then ``snakemake --report`` builds the HTML
report. The wall time of both is measured around the commands; the jobs' own ``TIMING``
lines (``campaign.pipeline.joblog.job_log``; a job that makes several products writes one per
product, ``part_of`` the job) split the CPU time of the run by stage:

* simulation (``simulate`` + ``write``: integrating the rig, writing the trial files),
* identification (``identify``), the lambda fits (``fit``), the tables (``table``), the
  figures (``figure``), the planner's maps (``maps``), the calibration report (``report``),
  the archive's finalisation (``finalize``),
* interpreter start-up + imports (``startup`` + ``imports``: paid by every job),
* other job work (the rest of the jobs' CPU),

measured in CPU seconds (contention from other work on the machine stretches wall times but
hardly CPU times); the CPU of the whole run not spent in jobs is Snakemake's own (DAG,
scheduling, job spawning). Per-job overhead against per-trial cost, the measurement behind
``job_unit``, is printed from the same lines.

``--before REF`` runs the same campaigns with the workflow and package of another version:
a git ref of this repository (exported with ``git archive`` into a temporary folder) or the
folder of another source tree, alternating with this one run by run, so that old and new
are measured side by side under the same load. A second table then gives the CPU per stage
as the jobs' ``TIMING`` lines split it (:data:`STAGE_ROWS`: simulation and trial writing per
base, identification per base, the planner's maps, the figures, each with its job's imports,
and start-up + imports over all jobs), old and new side by side.

Usage::

    python benchmarks/bench_campaign.py                          # reduced + full, job_unit sweep
    python benchmarks/bench_campaign.py --campaigns ci --units sweep,cell
    python benchmarks/bench_campaign.py --readme benchmarks/out/summary.md   # also record the summary
    python benchmarks/bench_campaign.py --repeats 3              # each run 3 times, the median shown
    python benchmarks/bench_campaign.py --repeats 3 --before main   # a git ref, or a source tree's folder

With ``--repeats N`` each campaign runs N times, one after the other; the table shows the run
with the median wall time (its CPU split) and the range of the N wall times, and the split
by stage gives the median of each stage's CPU over the N runs: on a machine shared with
other work one run's wall and CPU times move by 10 % and more.

Targets (2-core machine): full campaign with its report <= 25 s, reduced <= 10 s. The
script exits with status 1 if a run fails; missing a target is reported, not an error.
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import atexit
import datetime
import io
import json
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import yaml

from campaign.bench.common import BASELINE_AT_TARGETS, XARRAY_WRITE_AT_TARGETS, blas_line, run_command
from campaign.core.yamlfile import read_yaml

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
HEADING = "## Campaign wall time"
TARGETS = {"full": 25.0, "ci": 10.0}  # seconds with the report, 2-core machine
#: the CPU split by stage: the TIMING keys each stage sums
STAGES = {"simulation": ("simulate", "write"), "identification": ("identify",), "fits": ("fit",),
          "tables": ("table",), "figures": ("figure",), "maps": ("maps",), "calibration report": ("report",),
          "finalize": ("finalize",), "start-up + imports": ("startup", "imports")}
CONFIGS = {"full": REPO / "config" / "config.yaml", "ci": REPO / "config" / "tests" / "ci.yaml"}
#: the rows of the per-stage table: the TIMING keys each sums over the records (jobs and their
#: products) whose job name starts with one of the prefixes ("": every record)
STAGE_ROWS = {
    "simulation, fixed": ("simulate_fixed", ("simulate",)),
    "simulation, flexible": ("simulate_flexible", ("simulate",)),
    "writing trial files, fixed": ("simulate_fixed", ("write",)),
    "writing trial files, flexible": ("simulate_flexible", ("write",)),
    "identification, fixed": ("identify_fixed", ("identify",)),
    "identification, flexible": ("identify_flexible", ("identify",)),
    "planner maps": ("plan_maps", ("maps", "figure")),
    "planner maps: of which drawing the two figures": ("plan_maps", ("figure",)),
    "planner maps: imports": ("plan_maps", ("startup", "imports")),
    "figures 4-9": (("fig4", "fig5", "fig6", "fig7", "fig8", "fig9"), ("figure",)),
    "figures 4-9: imports (jobs drawing figures only)": (("fig5", "fig9", "model_figures"), ("startup", "imports")),
    "start-up + imports, all jobs": ("", ("startup", "imports")),
}


def run(cmd: list[str], cwd: Path, *, tree: Path = REPO) -> tuple[float, float]:
    """Run a command with the package of ``tree`` first on the path; return its wall time and
    the CPU time of it and all its descendants [s].

    Raises with its output tail if it fails.
    """
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(tree), os.environ.get("PYTHONPATH")) if p)}
    wall, cpu, _ = run_command(cmd, cwd=cwd, env=env)
    return wall, cpu


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


def machine_probe(repeats: int = 3) -> dict[str, float]:
    """How fast the machine runs now: the write references
    (:func:`campaign.bench.write_probe`: one NetCDF4 group through xarray/h5netcdf, about
    35 ms where the targets were set, and through plain h5py, about 3 ms) and its naive
    RK4 baseline (0.5 s of fixed-base trial at 0.1 ms steps; about 350 ms there for the
    original version, which does less per step than ours), median wall times [s]."""
    from campaign.bench import naive_rk4, write_probe
    from campaign.scene.description import make_scene

    scene = make_scene(base="fixed", config=1, gain="zero", speed=1.5)
    naive_rk4(scene)   # warm-up (imports, model), as trial_cost does
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        naive_rk4(scene, duration=0.5)
        times.append(time.perf_counter() - t0)
    return {"naive": statistics.median(times), **write_probe()}


def stage_split(recs: list[dict], cpu: float) -> dict[str, float]:
    """CPU seconds of each stage (:data:`STAGES`), the rest of the jobs' work and Snakemake's own."""
    jobs_cpu = sum(r["cpu"]["total"] for r in recs if "part_of" not in r)
    parts = {stage: 0.0 for stage in STAGES}
    for r in recs:
        for stage, keys in STAGES.items():
            for key in keys:
                # one job per product drew the planner's maps under "figure"
                part = "maps" if key == "figure" and r["job"] == "plan_maps" else stage
                parts[part] += r["cpu"].get(key, 0.0)
    parts["other job work"] = jobs_cpu - sum(parts.values())
    parts["Snakemake"] = max(0.0, cpu - jobs_cpu)
    return parts


def stage_rows(recs: list[dict]) -> dict[str, float]:
    """CPU seconds of each row of :data:`STAGE_ROWS` (the split by stage and base)."""
    out = {}
    for row, (prefix, keys) in STAGE_ROWS.items():
        prefixes = (prefix,) if isinstance(prefix, str) else prefix
        out[row] = sum(r["cpu"].get(k, 0.0) for r in recs if r["job"].split()[0].startswith(prefixes) for k in keys)
    return out


def bench_one(name: str, unit: str, cores: int, tree: Path = REPO) -> dict:
    """Run one campaign from clean in a temporary directory with the workflow of ``tree``;
    return the measurements."""
    probe_before = machine_probe()
    cfg = read_yaml(CONFIGS[name])
    cfg["job_unit"] = unit
    work = Path(tempfile.mkdtemp(prefix=f"bench-{name}-{unit}-"))
    try:
        config = work / "config.yaml"
        config.write_text(yaml.safe_dump(cfg, sort_keys=False))
        base = [SNAKEMAKE, "-s", str(tree / "Snakefile"), "--directory", str(work), "--configfile", str(config)]
        dag, _ = run(base + ["-n"], work, tree=tree)
        wall, cpu = run([*base[:5], "--cores", str(cores), *base[5:]], work, tree=tree)
        report, report_cpu = run(base + ["--report", str(work / "report.html")], work, tree=tree)
        results = work / cfg["results_root"] / cfg["campaign"]
        recs = timings(results)
        trials = trials_per_job(results)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    # the machine's speed drifts during a run: the probes before and after it, averaged
    probe_after = machine_probe()
    probe = {k: 0.5 * (probe_before[k] + probe_after[k]) for k in probe_before}
    jobs = [r for r in recs if "part_of" not in r]
    sim = [r for r in recs if r["job"].startswith("simulate")]
    ident = [r for r in recs if r["job"].startswith("identify")]
    parts = stage_split(recs, cpu)
    n_trials = sum(trials.values())
    per_job = [r["cpu"].get("startup", 0.0) + r["cpu"].get("imports", 0.0) for r in jobs]
    return {
        "campaign": name, "unit": unit, "cores": cores, "wall": wall, "report": report, "dag": dag, "probe": probe,
        "probes": (probe_before, probe_after), "tree": "this" if tree == REPO else "before",
        "cpu": cpu, "report_cpu": report_cpu, "jobs": len(jobs), "sim_jobs": len(sim), "trials": n_trials,
        "parts": parts, "stages": stage_rows(recs), "load": os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan"),
        "job_overhead": sum(per_job) / len(per_job) if per_job else float("nan"),
        "sim_per_trial": {b: _per_trial(sim, trials, b, ("simulate", "write")) for b in ("fixed", "flexible")},
        "ident_per_trial": {b: _per_trial(ident, trials, b, ("identify",)) for b in ("fixed", "flexible")},
        "trials_by_base": {b: sum(v for k, v in trials.items() if f"_{b}/" in k) for b in ("fixed", "flexible")},
    }


def _per_trial(recs: list[dict], trials: dict[str, int], base: str, stages: tuple[str, ...]) -> float:
    """CPU seconds per trial of ``stages`` over the jobs of one base."""
    mine = [r for r in recs if r["job"].split()[0].endswith(base)]
    n = sum(v for k, v in trials.items() if f"_{base}/" in k)
    cpu = sum(r["cpu"].get(s, 0.0) for r in mine for s in stages)
    return cpu / n if n else float("nan")


def table(rows: list[dict]) -> str:
    head = ("| campaign | tree | job unit | trials | jobs | wall [s] | + report [s] | xarray write probe [ms] | "
            "+ report scaled by the write reference [s] | target [s] | naive baseline [ms] | load | CPU [s] | "
            "CPU / cores [s] |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        cpu = r["cpu"]
        target = TARGETS.get(r["campaign"], float("nan"))
        total = r["wall"] + r["report"]
        walls = r.get("walls", [r["wall"]])
        wall = f"{r['wall']:.1f}" + (f" ({min(walls):.1f}-{max(walls):.1f}, median of {len(walls)})"
                                     if len(walls) > 1 else "")
        px, pb, pa = (r["probe"]["xarray"], r["probes"][0]["xarray"], r["probes"][1]["xarray"])
        scaled = total * XARRAY_WRITE_AT_TARGETS / px
        verdict = ("met" if total <= target else
                   "missed here; met scaled by the write reference" if scaled <= target else "missed")
        lines.append(f"| {r['campaign']} | {r['tree']} | {r['unit']} | {r['trials']} | {r['jobs']} | {wall} | "
                     f"{total:.1f} | {1e3 * px:.1f} ({1e3 * pb:.1f} / {1e3 * pa:.1f}) | "
                     f"{scaled:.1f} | {target:.0f} ({verdict}) | {1e3 * r['probe']['naive']:.0f} | {r['load']:.1f} | "
                     f"{cpu:.1f} | {cpu / r['cores']:.1f} |")
    return "\n".join(lines)


def split_table(rows: list[dict]) -> str:
    """The CPU split by stage of each campaign and tree, the median of each stage over the runs [s]."""
    names = list(rows[0]["split"])
    head = "| campaign | tree | " + " | ".join(names) + " | total |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        split = r["split"]
        lines.append(f"| {r['campaign']} | {r['tree']} | " + " | ".join(f"{split[k]:.1f}" for k in names)
                     + f" | {sum(split.values()):.1f} |")
    return "\n".join(lines)


def stages_table(rows: list[dict]) -> str:
    """:data:`STAGE_ROWS` down, one column per campaign and tree: the median CPU [s] of each
    stage over the runs, per trial [ms] for the stages of one base."""
    head = "| stage | " + " | ".join(f"{r['campaign']}, {r['tree']}" for r in rows) + " |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for stage in STAGE_ROWS:
        cells = []
        for r in rows:
            cpu = r["stage_median"][stage]
            base = next((b for b in ("fixed", "flexible") if stage.endswith(f", {b}")), None)
            n = r["trials_by_base"].get(base, 0) if base else 0
            cells.append(f"{cpu:.2f}" + (f" ({1e3 * cpu / n:.0f} ms)" if n else ""))
        lines.append(f"| {stage} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def before_tree(ref: str, parser: argparse.ArgumentParser) -> Path:
    """The source tree of ``--before``: a folder as it is, or a git ref of this repository
    exported into a temporary folder (removed when the script ends)."""
    if Path(ref).is_dir():
        return Path(ref).resolve()
    git = ["git", "-C", str(REPO)]
    if subprocess.run([*git, "rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}"], capture_output=True).returncode:
        parser.error(f"--before {ref}: neither a folder nor a git ref of {REPO}")
    tree = Path(tempfile.mkdtemp(prefix="bench-before-"))
    atexit.register(shutil.rmtree, tree, ignore_errors=True)
    archive = subprocess.run([*git, "archive", "--format=tar", ref], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(tree, filter="data")
    return tree


def granularity(rows: list[dict]) -> str:
    lines = []
    for r in rows:
        sim = ", ".join(f"{b} {1e3 * v:.0f} ms" for b, v in r["sim_per_trial"].items() if v == v)
        ident = ", ".join(f"{b} {1e3 * v:.0f} ms" for b, v in r["ident_per_trial"].items() if v == v)
        lines.append(f"- {r['campaign']} ({r['tree']}), job_unit {r['unit']}: {r['sim_jobs']} simulation jobs, "
                     f"{r['jobs']} jobs in all. Interpreter start-up + imports: {r['job_overhead']:.2f} s CPU per job; "
                     f"per trial: simulation + writing {sim}; identification {ident} (CPU). Building the DAG "
                     f"(dry run): {r['dag']:.1f} s.")
    return "\n".join(lines)


def machine() -> str:
    from importlib.metadata import version

    return (f"Machine: {platform.machine()}, {os.cpu_count()} CPUs; "
            f"Python {platform.python_version()}, snakemake {version('snakemake')}, pin {version('pin')}, "
            f"campaign {version('campaign')}; {datetime.date.today().isoformat()}.")


def write_section(readme: Path, body: str) -> None:
    """Replace (or append) this script's section of ``readme`` (campaign.bench.write_section)."""
    from campaign.bench import write_section as _write_section

    _write_section(readme, HEADING, body)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--campaigns", default="ci,full", help="ci and/or full, comma-separated (default: %(default)s)")
    parser.add_argument("--units", default="sweep", help="job units to compare: sweep and/or cell (default: %(default)s)")
    parser.add_argument("--cores", type=int, default=2, help="snakemake --cores (default: %(default)s)")
    parser.add_argument("--repeats", type=int, default=1,
                        help="runs of each campaign; the median wall time is shown (default: %(default)s)")
    parser.add_argument("--before", metavar="REF",
                        help="another version to run the same campaigns with, alternating with this one: a git ref "
                             "of this repository or the folder of a source tree (its Snakefile and package)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    print(blas_line())
    before = before_tree(args.before, parser) if args.before else None
    trees = [before, REPO] if before else [REPO]
    rows = []
    for name in args.campaigns.split(","):
        if name not in CONFIGS:
            parser.error(f"--campaigns: unknown campaign {name!r}; expected ci or full")
        for unit in args.units.split(","):
            if unit not in ("sweep", "cell"):
                parser.error(f"--units: unknown job unit {unit!r}; expected sweep or cell")
            print(f"running campaign {name}, job_unit {unit} ...", file=sys.stderr, flush=True)
            try:
                # old and new alternating, run by run, so that a change in the machine's load hits both
                got: dict[Path, list[dict]] = {tree: [] for tree in trees}
                for _ in range(max(1, args.repeats)):
                    for tree in trees:
                        got[tree].append(bench_one(name, unit, args.cores, tree))
            except RuntimeError as exc:
                print(f"bench_campaign: {exc}", file=sys.stderr)
                return 1
            for runs in got.values():
                runs = sorted(runs, key=lambda r: r["wall"])
                median = runs[(len(runs) - 1) // 2]
                split = {k: statistics.median(r["parts"][k] for r in runs) for k in median["parts"]}
                stages = {k: statistics.median(r["stages"][k] for r in runs) for k in median["stages"]}
                rows.append({**median, "walls": [r["wall"] for r in runs], "split": split, "stage_median": stages})
    body = "\n\n".join([
        f"Each campaign from a clean temporary directory with `snakemake --cores {args.cores}` (profile "
        "`profiles/default`), figures, tables and the archive manifest included; `+ report` adds "
        "`snakemake --report`. `CPU` is the CPU time of Snakemake and all its jobs (user + system, from "
        "`getrusage`); the table below splits it by stage. `CPU / cores` is what the run costs on an otherwise idle machine if both cores stay busy; "
        "`load` is the machine's 1-minute load average when the run ended (other work on the machine "
        "stretches the wall time, not the CPU time). `xarray write probe` is the machine-speed reference of the rig's targets, "
        "one NetCDF4 group of a few channels written through xarray/h5netcdf (`campaign.bench.write_probe`; "
        f"about {XARRAY_WRITE_AT_TARGETS * 1e3:.0f} ms where the targets were set), the mean of its median just "
        "before and just after the run (in brackets); `scaled` is the run with its report times "
        f"{XARRAY_WRITE_AT_TARGETS * 1e3:.0f} ms / the probe, what it would take on that machine. The scaling suits "
        "Python-bound work and the rest (process start-up, two jobs sharing the cores) only roughly. "
        "`naive baseline` is the straightforward RK4 (0.5 s of fixed-base trial at 0.1 ms steps) as "
        f"`campaign.bench.naive_rk4` implements it; it is not used for scaling, since ours does more per step "
        f"than the one the targets were set against (about {BASELINE_AT_TARGETS * 1e3:.0f} ms there).",
        table(rows),
        "CPU by stage [s] (the jobs' `TIMING` lines; `other job work` is the rest of the jobs' CPU, `Snakemake` "
        "the CPU no job spent), the median of each over the runs"
        + (f"; `before`: the workflow and package of `{args.before}`" if args.before else "") + ":\n\n"
        + split_table(rows),
        "CPU by stage and base [s], the median of each over the runs, from the jobs' `TIMING` lines (per trial in "
        "brackets):\n\n" + stages_table(rows),
        "Per-job overhead against per-trial cost (the measurement behind `job_unit`):\n\n" + granularity(rows),
        machine() + " Rerun: `.venv/bin/python benchmarks/bench_campaign.py"
        + (f" --repeats {args.repeats}" if args.repeats > 1 else "") + (f" --before {args.before}" if args.before else "")
        + " --readme benchmarks/out/summary.md`.",
    ])
    print(body)
    if args.readme:
        write_section(args.readme, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
