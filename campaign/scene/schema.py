"""The trial schema: every channel a trial records, with units, meaning and sampling clock.

This is the contract between the stages. The rig fills it, the archive validates and
documents it (the campaign README is generated from it), identification reads only the
``measured`` group. Change it only with a schema-version bump.

A trial is an ``xarray.DataTree`` with two groups:

``/measured``  what a real VES-II records (noisy, quantised, each channel on its own clock),
               plus the instrument constants an experimenter knows (hammer effective mass,
               pendulum radius, impact direction, robot model, the commanded configuration);
``/truth``     what only the simulator knows (exact states, true contact force and interval,
               true velocities at the contact edges); identification never reads it.

Every time coordinate is in seconds from the start of the recording; the contact happens
at an unknown (seeded, jittered) instant inside it, as on a real rig.

:class:`TrialArrays` holds the same trial as plain arrays (what the rig records before any
xarray object is built); the archive stores either form as the same file.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..core.vocabulary import FIXED, FLEXIBLE

if TYPE_CHECKING:
    import numpy as np

__all__ = ["SCHEMA_VERSION", "Clock", "Var", "CLOCKS", "MEASURED", "TRUTH", "variables", "FIXED_ONLY", "FLEXIBLE_ONLY",
           "ChannelArray", "GroupArrays", "TrialArrays"]

#: major.minor: a reader accepts files of the same major version and refuses a newer major.
SCHEMA_VERSION = "1.1"


@dataclasses.dataclass(frozen=True)
class Clock:
    """A sampling clock: one time dimension of the trial file."""

    dim: str
    long_name: str
    rate_key: str  # scene parameter that sets its rate [Hz], for the generated README


@dataclasses.dataclass(frozen=True)
class Var:
    """One channel or constant of the trial file."""

    name: str
    dims: tuple[str, ...]
    units: str
    long_name: str
    bases: tuple[str, ...] = (FIXED, FLEXIBLE)  # scenes that carry it


CLOCKS = {
    "t_joint": Clock("t_joint", "joint encoder sample time", "sensors.joint_encoder_rate"),
    "t_pend": Clock("t_pend", "pendulum encoder sample time", "sensors.pendulum_encoder_rate"),
    "t_force": Clock("t_force", "piezo force sample time", "sensors.piezo_rate"),
    "t_ft": Clock("t_ft", "base force/torque sensor sample time", "sensors.ft_rate"),
    "t_servo": Clock("t_servo", "servo (controller) tick time", "controller.servo_rate"),
    "t_base": Clock("t_base", "VES emulator step time", "ves.rate"),
    "t_truth": Clock("t_truth", "simulator truth sample time", "sensors.truth_rate"),
}

_FLEX = (FLEXIBLE,)

MEASURED = (
    # channels
    Var("q_enc", ("t_joint", "joint"), "rad", "joint angle from the joint encoders (DH convention)"),
    Var("theta_pend", ("t_pend",), "rad", "pendulum angle from the pivot encoder, 0 at the bottom, positive along n"),
    Var("f_piezo", ("t_force",), "N", "impact force from the piezo sensor at the hammer head"),
    Var("ft_force", ("t_ft", "axis"), "N", "force of the arm on its mounting, base F/T sensor, base frame"),
    Var("ft_torque", ("t_ft", "axis"), "N m", "moment of the arm on its mounting about the sensor origin, base frame"),
    Var("tau_cmd", ("t_servo", "joint"), "N m", "commanded joint torque (controller output after saturation, incl. gravity compensation)"),
    Var("base_position", ("t_base", "axis"), "m", "emulated base (structure tip) displacement from its initial position", _FLEX),
    Var("base_rotation", ("t_base", "axis"), "rad", "emulated base rotation vector from its initial attitude", _FLEX),
    Var("platform_cmd_position", ("t_base", "axis"), "m", "platform position command sent by the emulator", _FLEX),
    Var("platform_cmd_rotation", ("t_base", "axis"), "rad", "platform rotation-vector command sent by the emulator", _FLEX),
    Var("platform_position", ("t_base", "axis"), "m", "platform position measured (actual)", _FLEX),
    Var("platform_rotation", ("t_base", "axis"), "rad", "platform rotation vector measured (actual)", _FLEX),
    # instrument constants, known to the experimenter
    Var("q_cmd", ("joint",), "rad", "commanded (nominal) joint angles before the impact (DH convention)"),
    Var("hammer_mass_eff", (), "kg", "effective mass m_b of the pendulum at the hammer head (I_pivot / r^2)"),
    Var("pendulum_radius", (), "m", "distance from the pendulum pivot to the hammer contact point"),
    Var("impact_direction", ("axis",), "1", "unit impact direction n, base frame"),
    Var("piezo_full_scale", (), "N", "piezo sensor saturation level"),
    Var("base_mass", (), "kg", "emulated base mass (structure tip modal mass + platform)", _FLEX),
    Var("base_inertia", ("axis", "axis2"), "kg m2", "emulated base rotational inertia about its centre of mass", _FLEX),
    Var("base_com", ("axis",), "m", "emulated base centre of mass in the base (structure tip) frame", _FLEX),
    Var("base_mount", ("axis",), "m", "origin of the arm's base frame (F/T sensor) in the base (structure tip) frame", _FLEX),
)

TRUTH = (
    Var("q", ("t_truth", "joint"), "rad", "true joint angle"),
    Var("v", ("t_truth", "joint"), "rad s-1", "true joint velocity"),
    Var("theta", ("t_truth",), "rad", "true pendulum angle"),
    Var("theta_dot", ("t_truth",), "rad s-1", "true pendulum angular velocity"),
    Var("f_contact", ("t_truth",), "N", "true contact force along n (>= 0)"),
    Var("tip_velocity_n", ("t_truth",), "m s-1", "true velocity of the impact point along n"),
    Var("energy", ("t_truth",), "J", "total mechanical energy of arm, hammer, contact spring (and base)"),
    Var("contact_start", (), "s", "true contact start time"),
    Var("contact_end", (), "s", "true contact end time"),
    Var("v_a_pre", (), "m s-1", "true arm tip velocity along n at contact start"),
    Var("v_a_post", (), "m s-1", "true arm tip velocity along n at contact end"),
    Var("v_b_pre", (), "m s-1", "true hammer velocity along n at contact start"),
    Var("v_b_post", (), "m s-1", "true hammer velocity along n at contact end"),
    Var("impulse", (), "N s", "true contact impulse (integral of the contact force)"),
    Var("peak_force", (), "N", "true peak contact force"),
    Var("e_contact", (), "1", "restitution coefficient the contact model is set for"),
    Var("base_position", ("t_truth", "axis"), "m", "true base (structure tip) displacement", _FLEX),
    Var("base_rotation", ("t_truth", "axis"), "rad", "true base rotation vector", _FLEX),
    Var("base_velocity", ("t_truth", "axis"), "m s-1", "true base linear velocity, base-frame origin, world axes", _FLEX),
    Var("base_omega", ("t_truth", "axis"), "rad s-1", "true base angular velocity, world axes", _FLEX),
)

#: coordinate values of the non-time dimensions
COORDS = {"joint": None, "axis": ("x", "y", "z"), "axis2": ("x", "y", "z")}  # joint: the robot's active joint names

#: variables only a fixed-base or a flexible-base trial carries
FLEXIBLE_ONLY = tuple(v.name for v in MEASURED + TRUTH if v.bases == _FLEX)
FIXED_ONLY: tuple[str, ...] = ()


def variables(group: str, base: str) -> tuple[Var, ...]:
    """The variables of ``group`` ("measured" or "truth") that a ``base`` scene carries."""
    table = {"measured": MEASURED, "truth": TRUTH}[group]
    return tuple(v for v in table if base in v.bases)


@dataclasses.dataclass(frozen=True)
class ChannelArray:
    """One variable of a trial as plain arrays: what an :class:`xarray.Variable` holds."""

    dims: tuple[str, ...]
    values: np.ndarray
    attrs: dict[str, Any]

    @property
    def dtype(self) -> np.dtype:
        return self.values.dtype


class GroupArrays:
    """One group of a trial (``measured`` or ``truth``) as plain arrays.

    It offers the parts of an :class:`xarray.Dataset` the archive writer's validation and
    identification read: ``data_vars``, ``coords``, ``variables`` (both), ``dims`` (in order
    of first use, data variables first, as xarray orders them), ``sizes``, ``attrs`` and
    ``group[name]`` (a :class:`ChannelArray`, with ``values`` and ``dims``).

    Parameters
    ----------
    data_vars, coords : dict of str to ChannelArray
        The channels, and the coordinates of the group's dimensions (time in seconds on
        each clock, label names).
    attrs : dict, optional
        Group attributes.
    """

    __slots__ = ("data_vars", "coords", "variables", "dims", "sizes", "attrs")

    def __init__(self, data_vars: Mapping[str, ChannelArray], coords: Mapping[str, ChannelArray],
                 attrs: Mapping[str, Any] | None = None):
        self.data_vars = dict(data_vars)
        self.coords = dict(coords)
        self.variables = {**self.data_vars, **self.coords}
        self.dims = tuple(dict.fromkeys(d for v in self.variables.values() for d in v.dims))
        #: length of each dimension (as :attr:`xarray.Dataset.sizes`)
        self.sizes = {d: n for v in self.variables.values() for d, n in zip(v.dims, v.values.shape, strict=True)}
        self.attrs = dict(attrs or {})

    def __getitem__(self, name: str) -> ChannelArray:
        return self.variables[name]

    def __contains__(self, name: object) -> bool:
        return name in self.variables

    def __repr__(self) -> str:
        return (f"<GroupArrays: dims {self.sizes}, data variables {list(self.data_vars)}, "
                f"{len(self.attrs)} attributes>")


@dataclasses.dataclass
class TrialArrays:
    """A trial as plain arrays: root attributes and the groups ``measured`` and ``truth``.

    ``campaign.archive.write_trial`` stores it exactly as it stores the same trial given as
    an :class:`xarray.DataTree` (``campaign.rig.trial.to_tree`` builds that tree), without
    building xarray objects or importing xarray: a simulation job then does not pay ~0.7 s
    for importing xarray and pandas (``campaign.rig.simulate_arrays``).
    """

    attrs: dict[str, Any]
    groups: dict[str, GroupArrays]

    def __getitem__(self, group: str) -> GroupArrays:
        return self.groups[group]
