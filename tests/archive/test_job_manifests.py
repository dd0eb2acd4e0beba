"""Job manifests (campaign.archive.jobs): a simulation job lists what it wrote with the digests
taken as it wrote; finalize builds the archive's index, README and manifest from them without
opening a trial, the same files as from scratch, and still refuses, naming it, a trial file
changed since, deleted since, or written by no job; a rerun that reproduces a trial (within
the tolerance policy) keeps its file, and names a trial that moved.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import pytest

from campaign.archive import JOBS, finalize_campaign, open_trial_tree, read_job_manifests, verify, write_trial
from campaign.core.errors import TrialFileError
from campaign.pipeline.sweep import run_cells
from campaign.rig.sensors import measured_quanta
from campaign.scene.description import Scene

CELL = ("fixed", 1, "zero")
SPEEDS, REPEATS = [1.5], 2
R00, R01 = "fixed/config1/zero/v1.500/r00.nc", "fixed/config1/zero/v1.500/r01.nc"


def simulate(archive: Path, **kwargs) -> Path:
    """One job of one cell into ``archive``; its job manifest."""
    manifest = archive / JOBS / "fixed" / "zero.json"
    run_cells([CELL], archive_dir=archive, speeds=SPEEDS, repeats=REPEATS, job_manifest=manifest,
              job="simulate_fixed zero", **kwargs)
    return manifest


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[Path, Path]:
    archive = tmp_path_factory.mktemp("jobs") / "arch"
    return archive, simulate(archive)


@pytest.fixture
def job(written, tmp_path) -> tuple[Path, Path]:
    """A fresh copy of the written archive and its job manifest."""
    archive = tmp_path / "arch"
    shutil.copytree(written[0], archive)
    return archive, archive / written[1].relative_to(written[0])


def test_the_job_manifest_lists_each_trial_with_its_digests(job):
    archive, manifest = job
    entries = read_job_manifests([manifest])
    assert [e.path for e in entries] == [R00, R01]
    for e in entries:
        with h5py.File(archive / e.path, "r") as f:
            assert e.content == tuple(str(f[g].attrs["content_sha256"]) for g in ("measured", "truth"))
            assert e.row["seed"] == int(f.attrs["seed"]) and e.row["path"] == e.path
        assert e.size == (archive / e.path).stat().st_size and not e.kept
    assert json.loads(manifest.read_text())["job"] == "simulate_fixed zero"


def test_finalize_from_job_manifests_opens_no_trial_and_writes_what_a_scratch_finalize_writes(job, tmp_path,
                                                                                              monkeypatch):
    archive, manifest = job
    scratch = tmp_path / "scratch" / archive.name
    shutil.copytree(archive, scratch)
    shutil.rmtree(scratch / JOBS)
    finalize_campaign(scratch)

    def no_reading(*args, **kwargs):
        raise AssertionError("finalize opened a trial file")

    monkeypatch.setattr(h5py, "File", no_reading)
    finalize_campaign(archive, job_manifests=[manifest])
    monkeypatch.undo()
    for name in ("index.csv", "README.md", "MANIFEST.sha256"):
        assert (archive / name).read_bytes() == (scratch / name).read_bytes(), name
    assert JOBS not in (archive / "MANIFEST.sha256").read_text()   # bookkeeping, not part of the archive
    assert verify(archive) == []


def test_finalize_refuses_a_trial_changed_since_its_job_wrote_it(job):
    archive, manifest = job
    data = bytearray((archive / R01).read_bytes())
    data[-64] ^= 0x01
    (archive / R01).write_bytes(bytes(data))
    with pytest.raises(TrialFileError, match="changed since its simulation job wrote it") as info:
        finalize_campaign(archive, job_manifests=[manifest])
    assert str(archive / R01) in str(info.value) and R00 not in str(info.value)
    assert not (archive / "index.csv").exists()


def test_finalize_refuses_a_deleted_trial_and_one_no_job_wrote(job):
    archive, manifest = job
    (archive / R01).unlink()
    stale = archive / "fixed/config1/zero/v2.000/r00.nc"
    stale.parent.mkdir()
    shutil.copyfile(archive / R00, stale)
    with pytest.raises(TrialFileError) as info:
        finalize_campaign(archive, job_manifests=[manifest])
    message = str(info.value)
    assert f"{archive / R01}: missing" in message
    assert f"{stale}: no simulation job of this campaign wrote it" in message and f"same content (group digests) as {R00}" in message


def test_a_rerun_that_reproduces_the_trials_keeps_their_files(job):
    archive, manifest = job
    before = {rel: (archive / rel).read_bytes() for rel in (R00, R01)}
    simulate(archive)
    entries = read_job_manifests([manifest])
    assert [e.kept for e in entries] == [True, True]
    assert {rel: (archive / rel).read_bytes() for rel in (R00, R01)} == before
    # other gains: other trials, rewritten
    simulate(archive, gain_overrides={"zero": {"P": 100.0}})
    assert not any(e.kept for e in read_job_manifests([manifest]))
    assert (archive / R00).read_bytes() != before[R00]


def test_a_damaged_file_is_not_kept_but_rewritten(job):
    archive, manifest = job
    good = (archive / R00).read_bytes()
    data = bytearray(good)
    data[len(data) // 2] ^= 0xFF
    (archive / R00).write_bytes(bytes(data))
    simulate(archive)
    assert [e.kept for e in read_job_manifests([manifest])] == [False, True]
    assert verify(archive)[0].file == "MANIFEST.sha256"   # not finalized, otherwise intact
    finalize_campaign(archive, job_manifests=[manifest])
    assert verify(archive) == []


def _rewrite(path: Path, group: str, name: str, change) -> None:
    """Write ``path`` again with one channel changed (``change(values) -> values``): an intact
    file with its own content digests, as another machine or another code version leaves it."""
    tree = open_trial_tree(path)
    da = tree[group][name]
    tree[group][name] = da.copy(data=change(da.values.copy()))
    write_trial(tree, path)


def test_a_rerun_keeps_a_trial_within_the_tolerance_and_names_one_that_moved(job, capsys):
    archive, manifest = job
    scene = Scene.from_json(open_trial_tree(archive / R00).attrs["scene_json"])
    step = measured_quanta(scene)["q_enc"]

    def one_flip(q, k=1):
        q[5:5 + k, 1] += step[1]      # k samples of one encoder one count up
        return q

    # R00 as another machine leaves it: roundoff in the truth, one encoder count flipped
    _rewrite(archive / R00, "truth", "v", lambda v: v * (1 + 1e-13))
    _rewrite(archive / R00, "measured", "q_enc", one_flip)
    # R01 moved: two encoder counts flipped (more than roundoff explains)
    _rewrite(archive / R01, "measured", "q_enc", lambda q: one_flip(q, 2))
    stored = {rel: (archive / rel).read_bytes() for rel in (R00, R01)}
    capsys.readouterr()
    simulate(archive)
    lines = capsys.readouterr().out.splitlines()
    r00, r01 = (next(line for line in lines if line.endswith(rel)) for rel in (R00, R01))
    assert "kept (same trial) [largest difference: " in r00 and "truth/v; one-step flips: 1 in measured/q_enc]" in r00, r00
    assert "written: the file there held another trial (measured/q_enc" in r01 and "2 sample(s) one step (" in r01
    entries = read_job_manifests([manifest])
    assert [e.kept for e in entries] == [True, False]
    # the kept file stays byte for byte, and its entry is the kept file's
    assert (archive / R00).read_bytes() == stored[R00] and (archive / R01).read_bytes() != stored[R01]
    with h5py.File(archive / R00, "r") as f:
        assert entries[0].content == tuple(str(f[g].attrs["content_sha256"]) for g in ("measured", "truth"))
    finalize_campaign(archive, job_manifests=[manifest])
    assert verify(archive) == []
