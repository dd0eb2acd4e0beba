"""The studies as workflow rules: one runs end to end through Snakemake with its quick option,
the reduced campaign's targets read nothing under benchmarks/, a study product the
configuration does not list is refused naming the key, and benchmarks/ holds timings only."""

from __future__ import annotations

import csv
import re
import subprocess
from pathlib import Path

import pytest
import yaml

from campaign import studies
from campaign.report.tables import rig_check_table

from test_workflow import REPO, snakemake, write_config

#: a path under the repository's benchmarks/ folder (not results/<campaign>/benchmarks/, where
#: Snakemake's own benchmark records of the jobs go)
BENCH_PATH = re.compile(r"(?<![\w/.-])benchmarks/")


@pytest.mark.slow
def test_a_study_runs_through_snakemake_with_its_quick_option(tmp_path):
    snakemake(tmp_path, "--cores", "1", "study_plan_rig_check", "--config", "studies_quick=true")
    folder = tmp_path / "results" / "studies" / "plan_rig_check" / "quick"
    assert sorted(p.name for p in folder.glob("*.csv")) == sorted(
        f for f in studies.FILES["plan_rig_check"] if f.endswith(".csv"))
    with open(folder / "plan_rig_check.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["base"], r["structure"]) for r in rows] == [("fixed", ""), ("flexible", "space_class")]
    for r in rows:
        assert int(r["candidates"]) >= 3 and -1.0 <= float(r["spearman"]) <= 1.0
        assert 0.0 < float(r["best_over_worst"]) <= 1.0
        assert float(r["measured_min"]) > 0 and float(r["predicted_min"]) > 0
    with open(folder / "candidates.csv", newline="") as fh:
        assert sum(1 for _ in csv.DictReader(fh)) == sum(int(r["candidates"]) for r in rows)
    # the quick run skips the checks beside the table: their files hold only the header
    assert (folder / "passive.csv").read_text().count("\n") == 1
    # what the report shows of it, and the job's log
    assert len(rig_check_table(folder / "plan_rig_check.csv").rows) == 2
    assert "Spearman" in (folder / "report" / "plan_rig_check.html").read_text()
    assert "TIMING" in (folder / "logs" / "plan_rig_check_study.log").read_text()
    assert not (tmp_path / "results" / "ci").exists()        # a study is not a campaign's


def test_reduced_campaigns_targets_read_nothing_under_benchmarks(tmp_path):
    out = snakemake(tmp_path, "-n")
    assert not BENCH_PATH.search(out.stdout), [line for line in out.stdout.splitlines() if BENCH_PATH.search(line)]
    assert "results/studies" not in out.stdout
    # listed, the studies' report products come from their rules, into results/studies/
    listed = write_config(tmp_path / "listed.yaml", studies=["space_structure", "plan_rig_check"])
    out = snakemake(tmp_path, "-n", config=listed)
    assert not BENCH_PATH.search(out.stdout)
    for path in ("results/studies/space_structure/report/table4_structures.html",
                 "results/studies/space_structure/report/eq8_validity.png",
                 "results/studies/plan_rig_check/report/plan_rig_check.html"):
        assert path in out.stdout, path


def test_a_study_product_not_listed_is_refused_naming_the_key(tmp_path):
    out = snakemake(tmp_path, "table4_structures", "-n", check=False)
    assert out.returncode != 0
    assert "space_structure listed under the configuration key studies:" in out.stdout + out.stderr


def test_the_schema_names_every_study_and_each_has_a_module():
    schema = yaml.safe_load((REPO / "workflow" / "schemas" / "config.schema.yaml").read_text())
    assert tuple(schema["properties"]["studies"]["items"]["enum"]) == studies.NAMES
    for config in ("config.yaml", "tests/ci.yaml"):
        assert yaml.safe_load((REPO / "config" / config).read_text())["studies"] == []
    for name in studies.NAMES:
        assert (REPO / "campaign" / "studies" / f"{name}.py").is_file()
        assert re.search(rf"^rule {name}_study:$", (REPO / "workflow" / "rules" / "studies.smk").read_text(), re.M)


def test_benchmarks_hold_timing_scripts_only():
    tracked = subprocess.run(["git", "ls-files", "benchmarks"], cwd=REPO, capture_output=True, text=True,
                             check=True).stdout.split()
    assert tracked, "benchmarks/ is not tracked"
    assert not [p for p in tracked if p.endswith((".csv", ".png"))]
    scripts = [Path(p) for p in tracked if p.endswith(".py")]
    assert {p.name for p in scripts if not p.name.startswith("bench_")} == {"compiled_floor.py"}
    for path in scripts:
        text = (REPO / path).read_text()
        pin = text.find('for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):\n'
                        '    os.environ[_var] = "1"')
        # a script that loads numpy and the package only in its measuring functions has no
        # top-level import to come before: the pin must still be there
        first_import = min((i for i in (text.find("\nimport numpy"), text.find("\nfrom campaign")) if i >= 0),
                           default=len(text))
        assert 0 <= pin < first_import, f"{path} pins BLAS to one thread after numpy or the package loads"
        assert "print(blas_line())" in text, f"{path} does not say how many BLAS threads it ran"
