"""Shared fixtures: the robots (loaded once per session) and a hypothesis profile."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import settings

from campaign.model.robot import load_robot
from campaign.model.robot.floating import BaseBody

# Pinocchio's first calls are slower than the rest; a per-example deadline would flake.
settings.register_profile("campaign", deadline=None, max_examples=60)
settings.load_profile("campaign")


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
