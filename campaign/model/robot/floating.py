"""An arm mounted on a moving base: the Pinocchio free-flyer model of base + arm.

The flexible long-reach structure of the paper transmits no impulse through its spring and
damper during the impulsive phase, so there the base is a free body of mass/inertia ``M``
(paper, eq 8). This module builds that system as one Pinocchio model: a free-flyer root
joint carrying the base body, with the arm's reduced model appended at the mounting
frame. It serves both the Ex-IIT check of eq 8 and the ideally coupled flexible rig.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from ...core.errors import InputError
from . import Robot

__all__ = ["BaseBody", "FloatingRobot", "attach_to_floating_base"]


@dataclasses.dataclass(frozen=True)
class BaseBody:
    """Rigid body the arm stands on (platform plus the structure's tip modal mass).

    Attributes
    ----------
    mass : float
        Base mass [kg], > 0.
    inertia : ndarray, shape (3, 3)
        Rotational inertia about the base's centre of mass, base frame [kg m^2].
    com : ndarray, shape (3,)
        Centre of mass in the base frame [m].
    mount : pinocchio.SE3
        Placement of the arm's base frame in the base frame.
    """

    mass: float
    inertia: np.ndarray
    com: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    mount: pin.SE3 = dataclasses.field(default_factory=pin.SE3.Identity)

    def __post_init__(self):
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ValueError(f"base mass must be > 0 kg, got {self.mass!r}")
        inertia = np.asarray(self.inertia, dtype=float)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
            raise ValueError(f"base inertia must be a finite 3x3 matrix, got {inertia!r}")
        if np.min(np.linalg.eigvalsh(0.5 * (inertia + inertia.T))) <= 0:
            raise ValueError(f"base inertia must be positive definite, got {inertia.tolist()}")

    @property
    def spatial_inertia(self) -> pin.Inertia:
        return pin.Inertia(float(self.mass), np.asarray(self.com, float), np.asarray(self.inertia, float))


@dataclasses.dataclass(frozen=True)
class FloatingRobot:
    """Base + arm as one free-flyer Pinocchio model.

    ``q = [base position (3), base quaternion (4), arm q]``,
    ``v = [base twist in the base frame (6), arm v]``.
    """

    robot: Robot
    base: BaseBody
    model: pin.Model
    impact_frame_id: int
    mount_frame_id: int

    @property
    def nv_arm(self) -> int:
        return self.robot.nv

    def q_full(self, q_arm, base_pose: pin.SE3 | None = None) -> np.ndarray:
        """Full configuration from the arm's ``q`` and the base pose (identity by default)."""
        pose = pin.SE3.Identity() if base_pose is None else base_pose
        return np.concatenate([pin.SE3ToXYZQUAT(pose), np.asarray(q_arm, float)])


def attach_to_floating_base(robot: Robot, base: BaseBody) -> FloatingRobot:
    """Mount ``robot`` on a free-flying ``base`` and return the combined model.

    The arm's armature (reflected rotor inertia) is kept; the free-flyer joint has none.
    """
    root = pin.Model()
    root.name = f"{robot.name}_on_base"
    jid = root.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    root.appendBodyToJoint(jid, base.spatial_inertia, pin.SE3.Identity())
    body = root.addBodyFrame("base_body", jid, pin.SE3.Identity(), 0)
    mount = root.addFrame(pin.Frame("arm_mount", jid, body, base.mount, pin.FrameType.OP_FRAME))
    model = pin.appendModel(root, robot.model, mount, pin.SE3.Identity())
    model.armature = np.concatenate([np.zeros(6), robot.armature])
    impact_name = robot.model.frames[robot.impact_frame_id].name
    return FloatingRobot(
        robot=robot,
        base=base,
        model=model,
        impact_frame_id=int(model.getFrameId(impact_name)),
        mount_frame_id=int(model.getFrameId("arm_mount")),
    )


def base_body_of(record: Mapping):
    """The emulated base of a flexible-base record as a BaseBody: mass, inertia about its
    centre of mass, centre of mass and the arm's mount (translation) in the base frame."""


    mass = record.get("base_mass")
    inertia = record.get("base_inertia")
    if mass is None or not math.isfinite(float(mass)) or not inertia or len(inertia) != 9:
        raise InputError(f"flexible-base record {record.get('path') or ''} has no base_mass/base_inertia")
    com = np.asarray(record.get("base_com") or (0.0, 0.0, 0.0), float)
    mount = np.asarray(record.get("base_mount") or (0.0, 0.0, 0.0), float)
    return BaseBody(mass=float(mass), inertia=np.asarray(inertia, float).reshape(3, 3), com=com,
                    mount=pin.SE3(np.eye(3), mount))

