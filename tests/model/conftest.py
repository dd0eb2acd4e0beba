"""The model tests' shared fixture: a base body that exercises every term of eq 8."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from campaign.model.robot.floating import BaseBody


@pytest.fixture(scope="session")
def odd_base():
    """A base body with an off-centre centre of mass, full inertia and an offset, tilted mount,
    so that eq 8's moment arm r_gh and centroidal inertia are exercised in every component."""
    inertia = np.array([[0.9, 0.05, -0.02], [0.05, 1.2, 0.03], [-0.02, 0.03, 0.7]])
    mount = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.05, -0.03, 0.2]))
    return BaseBody(mass=7.5, inertia=inertia, com=np.array([0.02, -0.01, 0.05]), mount=mount)
