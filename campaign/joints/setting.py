"""What a joint-resistance model takes as known: the rig file's contact law, hammer, servo and
structures, the robot, and the digests that tie a fitted model to them.

A joint-resistance model fits the joints' own resistance (damping, friction, or a lambda);
everything else it needs is the rig's documented design, read from the rig file
(``config/rig.yaml``) and the paper's Table 1 gains (``config/paper.yaml``): the contact law
(:class:`campaign.rig.contact.ContactLaw`), the hammer's effective mass, gravity, the servo's
gains in joint units and its period, the named structures (:class:`campaign.rig.beam.Beam`) and
the VES-II loop. The arm's friction and damping in the rig file (``arm.*``) are what the
models estimate; no model reads them. :class:`Setting` carries those values with the
sha256 of the files they come from (:func:`file_digest`), which a saved model records and
a loaded model checks.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.files import sha256_file
from ..core.yamlfile import PROJECT_DIR, config_file, read_yaml
from ..model.paper import load_paper
from ..model.robot import Robot, load_robot, robot_dir
from ..rig.beam import Beam
from ..rig.contact import ContactLaw
from ..rig.controller import joint_gains
from ..rig.pendulum import Pendulum
from ..scene.description import load_structures, rig_values
from .emulated_base import Loop

__all__ = ["Setting", "file_digest", "robot_digests", "display_path"]


def file_digest(path) -> str:
    """sha256 of a file's bytes (hex)."""
    try:
        return sha256_file(path)
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None


def display_path(path) -> str:
    """``path`` relative to the project folder where it lies inside it (so a record made in
    one checkout reads the same in another), else as given."""
    p = Path(path).resolve()
    try:
        return p.relative_to(PROJECT_DIR).as_posix()
    except ValueError:
        return str(path)


def robot_digests(robot_name) -> dict[str, str]:
    """sha256 of a robot's parameter files: its drive file and its URDF, by file name."""
    try:
        folder = robot_dir(robot_name)
        drives = folder / "drives.yaml"
        urdf = folder / str(read_yaml(drives)["urdf"])
    except (OSError, KeyError, TypeError, ValueError) as exc:
        raise InputError(f"robot {robot_name}: cannot read its drive file: {exc}") from None
    return {drives.name: file_digest(drives), urdf.name: file_digest(urdf)}


@dataclasses.dataclass(frozen=True)
class Setting:
    """The rig and robot a joint-resistance model is fitted and used on.

    Attributes
    ----------
    robot : campaign.model.robot.Robot
    contact : campaign.rig.contact.ContactLaw
        The contact law (``contact.*``).
    hammer_mass : float
        The hammer's effective mass at its head ``m_b`` [kg] (eq 10).
    hammer_stiffness : float
        The pendulum's gravity restoring stiffness at its head, ``m g l_c / r^2`` [N/m]: over
        the contact it takes momentum from the hammer that eq 10 counts.
    gravity : float
        [m/s^2]
    servo_period : float
        The digital servo's period [s] (``controller.servo_rate``).
    gains : dict of str to (Kp, Kd)
        Every gain set of the paper's Table 1 in joint units [N m/rad, N m s/rad].
    structure : str
        The flexible base's named structure.
    beam : campaign.rig.beam.Beam
        Its tip model (``M_s``, ``K_s``, ``B_s``).
    loop : campaign.joints.emulated_base.Loop or None
        The VES-II loop (``ves.mode = loop``); None when the rig couples ideally.
    rig_file, paper_file : str
        The files the values come from (relative to the project where inside it).
    digests : dict
        sha256 of the rig file, the paper file and the robot's files.
    """

    robot: Robot
    contact: ContactLaw
    hammer_mass: float
    hammer_stiffness: float
    gravity: float
    servo_period: float
    gains: dict
    structure: str
    beam: Beam
    loop: Loop | None
    rig_file: str
    paper_file: str
    digests: dict

    @classmethod
    def from_rig(cls, rig=None, *, structure: str | None = None, robot: Robot | None = None) -> Setting:
        """The setting of a rig file (default ``config/rig.yaml``), its flexible base under the
        named ``structure`` (default the file's own)."""
        rig_path = Path(rig) if rig is not None else config_file("rig.yaml")
        if not rig_path.is_file():
            raise InputError(f"rig file {rig_path} does not exist")
        if structure is not None and structure not in load_structures(rig_path):
            raise InputError(f"unknown structure {structure!r}; the rig file names {sorted(load_structures(rig_path))}")
        values: dict[str, Any] = rig_values(rig=rig_path, params={"flexible.structure": structure} if structure else None)
        robot = load_robot(str(values["robot"])) if robot is None else robot
        gains = {}
        for name in load_paper()["gains"]:
            kp, kd, _ = joint_gains(str(name), values=values, robot=robot)
            gains[str(name)] = (np.asarray(kp, float), np.asarray(kd, float))
        paper_path = config_file("paper.yaml")
        digests = {"rig": file_digest(rig_path), "paper": file_digest(paper_path),
                   "robot": robot_digests(str(values["robot"]))}
        loop = Loop.from_values(values) if str(values["ves.mode"]) == "loop" else None
        pend = Pendulum.from_values(values)
        return cls(robot=robot, contact=ContactLaw.from_values(values), hammer_mass=float(pend.m_b),
                   hammer_stiffness=float(pend.mgl) / float(pend.radius) ** 2,
                   gravity=float(values["gravity"]), servo_period=1.0 / float(values["controller.servo_rate"]),
                   gains=gains, structure=str(values["flexible.structure"]), beam=Beam.from_values(values), loop=loop,
                   rig_file=display_path(rig_path), paper_file=display_path(paper_path), digests=digests)

    def rig_path(self) -> Path:
        """The rig file as a path to open: :attr:`rig_file` is shown relative to the project
        folder, whatever the working folder."""
        p = Path(self.rig_file)
        return p if p.is_absolute() or not (PROJECT_DIR / p).is_file() else PROJECT_DIR / p

    def servo(self, gain_sets) -> tuple[np.ndarray, np.ndarray]:
        """``(Kp, Kd)`` of each named gain set, shape (N, nv) each; InputError for an unknown one."""
        kp, kd = [], []
        for g in gain_sets:
            if g not in self.gains:
                raise InputError(f"unknown gain set {g!r}; the paper's Table 1 names {sorted(self.gains)}")
            kp.append(self.gains[g][0])
            kd.append(self.gains[g][1])
        nv = self.robot.nv
        return np.reshape(kp, (-1, nv)), np.reshape(kd, (-1, nv))
