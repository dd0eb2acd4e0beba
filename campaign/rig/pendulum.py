"""The impact device: a pendulum with a steel hammer head, a piezo sensor and a pivot encoder.

The pendulum swings in the vertical plane that holds n; ``theta = 0`` at the bottom, where
the head moves along n and touches the (undeformed) arm tip. The head is a point mass at
radius ``r``; the rod is uniform. About the pivot:

    I_p = m_head r^2 + m_rod r^2 / 3,     m g l_c = (m_head r + m_rod r / 2) g,

and the effective mass at the head along its path is ``m_b = I_p / r^2`` (eq 10's m_b).

The swing before the contact is analytic (exact elliptic solution of the pendulum), so no
step is spent on it: released at rest from ``theta_0``, the pendulum passes the bottom with
``r thetadot = v`` and, with ``t = 0`` at the bottom,

    theta(t) = 2 asin(k sn(w t | k^2)),   thetadot(t) = 2 k w cn(w t | k^2),

``k = sin(theta_0 / 2)``, ``w = sqrt(m g l_c / I_p)``, valid back to the release at
``t = -K(k^2) / w``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.special import ellipj, ellipk

from ..core.errors import InputError
from ..scene.description import hammer_reach

__all__ = ["Pendulum"]


@dataclasses.dataclass(frozen=True)
class Pendulum:
    """Pendulum impact device.

    Attributes
    ----------
    head_mass, rod_mass : float
        [kg]
    radius : float
        Pivot to the head's contact point [m].
    gravity : float
        [m/s^2]; 0 makes the swing a uniform rotation.
    max_release_deg : float
        Largest release angle the device allows [deg].
    """

    head_mass: float
    rod_mass: float
    radius: float
    gravity: float
    max_release_deg: float = 170.0

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> Pendulum:
        """The pendulum of flat rig values (``pendulum.*`` and ``gravity``, dotted keys)."""
        return cls(float(values["pendulum.head_mass"]), float(values["pendulum.rod_mass"]),
                   float(values["pendulum.radius"]), float(values["gravity"]),
                   float(values["pendulum.max_release_deg"]))

    @classmethod
    def from_scene(cls, scene) -> Pendulum:
        """The pendulum of a :class:`~campaign.scene.description.Scene`."""
        return cls.from_values(scene.param_dict)

    def __post_init__(self):
        if not (self.head_mass > 0 and math.isfinite(self.head_mass)):
            raise InputError(f"pendulum head_mass must be > 0 kg, got {self.head_mass!r}")
        if not (self.rod_mass >= 0 and math.isfinite(self.rod_mass)):
            raise InputError(f"pendulum rod_mass must be >= 0 kg, got {self.rod_mass!r}")
        if not (self.radius > 0 and math.isfinite(self.radius)):
            raise InputError(f"pendulum radius must be > 0 m, got {self.radius!r}")

    @property
    def inertia(self) -> float:
        """Inertia about the pivot ``I_p`` [kg m^2]."""
        return self.head_mass * self.radius**2 + self.rod_mass * self.radius**2 / 3.0

    @property
    def mgl(self) -> float:
        """Gravity moment coefficient ``m g l_c`` [N m]."""
        return (self.head_mass * self.radius + 0.5 * self.rod_mass * self.radius) * self.gravity

    @property
    def m_b(self) -> float:
        """Effective mass at the head along its path ``I_p / r^2`` [kg] (eq 10)."""
        return self.inertia / self.radius**2

    @property
    def omega(self) -> float:
        """Small-swing angular frequency ``sqrt(m g l_c / I_p)`` [rad/s]."""
        return math.sqrt(self.mgl / self.inertia)

    @property
    def max_speed(self) -> float:
        """Head speed at the bottom from the largest release angle [m/s] (``inf`` without
        gravity, where the hammer is launched at the asked speed)."""
        return hammer_reach(self.head_mass, self.rod_mass, self.radius, self.gravity, self.max_release_deg)

    def release_angle(self, speed: float) -> float:
        """Release angle [rad] that gives head speed ``speed`` [m/s] at the bottom.

        Raises InputError when the device cannot reach that speed.
        """
        if not (math.isfinite(speed) and speed > 0):
            raise InputError(f"impact speed must be > 0 m/s, got {speed!r}")
        if self.gravity == 0:
            return 0.0  # no gravity: the hammer is launched at the speed (ideal scene)
        c = 1.0 - self.inertia * (speed / self.radius) ** 2 / (2.0 * self.mgl)
        theta0 = math.acos(c) if c >= -1.0 else math.inf
        if not theta0 <= math.radians(self.max_release_deg):
            raise InputError(
                f"impact speed {speed} m/s is beyond what the pendulum can reach "
                f"(max {self.max_speed:.3f} m/s at its {self.max_release_deg} deg release limit)"
            )
        return theta0

    def swing(self, t, speed: float):
        """Analytic swing before the contact: ``(theta, thetadot)`` at times ``t <= 0``
        [s, relative to the arrival at the bottom], for arrival head speed ``speed``.

        Before the release the pendulum rests at the release angle (theta < 0 side).
        """
        t = np.asarray(t, dtype=float)
        w_bottom = speed / self.radius
        if self.gravity == 0:
            return w_bottom * t, np.full_like(t, w_bottom)
        theta0 = self.release_angle(speed)
        k = math.sin(theta0 / 2.0)
        m = k * k
        w = self.omega
        t_release = -ellipk(m) / w
        tt = np.maximum(t, t_release)
        sn, cn, _, _ = ellipj(w * tt, m)
        theta = 2.0 * np.arcsin(np.clip(k * sn, -1.0, 1.0))
        thetadot = 2.0 * k * w * cn
        before = t < t_release
        theta = np.where(before, -theta0, theta)
        thetadot = np.where(before, 0.0, thetadot)
        return theta, thetadot

    def head_position(self, theta):
        """Head displacement along n from the bottom point ``r sin(theta)`` [m]."""
        return self.radius * np.sin(theta)
