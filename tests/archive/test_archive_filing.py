"""Misfiled and duplicate trials are caught: by ``archive verify`` and ``finalize``, by
identification and by reuse, each naming both paths, even after the manifest was re-hashed to
match; a file outside the cell layout is refused and no reader counts it (they all take their
trials from one source: the index once finalized, else the cell layout).

Every case works on a copy of the committed reference archive.
"""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from campaign.archive import finalize_campaign, list_trials, verify, write_manifest
from campaign.cli.main import main
from campaign.core.errors import TrialFileError
from campaign.identify import find_trials
from campaign.identify.table import identify_trials
from campaign.pipeline.paths import index_cells

REPO = Path(__file__).resolve().parents[2]
HIGH = "fixed/config1/high/v1.500/r00.nc"
LOW = "fixed/config1/low/v1.500/r00.nc"
R00 = "fixed/config1/zero/v1.500/r00.nc"
R01 = "fixed/config1/zero/v1.500/r01.nc"


@pytest.fixture
def archive(tmp_path) -> Path:
    out = tmp_path / "ref"
    shutil.copytree(REPO / "archive" / "reference", out)
    return out


def _swap(archive: Path, a: str, b: str) -> None:
    tmp = archive / "swap.tmp.nc"
    (archive / a).rename(tmp)
    (archive / b).rename(archive / a)
    tmp.rename(archive / b)


def _messages(problems) -> list[str]:
    return [str(p) for p in problems]


def test_trials_swapped_between_gain_folders(archive, capsys):
    _swap(archive, HIGH, LOW)
    write_manifest(archive)  # the manifest now matches the files: only their content tells
    found = _messages(verify(archive))
    assert any(m.startswith(f"{HIGH}: misfiled") and LOW in m for m in found), found
    assert any(m.startswith(f"{LOW}: misfiled") and HIGH in m for m in found), found
    assert any(m.startswith(HIGH) and "index.csv line" in m and "gain 'high' in index.csv, 'low' in the file" in m
               for m in found), found
    assert main(["archive", "verify", str(archive)]) == 1
    assert f"{HIGH}: misfiled" in capsys.readouterr().out
    with pytest.raises(TrialFileError) as info:
        finalize_campaign(archive)
    assert f"{archive / HIGH}: misfiled" in str(info.value) and str(archive / LOW) in str(info.value)


def test_a_repeat_copied_to_the_next(archive):
    shutil.copyfile(archive / R00, archive / R01)
    write_manifest(archive)
    found = _messages(verify(archive))
    assert any(m.startswith(f"{R01}: misfiled") and R00 in m for m in found), found
    assert any(m.startswith(R01) and "same cell" in m and R00 in m for m in found), found
    assert any(m.startswith(R01) and "same content" in m and R00 in m for m in found), found
    with pytest.raises(TrialFileError) as info:
        finalize_campaign(archive)
    assert str(archive / R01) in str(info.value) and R00 in str(info.value)
    assert not (archive / "index.csv").read_text().count("r01.nc")  # nothing was rewritten


def test_an_index_row_that_contradicts_its_file(archive):
    index = archive / "index.csv"
    rows = list(csv.DictReader(index.open()))
    for row in rows:
        if row["path"] == HIGH:
            row["seed"] = "12345"
    with index.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    write_manifest(archive)
    found = _messages(verify(archive))
    assert any(m.startswith(HIGH) and "index.csv line" in m and "seed '12345'" in m for m in found), found


def test_identification_refuses_a_misfiled_trial(archive, tmp_path):
    """Reuse identifies the files its cells list: a Low trial under High stops the job, not the fit."""
    _swap(archive, HIGH, LOW)
    with pytest.raises(TrialFileError) as info:
        identify_trials([str(archive / HIGH)], tmp_path / "high.csv")
    assert str(archive / HIGH) in str(info.value) and str(archive / LOW) in str(info.value)
    assert not (tmp_path / "high.csv").exists()


def test_reuse_refuses_an_index_whose_row_contradicts_its_path(archive):
    index = archive / "index.csv"
    text = index.read_text().replace(f"{HIGH},fixed,1,high,", f"{HIGH},fixed,1,low,", 1)
    index.write_text(text)
    with pytest.raises(ValueError, match=f"path {HIGH} contradicts its row"):
        index_cells(archive)


# ------------------------------------------------------------------------------------------
# a duplicate outside the cell layout, and one source of truth for every reader
# ------------------------------------------------------------------------------------------
EXTRA = "fixed/extra/x.nc"


def _reader_counts(archive: Path, tmp_path: Path, capsys) -> dict[str, int]:
    """How many trials each reader of an archive takes: the index, ``archive ls``, the
    workflow's reuse (index_cells), identification's file list, ``fit-lambda`` and ``tables``."""
    counts = {"index": len(list(csv.DictReader((archive / "index.csv").open()))),
              "archive ls": len(list_trials(archive)),
              "workflow": sum(len(paths) for paths in index_cells(archive).values()),
              "find_trials": len(find_trials(archive))}
    capsys.readouterr()
    assert main(["fit-lambda", str(archive), "--json", "--bootstrap", "0"]) == 0
    counts["fit-lambda"] = json.loads(capsys.readouterr().out)["trials"]
    assert main(["tables", str(archive), "--out", str(tmp_path / "tables"), "--bootstrap", "0"]) == 0
    counts["tables"] = len(list(csv.DictReader((tmp_path / "tables" / "identification.csv").open())))
    return counts


def test_a_duplicate_outside_the_layout_is_refused_flagged_and_counted_by_no_reader(archive, tmp_path, capsys):
    (archive / EXTRA).parent.mkdir()
    shutil.copyfile(archive / R00, archive / EXTRA)
    write_manifest(archive)  # even listed in the manifest, verify names it
    found = _messages(verify(archive))
    assert any(m.startswith(f"{EXTRA}: outside the archive layout") and f"same content (group digests) as {R00}" in m
               for m in found), found
    with pytest.raises(TrialFileError) as info:
        finalize_campaign(archive)
    assert str(archive / EXTRA) in str(info.value) and R00 in str(info.value)
    assert main(["archive", "verify", str(archive)]) == 1
    assert EXTRA in capsys.readouterr().out
    counts = _reader_counts(archive, tmp_path, capsys)
    assert set(counts.values()) == {26}, counts


def test_readers_of_an_archive_not_finalized_take_its_cell_layout(archive, tmp_path, capsys):
    (archive / EXTRA).parent.mkdir()
    shutil.copyfile(archive / R00, archive / EXTRA)
    for name in ("index.csv", "MANIFEST.sha256"):
        (archive / name).unlink()
    assert len(find_trials(archive)) == len(list_trials(archive)) == 26
    assert EXTRA not in {r.path for r in list_trials(archive)}


def test_a_content_duplicate_inside_the_layout_is_refused_and_flagged(archive):
    """A copy of a trial into a cell of its own (a speed the campaign did not run) holds no
    other trial's cell, but the same content: finalize refuses it and verify names both."""
    copy = "fixed/config1/zero/v3.000/r00.nc"
    (archive / copy).parent.mkdir()
    shutil.copyfile(archive / R00, archive / copy)
    found = _messages(verify(archive))
    assert any(m.startswith(copy) and "same content" in m and R00 in m for m in found), found
    with pytest.raises(TrialFileError) as info:
        finalize_campaign(archive)
    assert str(archive / copy) in str(info.value)
