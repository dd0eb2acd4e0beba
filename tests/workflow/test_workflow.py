"""End-to-end tests of the Snakemake workflow: the reduced campaign (config/tests/ci.yaml) runs
through Snakemake in a temporary directory and its tables hold physically sensible numbers.

Also: ``snakemake --lint`` has no findings, a bad configuration stops with a message naming
the key, a rerun has nothing to do, editing one gain set reruns only what depends on it, a
target runs only the jobs it needs, a single trial file can be asked for, an archive is
re-analysed without simulating into a results folder of its own (a simulated campaign's
results stay byte-identical), the archive's finalisation refuses a trial changed since its
job wrote it, and a run killed mid-way completes on the rerun with an intact archive.

Nothing is written into the repository: every run uses ``--directory <tmp>`` with the
repository's Snakefile (whose ``profiles/default`` Snakemake picks up by itself).
"""

from __future__ import annotations

import csv
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from campaign.core.vocabulary import trial_relpath
from campaign.identify.table import read_identification
from campaign.model.paper import gain_counts
from campaign.pipeline.paths import cell_trials

import snakemake_forks

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
SNAKEFILE = REPO / "Snakefile"
CI_CONFIG = REPO / "config" / "tests" / "ci.yaml"
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
TIMEOUT = 900


def snakemake(workdir: Path, *args: str, config: Path | None = CI_CONFIG, check: bool = True,
              timeout: float = TIMEOUT, own_process: bool = False) -> subprocess.CompletedProcess:
    """Run the repository's workflow in ``workdir`` (targets first, then the options): the
    ``snakemake`` command through :mod:`snakemake_forks` (its entry point, without loading
    Snakemake again), or with ``own_process`` as a process of its own."""
    cmd = [SNAKEMAKE, "-s", str(SNAKEFILE), "--directory", str(workdir), *args]
    if config is not None:
        cmd += ["--configfile", str(config)]
    if own_process:
        proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=timeout)
    else:
        proc = snakemake_forks.run(cmd[1:], cwd=workdir, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake {' '.join(args)} failed ({proc.returncode}):\n"
                             f"{proc.stdout[-4000:]}\n{proc.stderr[-6000:]}")
    return proc


def planned_jobs(output: str) -> list[tuple[str, dict]]:
    """(rule, wildcards) of every job a dry run lists."""
    jobs = []
    for block in re.split(r"\n(?=(?:local)?rule \w+:\n)", "\n" + output):
        m = re.match(r"\n?(?:local)?rule (\w+):\n", block)
        if not m:
            continue
        wc = re.search(r"^\s+wildcards: (.*)$", block, re.M)
        wildcards = dict(kv.split("=", 1) for kv in wc.group(1).split(", ")) if wc else {}
        jobs.append((m.group(1), wildcards))
    return jobs


def write_config(path: Path, **changes) -> Path:
    """config/tests/ci.yaml with top-level keys replaced."""
    cfg = yaml.safe_load(CI_CONFIG.read_text())
    cfg.update(changes)
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return path


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def num(value: str) -> float:
    return float(value) if value not in ("", None) else math.nan


# ------------------------------------------------------------------------------------------
# the reduced campaign, run once per test run (tests/workflow/conftest.py: ci_campaign; read only, a test
# that writes into it works on ci_campaign_copy)
# ------------------------------------------------------------------------------------------
@pytest.fixture
def ci_run(ci_campaign) -> Path:
    return ci_campaign


def test_reduced_campaign_makes_every_product(ci_run):
    results = ci_run / "results" / "ci"
    for n in range(4, 10):
        png, pdf = results / "figures" / f"fig{n}.png", results / "figures" / f"fig{n}.pdf"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", png
        assert pdf.read_bytes()[:5] == b"%PDF-", pdf
        assert png.stat().st_size > 20_000, f"{png} is suspiciously small"
    for name in ("plan_workspace", "plan_directions"):   # the impact planner's maps
        png, pdf = results / "figures" / f"{name}.png", results / "figures" / f"{name}.pdf"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000, png
        assert pdf.read_bytes()[:5] == b"%PDF-", pdf
    for t in (2, 3, 4):
        assert (results / "tables" / f"table{t}.md").read_text().startswith(f"### Table {t}")
    for log in (results / "logs").rglob("*.log"):
        assert "TIMING" in log.read_text(), f"{log} has no TIMING line (job did not finish cleanly)"


def test_identification_is_physical(ci_run):
    rows = read_identification(sorted((ci_run / "results" / "ci" / "identify").rglob("*.csv")))
    assert len(rows) == 18 + 8  # ci.yaml: fixed 3 configs x 3 gains x 2 speeds; flexible 2 x 2 x 2
    used = [r for r in rows if not r["excluded"]]
    assert len(used) >= 0.9 * len(rows), [r["reason"] for r in rows if r["excluded"]]
    for r in used:
        assert 0.0 < r["e"] < 1.0, r
        assert math.isfinite(r["m_eff"]) and r["m_eff"] > 0.0, r
        assert r["v_b"] > 0.0 and r["v_b_post"] < r["v_b"], r  # the hammer slows down along n


def test_table2_bounds(ci_run):
    rows = read_csv(ci_run / "results" / "ci" / "tables" / "table2.csv")
    assert [int(r["config"]) for r in rows] == [1, 2, 3]
    for r in rows:
        m1, m2, m3 = num(r["m1"]), num(r["m2"]), num(r["m3"])
        assert all(math.isfinite(x) and x > 0 for x in (m1, m2, m3)), r
        # joint friction adds to the link dynamics, the high-gain servo adds more (paper, Table 2)
        assert m2 > m1 and m3 > m2, r
        # the model's lambda = 0 effective mass reproduces the paper's m1 within 2 %
        assert abs(num(r["m1"]) / num(r["m1_paper"]) - 1.0) < 0.02, r
    by_config = {int(r["config"]): num(r["m2"]) for r in rows}
    assert by_config[3] < by_config[1] < by_config[2]  # folded < intermediate < stretched


def test_table3_bounds(ci_run):
    rows = read_csv(ci_run / "results" / "ci" / "tables" / "table3.csv")
    assert [r["component"] for r in rows] == ["lambda_1", "lambda_2", "lambda_3"]
    for r in rows:
        for cls in ("zero_low", "high"):
            lam = num(r[cls])
            assert math.isfinite(lam) and lam >= 0.0, r
    lam3 = {cls: num(rows[2][cls]) for cls in ("zero_low", "high")}
    assert rows[2]["zero_low_identifiable"] == "yes" and rows[2]["high_identifiable"] == "yes"
    assert 0.0 < lam3["zero_low"] < lam3["high"]  # the servo raises the Virtual Rotor Inertia


def test_table4_bounds(ci_run):
    rows = read_csv(ci_run / "results" / "ci" / "tables" / "table4.csv")
    cells = {(int(r["config"]), r["gain"]): r for r in rows}
    assert set(cells) == {(1, "low"), (1, "high"), (2, "low"), (2, "high")}
    for r in rows:
        pred, ident = num(r["predicted"]), num(r["identified"])
        assert math.isfinite(pred) and pred > 0 and math.isfinite(ident) and ident > 0, r
        assert abs(pred / ident - 1.0) < 0.5, r  # eq 8 with the fitted lambda predicts the flexible m*
    for c in (1, 2):
        assert num(cells[(c, "high")]["identified"]) > num(cells[(c, "low")]["identified"])


def test_archive_is_finalized_and_intact(ci_run):
    from campaign.archive import verify

    archive = ci_run / "archive" / "ci"
    assert verify(archive) == []
    assert len(read_csv(archive / "index.csv")) == 26


def test_rerun_has_nothing_to_do(ci_run):
    out = snakemake(ci_run, "-n")
    assert "Nothing to be done" in out.stdout + out.stderr


def test_report_builds(ci_run, tmp_path):
    """The report groups its results as the campaign is, shows the tables and calibration
    notes as HTML (rendered inline, not download links) and holds every figure's PDF."""
    import json

    report = tmp_path / "report.html"
    snakemake(ci_run, "--report", str(report))
    text = report.read_text(errors="replace")
    assert report.stat().st_size > 100_000 and "Table 2" in text and "Figure 9" in text
    categories = json.loads(re.search(r"var categories = (\{.*?\});\n", text).group(1))
    assert set(categories) == {"Fixed base", "Flexible base", "Virtual rotor inertia (lambda)", "Calibration",
                               "Impact planner"}
    items = {Path(p).name for sub in categories.values() for files in sub.values() for p in files}
    assert {"table2.html", "table3.html", "table4.html", "calibration.html"} <= items
    assert {f"fig{i}.pdf" for i in range(4, 10)} | {f"fig{i}.png" for i in range(4, 10)} <= items
    assert {"plan_workspace.pdf", "plan_directions.pdf"} <= items
    assert not any(name.endswith((".csv", ".md")) for name in items)
    table = (ci_run / "results" / "ci" / "tables" / "table2.html").read_text()
    assert table.count("<tr>") == 1 + 3 and "<th>Config</th>" in table  # header + configurations 1-3


def test_editing_one_gain_reruns_only_its_dependents(ci_run, tmp_path):
    edited = write_config(tmp_path / "edited.yaml", gain_counts={"high": {"P": 400000}})
    out = snakemake(ci_run, "-n", config=edited)
    jobs = planned_jobs(out.stdout + out.stderr)
    sims = sorted((rule, wc["gain"]) for rule, wc in jobs if rule.startswith("simulate"))
    assert sims == [("simulate_fixed", "high"), ("simulate_flexible", "high")], jobs
    rules = {rule for rule, _ in jobs}
    # each base's identification is one job, the fits, Tables 2-3 and Figures 6-7 another
    assert {"identify_fixed", "identify_flexible", "fixed_base", "flexible_base", "fig9_base_motion",
            "planner_maps"} <= rules
    # products that do not depend on the high gains stay as they are
    assert not rules & {"model_figures", "fig5_joint3_motion"}, rules


def test_reuse_reanalyses_an_archive_without_simulating(ci_campaign_copy, tmp_path):
    """Re-analysing the campaign's own archive in its own folder: the products go to
    results/reuse-ci, the simulated campaign's results/ci stay byte-identical (and untouched),
    and identification from the archive reproduces every number."""
    ci_run = ci_campaign_copy
    reuse = write_config(tmp_path / "reuse.yaml", simulate=False, reuse_archive="archive/ci")
    out = snakemake(ci_run, "-n", config=reuse)
    dry = planned_jobs(out.stdout + out.stderr)
    rules = {rule for rule, _ in dry}
    assert not any(r.startswith("simulate") or r == "finalize_archive" for r in rules), rules
    assert {"verify_archive", "identify_fixed", "fixed_base", "flexible_base"} <= rules
    before = _digest_tree(ci_run / "results" / "ci")
    archive = _digest_tree(ci_run / "archive" / "ci")
    snakemake(ci_run, "table2", "results/reuse-ci/archive_verify.txt", config=reuse)
    assert _digest_tree(ci_run / "results" / "ci") == before
    assert _digest_tree(ci_run / "archive" / "ci") == archive  # nothing simulated, nothing archived
    ours = read_csv(ci_run / "results" / "reuse-ci" / "tables" / "table2.csv")
    original = read_csv(ci_run / "results" / "ci" / "tables" / "table2.csv")
    assert ours == original  # identification from the archive reproduces every number
    verified = (ci_run / "results" / "reuse-ci" / "archive_verify.txt").read_text()
    assert verified.startswith(f"archive {ci_run / 'archive' / 'ci'}: intact, 26 trials checked")


def test_reuse_refuses_to_mix_the_results_of_two_archives_of_one_name(ci_campaign_copy, tmp_path):
    """results/reuse-ci already holds the re-analysis of <ci_run>/archive/ci: another folder
    named ci is refused at start-up, naming the key and both archives."""
    ci_run = ci_campaign_copy
    other = tmp_path / "elsewhere" / "ci"
    other.mkdir(parents=True)
    (other / "index.csv").write_text("path,base,config,gain,speed,repeat\n")
    (ci_run / "results" / "reuse-ci").mkdir(parents=True, exist_ok=True)
    stamp = ci_run / "results" / "reuse-ci" / "archive_verify.txt"
    if not stamp.exists():
        stamp.write_text(f"archive {ci_run / 'archive' / 'ci'}: intact, 26 trials checked\n")
    reuse = write_config(tmp_path / "reuse.yaml", simulate=False, reuse_archive=str(other))
    out = snakemake(ci_run, "-n", config=reuse, check=False)
    said = [line for line in (out.stdout + out.stderr).splitlines() if "configuration key reuse_archive" in line]
    assert out.returncode != 0 and said and str(other) in said[0], out.stdout + out.stderr


def _digest_tree(root: Path) -> dict[str, tuple[str, int]]:
    import hashlib

    return {str(p.relative_to(root)): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*")) if p.is_file()}


def test_reuse_of_the_reference_archive_as_documented(ci_run, tmp_path):
    """``snakemake --cores 2 --config simulate=false`` with the default configuration, in a
    folder laid out like a fresh clone (config/ and the committed archive/reference) where a
    campaign was run before (its results in results/full): the cells come from the archive's
    index.csv, every product it can make is made into results/reuse-reference, nothing is
    written into the archive, and the earlier campaign's results stay byte-identical."""
    import shutil

    (tmp_path / "config").symlink_to(REPO / "config")
    (tmp_path / "archive").mkdir()
    (tmp_path / "archive" / "reference").symlink_to(REPO / "archive" / "reference")
    shutil.copytree(ci_run / "results" / "ci", tmp_path / "results" / "full")   # the campaign run before
    campaign = _digest_tree(tmp_path / "results" / "full")
    before = _digest_tree(REPO / "archive" / "reference")
    out = snakemake(tmp_path, "--cores", "2", "--config", "simulate=false", config=None, own_process=True)
    assert _digest_tree(REPO / "archive" / "reference") == before
    assert _digest_tree(tmp_path / "results" / "full") == campaign
    # the reference holds the structure the default configuration names: nothing to say
    assert not [line for line in out.stderr.splitlines() if line.startswith("reuse_archive:")]
    assert "structure of the flexible-base trials: space_class" in \
        (tmp_path / "results" / "reuse-reference" / "tables" / "table4.md").read_text()
    assert [p.name for p in (tmp_path / "archive").iterdir()] == ["reference"]
    results = tmp_path / "results" / "reuse-reference"
    assert (results / "archive_verify.txt").is_file()
    for name in ("table2", "table3", "table4"):
        assert (results / "tables" / f"{name}.csv").is_file()
    for name in ("fig4", "fig5", "fig6", "fig7", "fig8", "fig9"):
        assert (results / "figures" / f"{name}.png").is_file()
    rows = [r for f in sorted((results / "identify").rglob("*.csv")) for r in read_csv(f)]
    index = read_csv(REPO / "archive" / "reference" / "index.csv")
    assert sorted(Path(r["path"]).relative_to("archive/reference").as_posix() for r in rows) == \
        sorted(r["path"] for r in index)


# ------------------------------------------------------------------------------------------
# without running the campaign
# ------------------------------------------------------------------------------------------
def test_lint_has_no_findings(tmp_path):
    out = snakemake(tmp_path, "--lint", check=False)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Lints for" not in out.stdout + out.stderr


@pytest.mark.parametrize("changes, key", [
    ({"repeats": 0}, "repeats"),
    ({"speeds": [1.0, -2.0]}, "speeds"),
    ({"job_unit": "trial"}, "job_unit"),
    ({"bases": {"fixed": {"configurations": [1, 4], "gains": ["zero"]}}}, "configurations"),
    ({"figures": {"fig5": {"speed": 3.0, "repeat": 0}}}, "figures.fig5.speed"),
    ({"simulate": False, "reuse_archive": "no/such/archive"}, "reuse_archive"),
    ({"simulate": False, "reuse_archive": "a_file"}, "reuse_archive"),
    ({"plan_maps": {"resolution": 0.1, "config": 7}}, "plan_maps.config"),
    ({"plan_maps": {"resolution": 0.000001, "config": 1}}, "plan_maps.resolution"),
    ({"rig": "missing.yaml"}, "configuration key rig"),
    ({"archive_root": "a_file"}, "configuration key archive_root"),
    ({"results_root": "a_file"}, "configuration key results_root"),
])
def test_bad_config_stops_naming_the_key(tmp_path, changes, key):
    """At start-up, a dry run included: one line naming the key, nothing planned or written."""
    (tmp_path / "a_file").write_text("not a folder\n")
    bad = write_config(tmp_path / "bad.yaml", **changes)
    out = snakemake(tmp_path, "fig5", "-n", config=bad, check=False)
    assert out.returncode != 0
    said = [line for line in (out.stdout + out.stderr).splitlines() if key in line]
    assert said, out.stdout + out.stderr
    assert "Traceback" not in out.stderr and not planned_jobs(out.stdout + out.stderr)
    assert not (tmp_path / "archive").exists()


def test_planning_sees_jobs_not_trials(tmp_path):
    """A campaign of 108,000 trials (3000 speeds, 2 repeats) plans the same jobs as the reduced
    one, and no trial file: each simulation job's output is its job manifest."""
    speeds = [round(0.1 + 0.001 * i, 3) for i in range(3000)]
    big = write_config(tmp_path / "big.yaml", speeds=speeds, repeats=2, figures={})
    out = snakemake(tmp_path, "-n", config=big)
    text = out.stdout + out.stderr
    assert ".nc" not in text
    jobs = planned_jobs(text)
    assert sorted(r for r, _ in jobs if r.startswith("simulate")) == ["simulate_fixed"] * 3 + ["simulate_flexible"] * 2
    assert len(jobs) == 15


def test_table2_alone_runs_no_flexible_trial(tmp_path):
    """Table 2 is made by the fixed base's job (with the fits, Table 3 and Figures 6-7, from the
    same identification): no flexible-base job, no other figure."""
    out = snakemake(tmp_path, "table2", "-n")
    jobs = planned_jobs(out.stdout + out.stderr)
    rules = {rule for rule, _ in jobs}
    assert rules == {"simulate_fixed", "identify_fixed", "fixed_base", "table2"}, rules


@pytest.mark.parametrize("unit, expected", [
    ("sweep", [("simulate_fixed", {"gain": "zero"})]),
    ("cell", [("simulate_fixed", {"config": "1", "gain": "zero"})]),
])
def test_fig5_runs_one_simulation_job(tmp_path, unit, expected):
    cfg = write_config(tmp_path / "unit.yaml", job_unit=unit)
    out = snakemake(tmp_path, "fig5", "-n", config=cfg)
    jobs = planned_jobs(out.stdout + out.stderr)
    assert [j for j in jobs if j[0].startswith("simulate")] == expected
    assert {r for r, _ in jobs} == {"simulate_fixed", "fig5_joint3_motion", "fig5"}


def test_a_single_trial_can_be_asked_for(ci_run, tmp_path):
    """``snakemake <archive>/<base>/config<N>/<gain>/v<speed>/r<NN>.nc`` runs one job for that
    trial, the same trial its sweep's job writes; a trial the campaign does not run is refused."""
    from campaign.archive.filing import group_digests

    target = "archive/ci/fixed/config2/low/v1.500/r00.nc"
    out = snakemake(tmp_path, target)
    assert [r for r, _ in planned_jobs(out.stdout + out.stderr)] == ["simulate_trial"]
    assert group_digests(tmp_path / target) == group_digests(ci_run / target)
    assert sorted(p.name for p in (tmp_path / "archive" / "ci").rglob("*.nc")) == ["r00.nc"]
    out = snakemake(tmp_path, "archive/ci/fixed/config2/low/v3.000/r00.nc", "-n", check=False)
    assert out.returncode != 0 and "is not a trial of campaign ci" in out.stdout + out.stderr, out.stdout


def test_finalize_after_a_trial_changed_on_disk_fails_naming_it(ci_campaign_copy):
    """The archive's finalisation takes each trial's digests from the job that wrote it (it
    opens no trial), and still refuses a file changed since, naming it: the reduced campaign
    as before its finalisation (no MANIFEST.sha256), one trial changed since its job."""
    work = ci_campaign_copy
    manifest = work / "archive" / "ci" / "MANIFEST.sha256"
    manifest.unlink()
    assert sorted(r for r, _ in planned_jobs(snakemake(work, "archive", "-n").stdout)) == ["archive", "finalize_archive"]
    changed = "archive/ci/fixed/config1/zero/v2.500/r00.nc"
    data = bytearray((work / changed).read_bytes())
    data[-64] ^= 0x01
    (work / changed).write_bytes(bytes(data))
    out = snakemake(work, "archive", check=False)
    assert out.returncode != 0
    said = [line for line in (out.stdout + out.stderr).splitlines() if "changed since its simulation job" in line]
    assert said and changed in said[0] and "v1.500" not in said[0], out.stdout + out.stderr
    assert not manifest.exists()


def test_killed_run_completes_on_rerun(tmp_path):
    """SIGKILL the whole run while trials are being written, rerun: complete, intact archive."""
    from campaign.archive import verify

    cfg = write_config(tmp_path / "tiny.yaml", campaign="tiny", speeds=[1.0, 1.5, 2.0, 2.5], repeats=2,
                       bases={"fixed": {"configurations": [1], "gains": ["zero"]}})
    cmd = [SNAKEMAKE, "-s", str(SNAKEFILE), "--directory", str(tmp_path), "trials", "archive/tiny/MANIFEST.sha256",
           "--configfile", str(cfg)]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    cell = tmp_path / "archive" / "tiny" / "fixed" / "config1" / "zero"
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if cell.is_dir() and any(cell.rglob("*.nc")):
                break
            time.sleep(0.02)
        assert proc.poll() is None, "the run ended before it could be killed"
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    written = list(cell.rglob("*.nc"))
    assert 0 < len(written) < 8  # killed mid-way
    # a SIGKILLed Snakemake cannot release its lock on the working directory
    snakemake(tmp_path, "--unlock", config=cfg)
    snakemake(tmp_path, "trials", "archive/tiny/MANIFEST.sha256", config=cfg)
    assert len(list(cell.rglob("r*.nc"))) == 8
    assert not list(cell.rglob(".*.tmp"))
    assert verify(tmp_path / "archive" / "tiny") == []


# ------------------------------------------------------------------------------------------
# the pieces the workflow relies on
# ------------------------------------------------------------------------------------------
def test_trial_paths_agree_with_the_scene():
    from campaign.scene.description import make_scene

    for base, config, gain, speed, repeat in [("fixed", 1, "zero", 2.5, 0), ("flexible", 2, "high", 1.3, 11),
                                              ("fixed", 3, "low", 1.0 + 1e-12, 3)]:
        scene = make_scene(base=base, config=config, gain=gain, speed=speed, repeat=repeat)
        assert trial_relpath(base, config, gain, speed, repeat) == f"{scene.cell}.nc"
    assert cell_trials("a", "fixed", 1, "zero", [1.0, 2.5], 2) == [
        "a/fixed/config1/zero/v1.000/r00.nc", "a/fixed/config1/zero/v1.000/r01.nc",
        "a/fixed/config1/zero/v2.500/r00.nc", "a/fixed/config1/zero/v2.500/r01.nc"]


@pytest.mark.parametrize("call, message", [
    (lambda: trial_relpath("floating", 1, "zero", 1.0, 0), "unknown base 'floating'"),
    (lambda: trial_relpath("fixed", 1, "medium", 1.0, 0), "unknown gain set 'medium'"),
    (lambda: trial_relpath("fixed", 1, "zero", -1.0, 0), "impact speed"),
    (lambda: cell_trials("a", "fixed", 1, "zero", [1.0], 0), "repeats must be an integer >= 1, got 0"),
    (lambda: gain_counts("high", {"high": {"Q": 1}}), "gain_counts.high.Q"),
    (lambda: gain_counts("high", {"high": {"P": -5}}), "gain_counts.high.P = -5.0"),
])
def test_runner_names_bad_values(call, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        call()


def test_gain_counts_override_one_term():
    assert gain_counts("high") == (500000.0, 4000.0, 1500.0)
    assert gain_counts("high", {"high": {"P": 400000}}) == (400000.0, 4000.0, 1500.0)
    assert gain_counts("low", {"high": {"P": 400000}}) == (5000.0, 40.0, 0.0)


def test_conda_env_pins_match_the_lock():
    """workflow/envs/campaign.yaml (for --software-deployment-method conda) pins what constraints.txt pins."""
    env = yaml.safe_load((REPO / "workflow" / "envs" / "campaign.yaml").read_text())
    pip = next(d["pip"] for d in env["dependencies"] if isinstance(d, dict))
    lock = {}
    for line in (REPO / "constraints.txt").read_text().splitlines():
        if "==" in line and not line.startswith("#"):
            name, version = line.split("==", 1)
            lock[name.strip().lower().replace("_", "-")] = version.strip()
    for spec in pip:
        name, version = spec.split("==")
        assert lock.get(name.lower().replace("_", "-")) == version, f"{spec} differs from constraints.txt"


def _pdf_objects(path: Path) -> dict[int, tuple[bytes, bytes]]:
    """{object number: (dictionary, decoded stream)} of a PDF matplotlib wrote (no object streams)."""
    import zlib

    out = {}
    for m in re.finditer(rb"(\d+) 0 obj\n(.*?)endobj", path.read_bytes(), re.S):
        body = m.group(2)
        stream = re.search(rb"stream\n(.*)\nendstream", body, re.S)
        head = body[:stream.start()] if stream else body
        data = stream.group(1) if stream else b""
        out[int(m.group(1))] = (head, zlib.decompress(data) if b"/FlateDecode" in head and data else data)
    return out


def test_lean_pdf_fonts_change_only_the_embedded_font_files(tmp_path):
    """The figures' PDFs embed fonts without GSUB/GPOS/GDEF/kern (campaign.report.figures.style):
    every page object is the same as with matplotlib's own subsetting, the font files only shrink."""
    from campaign.report.figures import fig4, style

    fig = fig4.draw()
    lean = style.save(fig, tmp_path / "lean.png", tmp_path / "lean.pdf")[1]
    plain = tmp_path / "plain.pdf"
    fig.savefig(plain, format="pdf", metadata={"Creator": "campaign", "CreationDate": None})
    a, b = _pdf_objects(lean), _pdf_objects(plain)
    fonts = {int(x) for head, _ in b.values() for x in re.findall(rb"/FontFile2 (\d+) 0 R", head)}
    assert fonts and a.keys() == b.keys()
    for number, (head, data) in b.items():
        if number in fonts:
            assert len(a[number][1]) < len(data)
            continue
        lengths = re.compile(rb"/Length1? \d+( 0 R)?")
        if re.fullmatch(rb"\s*\d+\s*", head) and number - 1 in fonts:  # the font file's length
            continue
        assert (lengths.sub(b"", a[number][0]), a[number][1]) == (lengths.sub(b"", head), data), f"object {number}"


def test_figures_are_laid_out_once_for_png_and_pdf(tmp_path):
    """style.save runs the constrained layout for the PNG only and keeps it for the PDF (the
    layout costs 0.1-0.3 s a figure): after saving both, the axes sit where a PNG-only save
    puts them, not where the PDF renderer's own layout would (they differ by ~1 mm here)."""
    import numpy as np

    from campaign.report.figures import fig8, style

    def positions(fig):
        return np.array([ax.get_position().bounds for ax in fig.axes])

    both = fig8.draw()
    style.save(both, tmp_path / "f.png", tmp_path / "f.pdf")
    png_only = fig8.draw()
    style.save(png_only, tmp_path / "g.png")
    pdf_only = fig8.draw()
    style.save(pdf_only, None, tmp_path / "h.pdf")   # the PDF alone, laid out by the PDF renderer
    assert (tmp_path / "f.pdf").stat().st_size > 0
    assert np.array_equal(positions(both), positions(png_only))
    assert not np.allclose(positions(pdf_only), positions(png_only), rtol=0, atol=1e-4)

