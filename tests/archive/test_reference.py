"""The committed reference archive as a regression baseline.

``archive/reference`` is made by the project's own command (``config/tests/reference.yaml``: the
reduced campaign, see archive/README.md). On any machine, re-simulating its stored scenes
must reproduce its channels and identification on it the results stored beside it, both
within the tolerance policy (campaign.core.tolerance: another CPU or BLAS kernel moves them
by roundoff), and its documented command must rewrite none of its files; a change to the
rig or to identification that moves a number beyond the policy shows up here, and the
archive is then regenerated deliberately, not silently. Finalizing an intact copy changes
nothing.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from campaign import archive
from campaign.archive.sametrial import trial_differences
from campaign.core.tolerance import IDENTIFICATION_SCALES, identification_differences, worst
from campaign.identify import identify_file
from campaign.rig import simulate_arrays
from campaign.scene.description import Scene

ROOT = Path(__file__).resolve().parents[2] / "archive"
REFERENCE = ROOT / "reference"
STORED = ROOT / "reference.identification.csv"

#: a spread of the reference's cells: both bases, every gain, three configurations
RESIMULATED = (
    "fixed/config1/zero/v1.500/r00.nc",
    "fixed/config3/high/v2.500/r00.nc",
    "fixed/config2/low/v1.500/r00.nc",
    "flexible/config2/high/v2.500/r00.nc",
)


def test_the_reference_archive_verifies_clean():
    assert archive.verify(REFERENCE) == []
    # 26 trials: 18 fixed-base, 8 flexible-base, as archive/README.md says
    assert len(archive.list_trials(REFERENCE)) == 26
    assert len(archive.list_trials(REFERENCE, base="flexible")) == 8


@pytest.mark.parametrize("rel", RESIMULATED)
def test_resimulating_a_stored_scene_reproduces_its_channels(rel):
    path = REFERENCE / rel
    scene = Scene.from_json(archive.open_trial_tree(path).attrs["scene_json"])
    found = trial_differences(path, simulate_arrays(scene))
    assert len(found) > 30     # every channel of both groups, and their attributes
    assert worst(found).ok, [str(d) for d in found if not d.ok]


def test_identification_on_the_reference_reproduces_its_stored_results():
    stored = pd.read_csv(STORED, keep_default_na=False, dtype=str)
    assert len(stored) == 26
    keys = ("excluded", *IDENTIFICATION_SCALES)
    for _, row in stored.iterrows():
        rel = Path(row["path"])
        path = rel if rel.is_absolute() and rel.exists() else REFERENCE / Path(
            *Path(row["path"]).parts[-5:])
        res = identify_file(path)
        found = identification_differences({k: row[k] for k in ("speed", *keys)},
                                           {"speed": res.speed, **{k: getattr(res, k) for k in keys}}, name=str(rel))
        assert len(found) == len(keys) + 1
        assert worst(found).ok, [str(d) for d in found if not d.ok]


def test_the_reference_reproduces_the_papers_fixed_base_effective_masses_within_10_percent():
    # what the calibration promised, read from the stored identification (no simulation)
    from campaign.model.paper import load_paper
    t2 = load_paper()["table2"]
    df = pd.read_csv(STORED)
    fixed = df[(df.base == "fixed") & (df.excluded == 0)]
    for config in (1, 2, 3):
        m2 = fixed[(fixed.config == config) & fixed.gain.isin(["zero", "low"])].m_eff.mean()
        m3 = fixed[(fixed.config == config) & (fixed.gain == "high")].m_eff.mean()
        assert abs(m2 / t2["m2"][config] - 1) < 0.10, (config, m2)
        assert abs(m3 / t2["m3"][config] - 1) < 0.10, (config, m3)
    assert abs(fixed.e.mean() - 0.55) < 0.03
    assert np.all(np.isfinite(df.m_eff)) and np.all((df.e > 0) & (df.e < 1))


# ------------------------------------------------------------------------------------------
# reproducible by its documented command; finalize idempotent on it
# ------------------------------------------------------------------------------------------
REPO = ROOT.parent


def _documented_command() -> list[str]:
    """The regeneration command config/tests/reference.yaml documents (its ``snakemake`` line)."""
    text = (REPO / "config" / "tests" / "reference.yaml").read_text()
    lines = [line.strip("# ").split() for line in text.splitlines() if line.startswith("#   snakemake ")]
    assert len(lines) == 1, lines
    return lines[0][1:]


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".jobs" not in p.parts}


def test_finalize_on_an_intact_copy_changes_nothing(tmp_path):
    copy = tmp_path / "reference"
    shutil.copytree(REFERENCE, copy)
    before = _files(copy)
    archive.finalize_campaign(copy)
    assert _files(copy) == before


@pytest.mark.slow
def test_the_reference_regenerates_from_its_documented_command_with_no_file_changed(tmp_path):
    """The documented command, in a folder laid out like a fresh clone (config/ and copies of
    the committed archive/reference and its identification): every trial is simulated again
    and kept as it is (the same trial within the tolerance policy on any machine), and the
    index, README, manifest and identification come out byte for byte. A trial or
    identification that moved beyond the policy is named in the job logs."""
    (tmp_path / "config").symlink_to(REPO / "config")
    shutil.copytree(REFERENCE, tmp_path / "archive" / "reference")
    shutil.copyfile(STORED, tmp_path / "archive" / STORED.name)
    before = _files(tmp_path / "archive")
    cmd = [str(Path(sys.executable).parent / "snakemake"), "-s", str(REPO / "Snakefile"), "--directory", str(tmp_path),
           *_documented_command()]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    logs = tmp_path / "results" / "reference" / "logs"
    simulation = "".join(log.read_text() for log in logs.glob("simulate_*/*/*.log"))
    identification = "".join(log.read_text() for log in logs.rglob("identification_csv*.log"))
    after = _files(tmp_path / "archive")
    changed = sorted(rel for rel in before if after.get(rel) != before[rel])
    assert changed == [] and set(after) == set(before), (changed, [line for line in simulation.splitlines()
                                                                   if "written" in line], identification)
    assert simulation.count("kept (same trial)") == 26
