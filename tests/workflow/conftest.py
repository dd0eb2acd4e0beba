"""The workflow tests' shared fixture: the reduced campaign (config/tests/ci.yaml) runs
through Snakemake once per test run, shared by every test process (:func:`ci_campaign`; a
test that changes it works on a copy, :func:`ci_campaign_copy`)."""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")


@contextmanager
def _run_lock(tmp_path_factory, name: str):
    """An exclusive lock shared by the test processes of this run; yields their common folder."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    with open(root / f"{name}.lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield root
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def ci_campaign(tmp_path_factory) -> Path:
    """The working folder of the reduced campaign (config/tests/ci.yaml), run once per test run with
    the repository's Snakefile (``snakemake --directory <folder>``, profiles/default).
    Read only: a test that writes into it works on :func:`ci_campaign_copy`."""
    with _run_lock(tmp_path_factory, "ci_campaign") as root:
        work, done = root / "ci_campaign", root / "ci_campaign.done"
        if not done.is_file():
            shutil.rmtree(work, ignore_errors=True)
            work.mkdir()
            t0 = time.perf_counter()
            proc = subprocess.run([SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(work),
                                   "--configfile", str(REPO / "config" / "tests" / "ci.yaml")],
                                  cwd=work, capture_output=True, text=True, timeout=900)
            assert proc.returncode == 0, f"the reduced campaign failed:\n{proc.stdout[-4000:]}\n{proc.stderr[-6000:]}"
            done.write_text(f"{time.perf_counter() - t0:.1f} s\n")
    return work


@pytest.fixture
def ci_campaign_copy(ci_campaign, tmp_path) -> Path:
    """A copy of :func:`ci_campaign` (Snakemake's records included, file times kept) in the
    test's own folder, for a test that changes it."""
    return shutil.copytree(ci_campaign, tmp_path / "ci_campaign", symlinks=True)
