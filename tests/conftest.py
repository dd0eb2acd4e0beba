"""Shared fixtures and the run's settings.

- One BLAS thread per process, set before numpy loads, here and in every command a test
  starts (an explicit setting in the environment is kept). The suite runs on two test
  processes (pytest-xdist, ``pyproject.toml``); BLAS threads on top of them only wait for
  each other (identification at 1 kHz takes several times the CPU with two of them).
- The test files with the most end-to-end (``slow``) tests run first, each file's tests in
  their order in one process (``--dist loadfile``), so the longest files start first and the
  two processes finish together.
- The reduced campaign (config/ci.yaml) runs through Snakemake once per test run, shared by
  every test process (:func:`ci_campaign`; a test that changes it works on a copy,
  :func:`ci_campaign_copy`).
- The robots, loaded once per process, and a hypothesis profile.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import fcntl
import shutil
import subprocess
import sys
import time
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import settings

from campaign.model.robot import load_robot
from campaign.model.robot.floating import BaseBody

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")

# Pinocchio's first calls are slower than the rest; a per-example deadline would flake.
settings.register_profile("campaign", deadline=None, max_examples=60)
settings.load_profile("campaign")


def pytest_collection_modifyitems(config, items):
    """Files with more ``slow`` tests first; a file's tests stay together and in order."""
    slow = Counter(item.path for item in items if item.get_closest_marker("slow"))
    items.sort(key=lambda item: -slow[item.path])


def pytest_sessionfinish(session, exitstatus):
    """The Snakemake server of :mod:`snakemake_forks` ends with the session."""
    forks = sys.modules.get("snakemake_forks")
    if forks is not None:
        forks.stop()


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
    """The working folder of the reduced campaign (config/ci.yaml), run once per test run with
    the repository's Snakefile (``snakemake --directory <folder>``, profiles/default).
    Read only: a test that writes into it works on :func:`ci_campaign_copy`."""
    with _run_lock(tmp_path_factory, "ci_campaign") as root:
        work, done = root / "ci_campaign", root / "ci_campaign.done"
        if not done.is_file():
            shutil.rmtree(work, ignore_errors=True)
            work.mkdir()
            t0 = time.perf_counter()
            proc = subprocess.run([SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(work),
                                   "--configfile", str(REPO / "config" / "ci.yaml")],
                                  cwd=work, capture_output=True, text=True, timeout=900)
            assert proc.returncode == 0, f"the reduced campaign failed:\n{proc.stdout[-4000:]}\n{proc.stderr[-6000:]}"
            done.write_text(f"{time.perf_counter() - t0:.1f} s\n")
    return work


@pytest.fixture
def ci_campaign_copy(ci_campaign, tmp_path) -> Path:
    """A copy of :func:`ci_campaign` (Snakemake's records included, file times kept) in the
    test's own folder, for a test that changes it."""
    return shutil.copytree(ci_campaign, tmp_path / "ci_campaign", symlinks=True)


@pytest.fixture(scope="session")
def puma():
    """The PUMA 560 of the paper (joints 4-6 locked)."""
    return load_robot("puma560")


@pytest.fixture(scope="session")
def planar():
    """The planar two-link test arm."""
    return load_robot("planar2")


@pytest.fixture(scope="session")
def odd_base():
    """A base body with an off-centre centre of mass, full inertia and an offset, tilted mount,
    so that eq 8's moment arm r_gh and centroidal inertia are exercised in every component."""
    inertia = np.array([[0.9, 0.05, -0.02], [0.05, 1.2, 0.03], [-0.02, 0.03, 0.7]])
    mount = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.05, -0.03, 0.2]))
    return BaseBody(mass=7.5, inertia=inertia, com=np.array([0.02, -0.01, 0.05]), mount=mount)
