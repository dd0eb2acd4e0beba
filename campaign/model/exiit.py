"""The Extended-Inversed Inertia Tensor and what follows from it (paper, eqs 5-14).

Names follow the paper and Pinocchio: ``q`` joint angles [rad] (DH), ``H`` joint-space
inertia including the reflected rotor inertia (``model.armature``), ``J`` the impact-point
Jacobian in ``LOCAL_WORLD_ALIGNED`` (linear rows first), ``lam`` the Virtual Rotor Inertia
lambda [kg m^2] (diagonal given as a vector, or a full symmetric matrix), ``n`` the unit
impact direction in the base (world) frame.

* :func:`exiit_fixed`     eq 7   ``G* = J (H + lambda)^-1 J^T``
* :func:`exiit_floating`  eq 8   ``G* = J* (H* + lambda)^-1 J*^T + R_gh M^-1 R_gh^T``
* :func:`effective_mass`  eq 11  ``m* = 1 / (n^T G*_33 n)``; ``inf`` where n leaves the range
* :func:`post_impact_velocity` eq 13, :func:`impulse` eq 14
* :func:`effective_mass_batch` eq 11 over many configurations
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .robot import Robot
from .robot.floating import FloatingRobot

__all__ = [
    "lambda_matrix",
    "unit_direction",
    "inertia",
    "impact_jacobian",
    "exiit_fixed",
    "exiit_floating",
    "exiit_floating_direct",
    "effective_mass",
    "effective_mass_from_G",
    "effective_mass_batch",
    "post_impact_velocity",
    "impulse",
    "RANGE_RTOL",
]

#: n^T G33 n below RANGE_RTOL * trace(G33) means n is (numerically) outside the range of
#: G33: the arm cannot move its tip along n, and m* is infinite.
RANGE_RTOL = 1e-12


def lambda_matrix(lam, nv: int) -> np.ndarray:
    """Virtual Rotor Inertia as an (nv, nv) matrix, checked (eq 4, 15).

    ``None`` means zero; a vector is the diagonal (eq 15); a matrix must be symmetric
    positive semi-definite. Raises ValueError naming the bad value.
    """
    if lam is None:
        return np.zeros((nv, nv))
    arr = np.asarray(lam, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"lambda = {np.asarray(lam).tolist()} must be finite (kg m^2)")
    if arr.ndim == 1:
        if arr.shape != (nv,):
            raise ValueError(f"lambda has {arr.size} values, the arm has {nv} joints")
        if np.any(arr < 0):
            raise ValueError(f"lambda = {arr.tolist()} must be >= 0 (kg m^2)")
        return np.diag(arr)
    if arr.shape != (nv, nv):
        raise ValueError(f"lambda matrix must be {nv}x{nv}, got shape {arr.shape}")
    if not np.allclose(arr, arr.T, rtol=1e-12, atol=1e-12):
        raise ValueError(f"lambda matrix must be symmetric, got {arr.tolist()}")
    if np.min(np.linalg.eigvalsh(arr)) < -1e-12 * max(1.0, np.abs(arr).max()):
        raise ValueError(f"lambda matrix must be positive semi-definite, got {arr.tolist()}")
    return arr


def unit_direction(n) -> np.ndarray:
    """Normalise an impact direction; a zero, non-finite or non-3-vector is an error."""
    arr = np.asarray(n, dtype=float)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"direction must be 3 finite numbers, got {np.asarray(n).tolist()}")
    scale = np.abs(arr).max()        # scaled first: a norm of 1e308 or 1e-320 parts would over- or underflow
    if scale == 0:
        raise ValueError(f"direction {arr.tolist()} is the zero vector")
    arr = arr / scale
    return arr / np.linalg.norm(arr)


def inertia(model: pin.Model, data: pin.Data, q) -> np.ndarray:
    """Joint-space inertia ``H(q)`` (CRBA, armature included), symmetric."""
    H = pin.crba(model, data, q)
    return np.triu(H) + np.triu(H, 1).T


def impact_jacobian(model: pin.Model, data: pin.Data, q, frame_id: int) -> np.ndarray:
    """6 x nv Jacobian of the impact point, ``LOCAL_WORLD_ALIGNED`` (linear rows first)."""
    return pin.computeFrameJacobian(model, data, q, frame_id, pin.LOCAL_WORLD_ALIGNED)


def exiit_fixed(robot: Robot, q, lam=None, *, data: pin.Data | None = None) -> np.ndarray:
    """Ex-IIT of a ground-fixed arm, eq 7: ``G* = J (H + lambda)^-1 J^T`` (6 x 6)."""
    model = robot.model
    data = model.createData() if data is None else data
    q = np.asarray(q, dtype=float)
    H = inertia(model, data, q) + lambda_matrix(lam, model.nv)
    J = impact_jacobian(model, data, q, robot.impact_frame_id)
    return J @ np.linalg.solve(H, J.T)


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def exiit_floating(frobot: FloatingRobot, q_arm, lam=None, *, base_pose: pin.SE3 | None = None,
                   data: pin.Data | None = None, parts: bool = False):
    """Ex-IIT of an arm on a free (or flexibly supported) base, eq 8.

    ``G* = J* (H* + lambda)^-1 J*^T + R_gh M^-1 R_gh^T`` with the augmented (generalised)
    Jacobian ``J* = J_m - J_b M_b^-1 H_bm`` and inertia ``H* = H_m - H_bm^T M_b^-1 H_bm``
    of the free-flyer model, ``M = diag(w E, H_g)`` the system's mass and centroidal
    inertia, and ``R_gh = [[E, -[r_gh]x], [0, E]]`` with ``r_gh`` from the centroid to the
    impact point. The base's spring and damper transmit no impulse, so only ``M`` enters.

    Parameters
    ----------
    frobot : FloatingRobot
    q_arm : array_like, shape (nv_arm,)
    lam : None, vector or matrix
        Virtual Rotor Inertia of the arm's joints [kg m^2].
    parts : bool
        Also return ``(J_star, H_star, R_gh, M)``.
    """
    model = frobot.model
    data = model.createData() if data is None else data
    nb = 6
    q = frobot.q_full(q_arm, base_pose)
    Mfull = inertia(model, data, q)
    Jfull = impact_jacobian(model, data, q, frobot.impact_frame_id)  # runs forward kinematics
    Mb, Hbm, Hm = Mfull[:nb, :nb], Mfull[:nb, nb:], Mfull[nb:, nb:]
    Jb, Jm = Jfull[:, :nb], Jfull[:, nb:]
    Mb_inv_Hbm = np.linalg.solve(Mb, Hbm)
    H_star = Hm - Hbm.T @ Mb_inv_Hbm
    J_star = Jm - Jb @ Mb_inv_Hbm

    # centroid, total mass w and centroidal inertia H_g (world-aligned, about the centroid)
    r_g = np.array(pin.centerOfMass(model, data, q))
    pin.ccrba(model, data, q, np.zeros(model.nv))
    w = float(data.Ig.mass)
    H_g = np.array(data.Ig.inertia)
    r_gh = np.array(data.oMf[frobot.impact_frame_id].translation) - r_g
    R_gh = np.block([[np.eye(3), -_skew(r_gh)], [np.zeros((3, 3)), np.eye(3)]])
    M = np.block([[w * np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), H_g]])

    lam_m = lambda_matrix(lam, frobot.nv_arm)
    G = J_star @ np.linalg.solve(H_star + lam_m, J_star.T) + R_gh @ np.linalg.solve(M, R_gh.T)
    if parts:
        return G, (J_star, H_star, R_gh, M)
    return G


def exiit_floating_direct(frobot: FloatingRobot, q_arm, lam=None, *, base_pose: pin.SE3 | None = None,
                          data: pin.Data | None = None) -> np.ndarray:
    """Operational-space inverse inertia of the impact point, ``J M^-1 J^T``, of the full
    free-flyer model (lambda added to the arm block). An independent route to eq 8."""
    model = frobot.model
    data = model.createData() if data is None else data
    q = frobot.q_full(q_arm, base_pose)
    Mfull = inertia(model, data, q)
    Mfull[6:, 6:] += lambda_matrix(lam, frobot.nv_arm)
    J = impact_jacobian(model, data, q, frobot.impact_frame_id)
    return J @ np.linalg.solve(Mfull, J.T)


def effective_mass_from_G(G, n) -> float:
    """Eq 11 from an Ex-IIT: ``m* = 1 / (n^T G*_33 n)`` [kg], ``inf`` outside the range."""
    n = unit_direction(n)
    G33 = np.asarray(G)[:3, :3]
    s = float(n @ G33 @ n)
    tr = float(np.trace(G33))
    if not np.isfinite(s):
        raise FloatingPointError(f"n^T G33 n is not finite ({s}); the inertia matrix is singular")
    if s <= RANGE_RTOL * tr or tr <= 0.0:
        return float("inf")
    return 1.0 / s


def effective_mass(robot: Robot | FloatingRobot, q, n=(-1.0, 0.0, 0.0), lam=None, *,
                   data: pin.Data | None = None) -> float:
    """Effective mass at the impact point along ``n``, eq 11 [kg].

    A :class:`Robot` is ground-fixed (eq 7); a :class:`FloatingRobot` stands on a free base
    (eq 8). Returns ``inf`` where ``n`` leaves the range of ``G*_33`` (the tip cannot move
    along ``n``), never a division error or a huge finite number.
    """
    if isinstance(robot, FloatingRobot):
        G = exiit_floating(robot, q, lam, data=data)
    else:
        G = exiit_fixed(robot, q, lam, data=data)
    return effective_mass_from_G(G, n)


def effective_mass_batch(robot: Robot, Q, n=(-1.0, 0.0, 0.0), lam=None) -> np.ndarray:
    """Eq 11 for a fixed base over many configurations.

    Pinocchio evaluates ``H`` and ``J`` per row of ``Q`` (shape (N, nv), DH radians); the
    linear algebra is batched in NumPy. Returns shape (N,) [kg], ``inf`` where ``n`` leaves
    the range of ``G*_33``.
    """
    model = robot.model
    data = model.createData()
    Q = np.asarray(Q, dtype=float)
    if Q.ndim != 2 or Q.shape[1] != model.nq:
        raise ValueError(f"Q must have shape (N, {model.nq}), got {Q.shape}")
    n = unit_direction(n)
    lam_m = lambda_matrix(lam, model.nv)
    N, nv = Q.shape[0], model.nv
    H = np.empty((N, nv, nv))
    JT = np.empty((N, nv, 3))   # J_lin^T: eq 11 needs n^T J_lin, the range test trace(G33)
    fid = robot.impact_frame_id
    crba, jac, lwa = pin.crba, pin.computeFrameJacobian, pin.LOCAL_WORLD_ALIGNED
    for i in range(N):
        qi = Q[i]
        H[i] = crba(model, data, qi)
        JT[i] = jac(model, data, qi, fid, lwa)[:3].T
    H = np.triu(H) + np.swapaxes(np.triu(H, 1), 1, 2) + lam_m
    Jn = JT @ n                                             # (N, nv)
    X = np.linalg.solve(H, np.concatenate([Jn[:, :, None], JT], axis=2))
    s = np.einsum("ij,ij->i", Jn, X[:, :, 0])               # n^T G33 n
    tr = np.einsum("ijk,ijk->i", JT, X[:, :, 1:])           # trace(G33)
    # the same range test as effective_mass_from_G, so batch and scalar agree on inf
    out = np.full(N, np.inf)
    ok = (s > RANGE_RTOL * tr) & (tr > 0.0)
    out[ok] = 1.0 / s[ok]
    return out


def post_impact_velocity(m_eff, m_b, v_a, v_b, e):
    """Arm tip velocity along n after the impact, eq 13 [m/s].

    ``v'_a = ((1+e) m_b v_b + (m* - e m_b) v_a) / (m* + m_b)``; for ``m* = inf`` the tip does
    not move (``v'_a = v_a``). Works element-wise on arrays.
    """
    m_eff, m_b, v_a, v_b, e = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (m_eff, m_b, v_a, v_b, e)))
    inf = np.isinf(m_eff)
    with np.errstate(invalid="ignore"):
        out = ((1 + e) * m_b * v_b + (m_eff - e * m_b) * v_a) / (m_eff + m_b)
    out = np.where(inf, v_a, out)
    return out[()] if out.ndim == 0 else out


def impulse(m_eff, m_b, v_a, v_b, e):
    """Impulse on the arm along n, eq 14 [N s]: ``(1+e) m* m_b (v_b - v_a) / (m* + m_b)``.

    For ``m* = inf`` this is ``(1+e) m_b (v_b - v_a)`` (a wall).
    """
    m_eff, m_b, v_a, v_b, e = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (m_eff, m_b, v_a, v_b, e)))
    inf = np.isinf(m_eff)
    with np.errstate(invalid="ignore"):
        out = (1 + e) * m_eff * m_b * (v_b - v_a) / (m_eff + m_b)
    out = np.where(inf, (1 + e) * m_b * (v_b - v_a), out)
    return out[()] if out.ndim == 0 else out
