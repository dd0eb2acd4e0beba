"""The product comparison of the SLURM cluster test (tests/cluster/compare_runs.py) on two
small hand-made runs: what it accepts as equal (trial files written at another time, other
log contents) and every kind of difference it must name."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import compare_runs
import h5py
import pytest


def write_trial(path: Path, *, date: str, measured: str = "m" * 64, seed: int = 7) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        f.attrs["date_created"] = date
        f.attrs["history"] = f"{date} simulated by campaign"   # as the writer's: it starts with the time
        f.attrs["content_sha256"] = f"root-digest-of-{date}"
        f.attrs["seed"] = seed
        for name, digest in (("measured", measured), ("truth", "t" * 64)):
            g = f.create_group(name)
            g.attrs["content_sha256"] = digest
            g.create_dataset("x", data=[1.0, 2.0])


def make_run(root: Path, *, date: str) -> Path:
    trial = "archive/ci/fixed/config1/zero/v1.500/r00.nc"
    write_trial(root / trial, date=date)
    (root / "archive/ci/index.csv").write_text("trial,seed\nr00,7\n")
    (root / "archive/ci/MANIFEST.sha256").write_text(f"{'a' * 64}  index.csv\n{date[-2:] * 32}  {trial.removeprefix('archive/ci/')}\n")
    for rel, text in (("results/ci/tables/table2.csv", "m_eff\n1.5\n"),
                      ("results/ci/logs/table2.log", f"took 0.3 s at {date}\n"),
                      ("results/ci/benchmarks/fit_lambda/high.tsv", f"s\n{date}\n")):
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    entry = {"path": trial.removeprefix("archive/ci/"), "content": ["m" * 64, "t" * 64], "kept": False,
             "rates": {"ves.rate": 1000.0}, "row": {"seed": 7}, "sha256": date[-2:] * 32, "size": 1000 + len(date) + date.count("2")}
    (root / "archive/ci/.jobs/fixed").mkdir(parents=True)
    (root / "archive/ci/.jobs/fixed/zero.json").write_text(json.dumps({"format": "campaign job manifest 1",
                                                                       "job": "simulate_fixed", "trials": [entry]}))
    (root / ".snakemake").mkdir()
    (root / ".snakemake/state").write_text(date)
    return root


@pytest.fixture
def runs(tmp_path):
    return make_run(tmp_path / "a", date="2026-01-01T00:00:01Z"), make_run(tmp_path / "b", date="2026-01-01T00:00:02Z")


def test_runs_written_at_different_times_agree(runs):
    agree, problems = compare_runs.compare(*runs)
    assert problems == []
    assert agree == {"bytes": 2, "trial": 1, "manifest": 1, "job manifest": 1, "log": 2}


def test_a_changed_byte_is_named(runs):
    a, b = runs
    (b / "results/ci/tables/table2.csv").write_text("m_eff\n1.6\n")
    assert compare_runs.compare(a, b)[1] == ["results/ci/tables/table2.csv: bytes differ"]


@pytest.mark.parametrize("change, where", [({"measured": "x" * 64}, "'measured'"), ({"seed": 8}, "'/'")])
def test_a_trial_with_other_content_is_named(runs, change, where):
    a, b = runs
    write_trial(b / "archive/ci/fixed/config1/zero/v1.500/r00.nc", date="2026-01-01T00:00:02Z", **change)
    (problem,) = compare_runs.compare(a, b)[1]
    assert problem.startswith("archive/ci/fixed/config1/zero/v1.500/r00.nc: groups") and where in problem


def test_a_manifest_entry_other_than_a_trial_is_compared(runs):
    a, b = runs
    manifest = b / "archive/ci/MANIFEST.sha256"
    manifest.write_text(manifest.read_text().replace("a" * 64, "b" * 64))
    assert compare_runs.compare(a, b)[1] == ["archive/ci/MANIFEST.sha256: digests of ['index.csv'] differ"]


def test_a_job_manifest_entry_with_other_content_is_named(runs):
    a, b = runs
    path = b / "archive/ci/.jobs/fixed/zero.json"
    doc = json.loads(path.read_text())
    doc["trials"][0]["content"][0] = "x" * 64
    path.write_text(json.dumps(doc))
    assert compare_runs.compare(a, b)[1] == [
        "archive/ci/.jobs/fixed/zero.json: entries differ (['fixed/config1/zero/v1.500/r00.nc'])"]


def test_missing_and_extra_products_are_named(runs):
    a, b = runs
    (b / "results/ci/logs/table2.log").unlink()
    shutil.copy(b / "results/ci/tables/table2.csv", b / "results/ci/tables/table3.csv")
    assert compare_runs.compare(a, b)[1] == [f"only in {a}: results/ci/logs/table2.log",
                                             f"only in {b}: results/ci/tables/table3.csv"]


def test_command_line_exit_codes(runs, tmp_path, capsys):
    a, b = runs
    assert compare_runs.main([str(a), str(b)]) == 0
    (b / "archive/ci/index.csv").write_text("other\n")
    assert compare_runs.main([str(a), str(b)]) == 1
    assert "DIFFERENT: archive/ci/index.csv: bytes differ" in capsys.readouterr().out
    assert compare_runs.main([str(a), str(tmp_path / "missing")]) == 2
    assert compare_runs.main([str(a), str(tmp_path / "empty")]) == 2
    (tmp_path / "empty").mkdir()
    assert compare_runs.main([str(tmp_path / "empty"), str(b)]) == 1
