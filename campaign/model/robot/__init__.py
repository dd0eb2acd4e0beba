"""Robot models: a URDF plus a drive-parameter file, loaded into Pinocchio.

A robot is described by two files in one folder:

* a URDF with the links' kinematics and rigid-body inertias (the lingua franca of
  robot models), and
* ``drives.yaml`` with what a URDF cannot say: rotor inertia ``Jm``, gear ratio ``G``,
  motor-side viscous ``B`` and Coulomb ``Tc_pos``/``Tc_neg`` friction, peak joint torque
  ``tau_max``, encoder resolution, which joints move, where the others are locked, where
  the impact point is, and the robot's pose conventions (the offset of the angles users
  give poses in, its numbered configurations: :mod:`campaign.model.conventions`), and
  optionally how the impact point's inverse kinematics is solved (``position_ik``).

:func:`load_robot` turns them into a :class:`Robot`: a Pinocchio ``model`` reduced to the
active joints (the locked links ride on the last active one), with
``model.armature = Jm G^2`` (the reflected rotor inertia, part of the "link dynamics" of
the paper's Table 2) and an operational frame at the impact point. Drive values are
referred to the joint side once, here, so no later stage has to remember the gearing.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np
import pinocchio as pin

from ...core.yamlfile import parse_yaml_bytes, read_yaml_bytes
from ..conventions import ROBOTS_DIR, robot_dir
from .elbow import POSITION_IK, elbow_geometry

__all__ = ["Robot", "load_robot", "robot_dir", "ROBOTS_DIR"]

_DRIVE_KEYS = ("Jm", "G", "B", "Tc_pos", "Tc_neg", "tau_max", "encoder_resolution")


@dataclasses.dataclass(frozen=True)
class Robot:
    """A robot arm ready for dynamics, with its drives referred to the joint side.

    Attributes
    ----------
    name : str
        Robot name from the drive file.
    model : pinocchio.Model
        Reduced model (active joints only), ``armature`` set to ``Jm G^2``.
    impact_frame_id : int
        Id in ``model`` of the impact-point frame.
    joint_names : tuple of str
        Names of the active joints, in ``q`` order.
    armature : ndarray, shape (nv,)
        Reflected rotor inertia ``Jm G^2`` [kg m^2].
    viscous : ndarray, shape (nv,)
        Joint-side viscous friction ``B G^2`` [N m s/rad].
    coulomb_pos, coulomb_neg : ndarray, shape (nv,)
        Joint-side Coulomb friction magnitudes ``|Tc| |G|`` for joint velocity > 0 and
        < 0 [N m], both >= 0.
    tau_max : ndarray, shape (nv,)
        Peak joint torque [N m].
    encoder_resolution : ndarray, shape (nv,)
        Joint-side encoder resolution [rad per count].
    q_lower, q_upper : ndarray, shape (nq,)
        Joint limits [rad], inclusive.
    angle_offset_deg : ndarray, shape (nv,)
        Offset [deg] from the angles a pose is given in (``--q``, configurations) to the
        model's: ``q = radians(angle + angle_offset_deg)``.
    source : str
        Path of the drive file the robot was loaded from.
    position_ik : str
        How the impact point's inverse kinematics is solved
        (:func:`campaign.model.robot.ik.position_branches_many`): ``"elbow"`` in closed form,
        for an arm whose geometry is an elbow arm's (:mod:`campaign.model.robot.elbow`),
        ``"iterative"`` for any other (or when the drive file's ``position_ik`` says so).
    """

    name: str
    model: pin.Model
    impact_frame_id: int
    joint_names: tuple[str, ...]
    armature: np.ndarray
    viscous: np.ndarray
    coulomb_pos: np.ndarray
    coulomb_neg: np.ndarray
    tau_max: np.ndarray
    encoder_resolution: np.ndarray
    q_lower: np.ndarray
    q_upper: np.ndarray
    angle_offset_deg: np.ndarray
    source: str
    position_ik: str = "iterative"

    @property
    def nv(self) -> int:
        return self.model.nv

    def check_q(self, q, *, what: str = "q") -> np.ndarray:
        """Return ``q`` as a float array, or raise ValueError naming a bad angle.

        Limits are inclusive (configuration 3 of the paper sits exactly on joint 3's
        +45 deg DH limit); a tolerance of 1e-9 rad absorbs degree-radian round-off.
        """
        q = np.asarray(q, dtype=float)
        if q.shape != (self.model.nq,):
            raise ValueError(f"{what} must have {self.model.nq} angles, got shape {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError(f"{what} = {q.tolist()} is not finite")
        tol = 1e-9
        for i, name in enumerate(self.joint_names):
            if not (self.q_lower[i] - tol <= q[i] <= self.q_upper[i] + tol):
                raise ValueError(
                    f"{what}: joint {name} angle {np.degrees(q[i]):.6g} deg (DH) is outside its "
                    f"limits [{np.degrees(self.q_lower[i]):.6g}, {np.degrees(self.q_upper[i]):.6g}] deg"
                )
        return q

    def q_from_angles(self, angles_deg, *, what: str = "pose") -> np.ndarray:
        """The model's angles ``q = radians(angles_deg + angle_offset_deg)`` [rad] of a pose
        given in the robot's own angles [deg], checked as :meth:`check_q` checks them; raises
        ValueError naming the pose and, for a wrong count, the number of angles the robot takes."""
        angles = np.asarray(angles_deg, dtype=float)
        if angles.shape != self.angle_offset_deg.shape:
            raise ValueError(f"{what}: robot {self.name} takes {self.angle_offset_deg.size} joint angles "
                             f"({', '.join(self.joint_names)}), got {angles.ravel().tolist()}")
        return self.check_q(np.radians(angles + self.angle_offset_deg), what=what)


def load_robot(name_or_path: str | Path = "puma560") -> Robot:
    """Load a robot from its URDF and drive file.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped robot name (``"puma560"``, ``"planar2"``), a folder holding
        ``drives.yaml``, or the path of a drive file.

    Returns
    -------
    Robot
    """
    folder = robot_dir(name_or_path)
    drive_file = Path(name_or_path) if Path(name_or_path).is_file() else folder / "drives.yaml"
    drive_content = read_yaml_bytes(drive_file, what="drive file")
    spec = parse_yaml_bytes(str(drive_file), drive_content)
    urdf = folder / spec["urdf"]
    try:
        with open(urdf, "rb") as fh:
            urdf_content = fh.read()
    except OSError:
        urdf_content = None          # Pinocchio reports the missing file, as before
    robot = _load_robot(str(drive_file), drive_content, str(urdf), urdf_content)
    # a fresh model and arrays per call (callers may modify them), as from a fresh parse
    return dataclasses.replace(robot, model=robot.model.copy(), **{
        f.name: getattr(robot, f.name).copy() for f in dataclasses.fields(robot)
        if isinstance(getattr(robot, f.name), np.ndarray)})


@functools.lru_cache(maxsize=16)
def _load_robot(drive_file: str, drive_content: bytes, urdf: str, urdf_content: bytes | None) -> Robot:
    """The robot of a drive file and its URDF, built once per content of both files (an
    edited file is picked up at the next call; the key holds their bytes)."""
    return _build_robot(Path(drive_file), parse_yaml_bytes(drive_file, drive_content), urdf)


def _build_robot(drive_file: Path, spec: dict, urdf: str) -> Robot:
    """Build the robot from a parsed drive file (not modified: it is the cached parse)."""
    full = pin.buildModelFromUrdf(urdf)

    locked = spec.get("locked_q") or {}
    active = list(spec["active_joints"])
    all_names = [full.names[i] for i in range(1, full.njoints)]
    for name in list(locked) + active:
        if name not in all_names:
            raise ValueError(f"{drive_file}: joint {name!r} is not in the URDF (joints: {all_names})")
    missing = [n for n in all_names if n not in locked and n not in active]
    if missing:
        raise ValueError(f"{drive_file}: joints {missing} are neither active nor locked")

    q_ref = pin.neutral(full)
    for name, value in locked.items():
        q_ref[full.joints[full.getJointId(name)].idx_q] = float(value)
    if locked:
        model = pin.buildReducedModel(full, [full.getJointId(n) for n in locked], q_ref)
    else:
        model = full
    names = tuple(model.names[i] for i in range(1, model.njoints))
    if list(names) != active:
        raise ValueError(f"{drive_file}: active_joints {active} must follow the URDF order {list(names)}")

    drives = spec["joints"]
    vals = {}
    for key in _DRIVE_KEYS:
        try:
            vals[key] = np.array([float(drives[n][key]) for n in names])
        except KeyError as exc:
            raise ValueError(f"{drive_file}: drive parameter {exc} missing for an active joint") from None
    for key in ("Jm", "B", "tau_max", "encoder_resolution"):
        if np.any(vals[key] < 0) or (key in ("tau_max", "encoder_resolution") and np.any(vals[key] == 0)):
            raise ValueError(f"{drive_file}: {key} = {vals[key].tolist()} must be positive")
    offset = spec.get("angle_offset_deg")
    offset = np.zeros(len(names)) if offset is None else np.asarray(offset, dtype=float)
    if offset.shape != (len(names),) or not np.all(np.isfinite(offset)):
        raise ValueError(f"{drive_file}: angle_offset_deg must be {len(names)} finite angles [deg], one per "
                         f"active joint, got {spec.get('angle_offset_deg')!r}")
    G = vals["G"]
    armature = vals["Jm"] * G**2
    model.armature = armature.copy()

    position_ik = spec.get("position_ik", "auto")
    if position_ik not in ("auto", *POSITION_IK):
        raise ValueError(f"{drive_file}: position_ik = {position_ik!r} must be one of auto, {', '.join(POSITION_IK)}")

    imp = spec["impact_frame"]
    parent = model.getFrameId(imp["parent_frame"])
    if parent >= model.nframes:
        raise ValueError(f"{drive_file}: impact parent frame {imp['parent_frame']!r} not in the model")
    pf = model.frames[parent]
    placement = pf.placement * pin.SE3(np.eye(3), np.asarray(imp["xyz"], dtype=float))
    fid = model.addFrame(pin.Frame(imp["name"], pf.parentJoint, parent, placement, pin.FrameType.OP_FRAME))
    if position_ik in ("auto", "elbow"):
        try:
            elbow_geometry(model, fid, where=str(drive_file))     # the closed form fits this arm
            position_ik = "elbow"
        except ValueError:
            if position_ik == "elbow":
                raise
            position_ik = "iterative"

    return Robot(
        name=str(spec["robot"]),
        model=model,
        impact_frame_id=int(fid),
        joint_names=names,
        armature=armature,
        viscous=vals["B"] * G**2,
        coulomb_pos=np.abs(vals["Tc_pos"]) * np.abs(G),
        coulomb_neg=np.abs(vals["Tc_neg"]) * np.abs(G),
        tau_max=vals["tau_max"],
        encoder_resolution=vals["encoder_resolution"],
        q_lower=np.array(model.lowerPositionLimit, dtype=float),
        q_upper=np.array(model.upperPositionLimit, dtype=float),
        angle_offset_deg=offset,
        source=str(drive_file),
        position_ik=str(position_ik),
    )
