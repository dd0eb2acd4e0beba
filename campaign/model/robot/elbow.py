"""Closed-form inverse kinematics of an elbow arm's positioning chain, for all grid points at once.

An *elbow arm* (the PUMA 560's first three joints) turns joint 1 about the base frame's z
axis, which passes through the base origin, and joints 2 and 3 about axes parallel to each
other and perpendicular to z. The impact point then moves as the product of exponentials of
the three axes taken at ``q = 0`` (axis direction ``a_i`` through a point ``c_i``, read
from Pinocchio's joint Jacobian, :func:`elbow_geometry`):

* joints 2 and 3 move it in a plane perpendicular to ``a_2``, at a fixed distance ``d``
  from the plane through z that holds ``a_2`` (the shoulder offset): a planar two-link arm
  whose links are the distance between axes 2 and 3 and from axis 3 to the point;
* joint 1 turns that plane about z.

A target ``t`` is reached with ``r = +-sqrt(t_x^2 + t_y^2 - d^2)`` (shoulder on either side)
and the planar arm's two elbow solutions: up to four poses, each one ``atan2``/``acos``
away (:func:`elbow_candidates`). :func:`campaign.model.robot.ik.position_branches_many`
wraps them into the joint limits and keeps those whose forward kinematics (Pinocchio) hits
the target, as for its iterative solver. The loader reads the arm's geometry
(:func:`elbow_geometry`) and solves in closed form when it is an elbow arm's; a drive file may
say ``position_ik: iterative`` (the iterative solver) or ``position_ik: elbow`` (the closed
form, refused with ValueError for an arm it does not fit); ``auto``, the default, chooses by
the geometry.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

__all__ = ["ElbowGeometry", "elbow_geometry", "elbow_candidates", "POSITION_IK"]

#: the solvers of the impact point's inverse kinematics: the iterative one of any arm, the
#: closed form of an elbow arm (a drive file's ``position_ik`` names one, or ``auto``)
POSITION_IK = ("iterative", "elbow")

#: largest misalignment of the axes [rad] and offset [m] an elbow arm's geometry may show
_GEOMETRY_TOL = 1e-9


@dataclasses.dataclass(frozen=True)
class ElbowGeometry:
    """The constants of an elbow arm's closed form, from its axes at ``q = 0``.

    Attributes
    ----------
    s1 : float
        +1 when joint 1 turns about +z, -1 about -z.
    s3 : float
        +1 when joint 3's axis points as joint 2's, -1 when opposite.
    u, h : ndarray, shape (3,)
        Joint 2's axis and ``z x u`` (horizontal): with z they span the base frame at ``q1 = 0``.
    d : float
        Shoulder offset: the impact point's coordinate along ``u`` [m].
    o2 : ndarray, shape (2,)
        Joint 2's axis in the plane of the links, coordinates along ``h`` and z [m].
    l2, l3 : float
        Distance between axes 2 and 3, and from axis 3 to the impact point [m].
    beta2, beta3 : float
        Directions of those two links in the plane at ``q = 0`` [rad], from ``h`` towards z.
    """

    s1: float
    s3: float
    u: np.ndarray
    h: np.ndarray
    d: float
    o2: np.ndarray
    l2: float
    l3: float
    beta2: float
    beta3: float


def elbow_geometry(model: pin.Model, frame_id: int, *, where: str = "robot") -> ElbowGeometry:
    """The closed form's constants of ``model`` (three revolute joints) and its impact frame;
    ValueError naming ``where`` when the arm is not an elbow arm."""
    if model.nq != 3 or model.nv != 3 or model.njoints != 4:
        raise ValueError(f"{where}: position_ik elbow needs 3 revolute active joints, the model has nq = {model.nq}")
    data = model.createData()
    q0 = np.zeros(3)
    J = pin.computeJointJacobians(model, data, q0)             # world frame, each column at the origin
    pin.framesForwardKinematics(model, data, q0)
    p0 = np.array(data.oMf[frame_id].translation)
    a = [np.array(J[3:, i]) for i in range(3)]
    c = [np.cross(a[i], np.array(J[:3, i])) for i in range(3)]  # v = c x a: the axis's point nearest the origin
    ez = np.array([0.0, 0.0, 1.0])
    why = []
    if any(abs(np.linalg.norm(ai) - 1.0) > _GEOMETRY_TOL for ai in a):
        why.append("a joint is not revolute")
    elif np.linalg.norm(np.cross(a[0], ez)) > _GEOMETRY_TOL or np.linalg.norm(c[0][:2]) > _GEOMETRY_TOL:
        why.append("joint 1 does not turn about the base z axis")
    elif abs(a[1] @ ez) > _GEOMETRY_TOL or np.linalg.norm(np.cross(a[1], a[2])) > _GEOMETRY_TOL:
        why.append("joints 2 and 3 are not parallel and horizontal")
    if why:
        raise ValueError(f"{where}: position_ik elbow does not fit this arm: {why[0]}")
    u = a[1]
    h = np.cross(ez, u)
    plane = np.array([h, ez])                                   # (h, z) coordinates of the links' plane
    o2, o3, pp = plane @ c[1], plane @ c[2], plane @ p0
    l2, l3 = float(np.linalg.norm(o3 - o2)), float(np.linalg.norm(pp - o3))
    if min(l2, l3) <= _GEOMETRY_TOL:
        raise ValueError(f"{where}: position_ik elbow does not fit this arm: a link of the elbow has no length")
    return ElbowGeometry(s1=float(np.sign(a[0] @ ez)), s3=float(np.sign(a[2] @ u)), u=u, h=h, d=float(p0 @ u),
                         o2=o2, l2=l2, l3=l3, beta2=float(np.arctan2(*(o3 - o2)[::-1])),
                         beta3=float(np.arctan2(*(pp - o3)[::-1])))


def elbow_candidates(geo: ElbowGeometry, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The four closed-form poses of each target (M, 3) [m]: shoulder (``r`` > 0, < 0) x elbow
    (``gamma`` > 0, < 0). Returns (M, 4, 3) [rad] (not wrapped into the joint limits) and a
    mask (M, 4) of the real ones (the target within the shoulder's and the elbow's reach; a
    target up to 1e-12 of the reach outside it is put on it, and forward kinematics judges)."""
    P = np.asarray(targets, dtype=float)
    rho2 = P[:, 0] ** 2 + P[:, 1] ** 2
    r_abs = np.sqrt(np.maximum(rho2 - geo.d**2, 0.0))
    shoulder_ok = rho2 - geo.d**2 >= -1e-12
    r = np.stack([r_abs, -r_abs], axis=1)                               # (M, 2)
    # the horizontal position d u + r h at q1 = 0, turned by s1 q1 onto the target's azimuth
    hx = geo.d * geo.u[0] + r * geo.h[0]
    hy = geo.d * geo.u[1] + r * geo.h[1]
    q1 = geo.s1 * (np.arctan2(P[:, 1], P[:, 0])[:, None] - np.arctan2(hy, hx))
    wr, wz = r - geo.o2[0], P[:, 2:3] - geo.o2[1]                        # target from axis 2, (M, 2)
    cg = (wr**2 + wz**2 - geo.l2**2 - geo.l3**2) / (2.0 * geo.l2 * geo.l3)
    elbow_ok = np.abs(cg) <= 1.0 + 1e-12
    g = np.arccos(np.clip(cg, -1.0, 1.0))
    gamma = np.stack([g, -g], axis=2)                                    # (M, 2 shoulder, 2 elbow)
    theta2 = np.arctan2(wz, wr)[:, :, None] - np.arctan2(geo.l3 * np.sin(gamma), geo.l2 + geo.l3 * np.cos(gamma))
    Q = np.empty(P.shape[:1] + (2, 2, 3))
    Q[..., 0] = q1[:, :, None]
    Q[..., 1] = theta2 - geo.beta2
    Q[..., 2] = geo.s3 * (gamma + geo.beta2 - geo.beta3)
    ok = (shoulder_ok[:, None] & elbow_ok)[:, :, None] & np.ones((1, 1, 2), dtype=bool)
    return Q.reshape(-1, 4, 3), ok.reshape(-1, 4)
