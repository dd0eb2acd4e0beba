"""Where the impact device stands for a pose and an impact direction, and whether it can.

The pendulum swings in the vertical plane through the impact point that holds the
horizontal impact direction n; at the bottom of its swing (``theta = 0``) the head touches
the impact point moving along +n, so the pivot sits a pendulum radius ``r`` straight above
the impact point, and before the touch the head comes along the arc

    p_head(theta) = p_tip + r sin(theta) n + r (1 - cos(theta)) e_z,   theta in [-theta_0, 0]

from the release angle ``theta_0`` of the impact speed (:meth:`Pendulum.release_angle`).

:func:`place_pendulum` refuses, with one line naming the cause, a pose and direction the
rig cannot strike:

* a joint angle outside the arm's limits;
* an impact point too low for the head to pass above the floor, or so high that the pivot
  would sit above the stand's highest mounting (``placement.pivot_z_max``);
* an impact point inside one of the arm's other links, or a swing whose head would pass
  through a link on its way in.

The arm's links are capsules of radius ``placement.link_radius`` around the segments
joining its successive joint origins and the impact point, plus the pedestal from the floor
(``placement.floor_z``) to the first joint; the head is a sphere of radius
``placement.head_radius``. The link that ends at the impact point (the forearm) is the
struck one: only head positions farther than ``placement.struck_zone`` from the impact
point (the padded wrist and the hammer's last run-in) are checked against it, so a blow
along the forearm from the elbow's side is refused while a blow across it is not.
How the experiment design uses it: user guide, *Experiment design for lambda*
(``docs/design.rst``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from ..core.errors import InputError

__all__ = ["Placement", "PLACEMENT_KEYS", "arm_segments", "place_pendulum", "placement_params"]

#: rig parameters of the device's placement (config/rig.yaml ``placement``)
PLACEMENT_KEYS = ("placement.link_radius", "placement.head_radius", "placement.floor_z", "placement.pivot_z_max",
                  "placement.struck_zone")

#: head positions sampled along the swing per radian of arc
_ARC_SAMPLES_PER_RAD = 40


@dataclasses.dataclass(frozen=True)
class Placement:
    """The impact device set up for one pose and direction.

    Attributes
    ----------
    tip : ndarray, shape (3,)
        Impact point, arm base frame [m].
    n : ndarray, shape (3,)
        Horizontal unit impact direction.
    pivot : ndarray, shape (3,)
        Pendulum pivot, ``tip + r e_z`` [m].
    clearance : float
        Smallest distance between the swinging head's surface and a link's surface along
        the checked part of the swing [m] (> 0).
    """

    tip: np.ndarray
    n: np.ndarray
    pivot: np.ndarray
    clearance: float


def placement_params(params) -> dict[str, float] | None:
    """The placement parameters of a scene's parameter dict, or None if it has none (a scene
    stored before the placement parameters existed is replayed as stored)."""
    if not all(k in params for k in PLACEMENT_KEYS):
        return None
    out = {k.split(".", 1)[1]: float(params[k]) for k in PLACEMENT_KEYS}
    for key in ("link_radius", "head_radius", "struck_zone"):
        if not (math.isfinite(out[key]) and out[key] >= 0):
            raise InputError(f"rig parameter placement.{key} must be >= 0 m, got {out[key]!r}")
    for key in ("floor_z", "pivot_z_max"):
        if not math.isfinite(out[key]):
            raise InputError(f"rig parameter placement.{key} must be finite, got {out[key]!r}")
    return out


def arm_segments(robot, q, *, data=None) -> tuple[list[tuple[str, np.ndarray, np.ndarray]], np.ndarray]:
    """The arm's link segments at ``q`` (DH radians) and its impact point, base frame.

    Returns
    -------
    segments : list of (name, a, b)
        Segments joining successive distinct joint origins and, last, the impact point,
        named ``"<joint>-<joint>"`` after their ends (``"j2-j3"`` the upper arm, ``"j3-tip"``
        the struck forearm); coincident origins are merged.
    tip : ndarray, shape (3,)
    """

    model = robot.model
    data = model.createData() if data is None else data
    pin.framesForwardKinematics(model, data, np.asarray(q, float))
    points = [(model.names[j], np.array(data.oMi[j].translation)) for j in range(1, model.njoints)]
    tip = np.array(data.oMf[robot.impact_frame_id].translation)
    points.append(("tip", tip))
    segments = []
    prev_name, prev = points[0]
    for name, p in points[1:]:
        if np.linalg.norm(p - prev) > 1e-9:
            segments.append((f"{prev_name}-{name}", prev, p))
            prev_name, prev = name, p
        else:
            prev_name = prev_name if name == "tip" else name
    return segments, tip


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each row of ``points`` to the segment a-b."""
    ab = b - a
    t = np.clip((points - a) @ ab / float(ab @ ab), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def place_pendulum(robot, q, n, *, radius: float, release_angle: float, link_radius: float,
                   head_radius: float, floor_z: float, pivot_z_max: float, struck_zone: float, what: str = "pose",
                   data=None) -> Placement:
    """Set the pendulum up to strike the impact point of pose ``q`` along ``n``, or refuse.

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    q : array_like
        DH joint angles [rad].
    n : array_like, shape (3,)
        Horizontal unit impact direction, base frame.
    radius : float
        Pendulum radius (pivot to the head's contact point) [m].
    release_angle : float
        Release angle of the impact speed [rad] (0 for a launched hammer: the head's path is
        then the short straight run-in along n that the arc's first samples cover).
    link_radius, head_radius, floor_z, pivot_z_max, struck_zone : float
        Placement parameters (see the module docstring) [m].
    what : str
        How the pose is named in a refusal.

    Returns
    -------
    Placement

    Raises
    ------
    InputError
        Joint limits, an unreachable impact point, the impact point inside a link, or a
        swing through a link, named with the numbers.
    """
    try:
        q = robot.check_q(np.asarray(q, float), what=what)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    n = np.asarray(n, float)
    segments, tip = arm_segments(robot, q, data=data)
    low = floor_z + head_radius
    if tip[2] < low:
        raise InputError(f"{what}: impact point at z = {tip[2]:.3f} m is below {low:.3f} m (floor "
                         f"placement.floor_z = {floor_z:g} m + head radius): the hammer cannot reach it")
    pivot = tip + np.array([0.0, 0.0, radius])
    if pivot[2] > pivot_z_max:
        raise InputError(f"{what}: the pendulum cannot reach the impact point at z = {tip[2]:.3f} m: its pivot "
                         f"would be at z = {pivot[2]:.3f} m, above the stand's highest mounting "
                         f"placement.pivot_z_max = {pivot_z_max:g} m")
    gap = link_radius + head_radius
    # the pedestal: a vertical link from the floor to the first joint's origin
    first = segments[0][1] if segments else tip
    others = [("pedestal", np.array([first[0], first[1], floor_z]), first)]
    struck = [s for s in segments if s[0].endswith("-tip")]
    others += [s for s in segments if not s[0].endswith("-tip")]
    for name, a, b in others:
        d = float(_segment_distance(tip[None, :], a, b)[0])
        if d < link_radius:
            raise InputError(f"{what}: the impact point lies inside link {name} of the arm ({d:.3f} m from its axis, "
                             f"link radius placement.link_radius = {link_radius:g} m)")
    # the head's swing in, from the release to the touch
    theta0 = max(float(release_angle), 0.2)
    th = -np.linspace(0.0, theta0, max(8, int(math.ceil(theta0 * _ARC_SAMPLES_PER_RAD))) + 1)
    heads = tip[None, :] + radius * (np.sin(th)[:, None] * n[None, :]
                                     + (1.0 - np.cos(th))[:, None] * np.array([0.0, 0.0, 1.0])[None, :])
    away = np.linalg.norm(heads - tip, axis=1) > struck_zone
    clearance = math.inf
    for name, a, b in others + struck:
        pts = heads[away] if name.endswith("-tip") else heads[1:]
        if not len(pts):
            continue
        d = _segment_distance(pts, a, b)
        k = int(np.argmin(d))
        clearance = min(clearance, float(d[k]) - gap)
        if d[k] < gap:
            raise InputError(f"{what}: the hammer's swing along n = {np.round(n, 4).tolist()} passes through link "
                             f"{name} of the arm (head {float(d[k]):.3f} m from its axis at "
                             f"{np.round(pts[k], 3).tolist()} m; needs {gap:.3f} m): the impact point is not exposed "
                             "from this direction")
    return Placement(tip=tip, n=n, pivot=pivot, clearance=float(clearance))
