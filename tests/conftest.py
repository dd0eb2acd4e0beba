"""Shared fixtures and the run's settings.

- One BLAS thread per process, set before numpy loads, here and in every command a test
  starts (an explicit setting in the environment is kept). The suite runs on two test
  processes (pytest-xdist, ``pyproject.toml``); BLAS threads on top of them only wait for
  each other (identification at 1 kHz takes several times the CPU with two of them).
- The test files with the most end-to-end (``slow``) tests run first, each file's tests in
  their order in one process (``--dist loadfile``), so the longest files start first and the
  two processes finish together.
- The robots, loaded once per process, and a hypothesis profile.

A fixture only one package's tests use lives in that folder's ``conftest.py`` (the reduced
campaign's run in ``tests/workflow/``, the off-centre base body in ``tests/model/``).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys
from collections import Counter

import pytest
from hypothesis import settings

from campaign.model.robot import load_robot

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


@pytest.fixture(scope="session")
def puma():
    """The PUMA 560 of the paper (joints 4-6 locked)."""
    return load_robot("puma560")


@pytest.fixture(scope="session")
def planar():
    """The planar two-link test arm."""
    return load_robot("planar2")
