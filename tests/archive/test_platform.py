"""The platform a trial was computed on: each trial file records it (CPU, operating system,
Python, NumPy with its BLAS library and the kernel that library picked at run time,
Pinocchio), a rerun on another platform that reproduces a trial keeps its file, and
``campaign archive verify`` lists an archive's platforms when they differ without calling
the archive corrupt, older files without the attributes included.
"""

from __future__ import annotations

import platform
import shutil
from pathlib import Path

import h5py
import numpy as np

from campaign.archive import (
    fileformat,
    finalize_campaign,
    list_trials,
    open_trial_tree,
    provenance,
    trial_path,
    verify_report,
    write_trial,
    write_trial_entry,
)
from campaign.archive.machine import NOT_RECORDED, platform_attributes, platform_summary
from campaign.cli.main import main as cli_main
from campaign.scene.description import Scene

from synthetic import synthetic_trial

REFERENCE = Path(__file__).resolve().parents[2] / "archive" / "reference"
#: a trial of the committed reference, written before trials recorded their platform
OLD_TRIAL = "fixed/config1/zero/v1.500/r00.nc"
DURATION = 0.3  # s: short synthetic recordings
PLATFORM_KEYS = ("cpu_architecture", "cpu_model", "operating_system", "python_implementation", "python_version",
                 "numpy_blas", "numpy_blas_version", "numpy_blas_kernel", "numpy_simd", "computing_platform")
#: another platform, as a node of a cluster with other CPUs would record it
ELSEWHERE = {"cpu_architecture": "aarch64", "cpu_model": "Neoverse-N1", "operating_system": "Linux glibc 2.35",
             "numpy_blas": "OpenBLAS", "numpy_blas_version": "0.3.29", "numpy_blas_kernel": "NEOVERSEN1",
             "numpy_simd": "NEON NEON_FP16 NEON_VFPV4 ASIMD ASIMDHP"}


def _root(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        return {k: f.attrs[k] for k in f.attrs}


def _elsewhere(monkeypatch) -> str:
    """Make this process write trials as if on another platform; that platform's summary."""
    other = {**provenance(), **ELSEWHERE}
    other.pop("computing_platform")
    other["computing_platform"] = platform_summary(other)
    monkeypatch.setattr(fileformat, "_provenance", lambda: tuple(other.items()))
    return other["computing_platform"]


def _cell(tree) -> str:
    return Scene.from_json(tree.attrs["scene_json"]).cell


def test_a_trial_records_the_platform_that_computed_it(tmp_path):
    import scipy.linalg  # noqa: F401 - SciPy's own OpenBLAS loaded too: NumPy's must still be the one named

    root = _root(write_trial(synthetic_trial(duration=DURATION), tmp_path / "t.nc"))
    for key in PLATFORM_KEYS:
        assert isinstance(root[key], str) and root[key].strip(), key
    assert root["cpu_architecture"] == platform.machine()
    assert root["python_implementation"] == platform.python_implementation()
    assert root["python_version"] == platform.python_version()
    assert root["operating_system"].startswith(platform.system())
    build = np.show_config(mode="dicts")
    blas = build["Build Dependencies"]["blas"]
    if "openblas" in blas["name"].lower():
        # the library NumPy was built with (SciPy's has another version here), and the kernel
        # OpenBLAS picked for this CPU: a core name, never left unknown
        assert root["numpy_blas"] == "OpenBLAS"
        assert root["numpy_blas_version"] == blas["version"]
        assert root["numpy_blas_kernel"] not in ("", "unknown")
    simd = build["SIMD Extensions"]
    assert root["numpy_simd"].split() == simd["baseline"] + simd["found"]
    # the summary names each part that decides the arithmetic
    summary = root["computing_platform"]
    for part in (root["cpu_architecture"], root["numpy_blas_kernel"], root["numpy_version"],
                 root["pinocchio_version"], root["python_version"]):
        assert part in summary
    assert summary == platform_summary(root)


def test_the_platform_is_found_once_per_process(monkeypatch):
    first = platform_attributes()

    def fail(*args, **kwargs):
        raise AssertionError("the platform was looked up again")

    monkeypatch.setattr("threadpoolctl.threadpool_info", fail)
    assert platform_attributes() == first and set(first) <= set(provenance())


def test_a_rerun_on_another_platform_that_reproduces_a_trial_keeps_its_file(tmp_path, monkeypatch):
    tree = synthetic_trial(duration=DURATION)
    path = trial_path(tmp_path, Scene.from_json(tree.attrs["scene_json"]))
    with monkeypatch.context() as m:
        other = _elsewhere(m)
        write_trial(tree, path)
    before = path.read_bytes()
    assert _root(path)["computing_platform"] == other != provenance()["computing_platform"]
    entry = write_trial_entry(tree, path, campaign_dir=tmp_path, keep_same=True)
    assert entry.kept and path.read_bytes() == before


def test_a_file_written_before_trials_recorded_their_platform_is_kept_by_a_rerun(tmp_path):
    """The same trial written now (with the platform attributes) is the committed file's trial."""
    path = tmp_path / OLD_TRIAL
    path.parent.mkdir(parents=True)
    shutil.copyfile(REFERENCE / OLD_TRIAL, path)
    assert "computing_platform" not in _root(path)
    entry = write_trial_entry(open_trial_tree(path), path, campaign_dir=tmp_path, keep_same=True)
    assert entry.kept and path.read_bytes() == (REFERENCE / OLD_TRIAL).read_bytes()


def test_verify_lists_the_platforms_of_an_archive_without_calling_it_corrupt(tmp_path, monkeypatch, capsys):
    """Trials of two platforms and one older file that records none: three groups, no problem."""
    folder = tmp_path / "mixed"
    (folder / OLD_TRIAL).parent.mkdir(parents=True)
    shutil.copyfile(REFERENCE / OLD_TRIAL, folder / OLD_TRIAL)
    here = [synthetic_trial(duration=DURATION, config=2), synthetic_trial(duration=DURATION, config=3)]
    for tree in here:
        write_trial(tree, folder / f"{_cell(tree)}.nc")
    tree = synthetic_trial(duration=DURATION, base="flexible")
    with monkeypatch.context() as m:
        other = _elsewhere(m)
        write_trial(tree, folder / f"{_cell(tree)}.nc")
    finalize_campaign(folder)

    mine = provenance()["computing_platform"]
    report = verify_report(folder)
    assert report.problems == []
    assert report.platforms == {mine: 2, other: 1, NOT_RECORDED: 1}
    assert {r.path: r.computing_platform for r in list_trials(folder)}[OLD_TRIAL] == NOT_RECORDED
    assert cli_main(["archive", "verify", str(folder)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out == [f"{folder}: trials from 3 platforms: {mine} (2 trials), {other} (1 trial), {NOT_RECORDED} (1 trial)",
                   f"{folder}: ok"]


def test_verify_says_nothing_of_platforms_when_all_trials_share_one(tmp_path, capsys):
    folder = tmp_path / "one"
    for config in (1, 2):
        tree = synthetic_trial(duration=DURATION, config=config)
        write_trial(tree, folder / f"{_cell(tree)}.nc")
    finalize_campaign(folder)
    report = verify_report(folder)
    assert report.problems == [] and list(report.platforms.values()) == [2] and report.platform_note() is None
    assert cli_main(["archive", "verify", str(folder)]) == 0
    assert capsys.readouterr().out == f"{folder}: ok\n"
