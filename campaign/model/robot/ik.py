"""Inverse kinematics of the positioning chain: every arm pose that puts the impact point at a target.

The impact point (the wrist centre) depends on the positioning joints only, so the arm
reaches a point with a finite set of poses, its *branches* (a PUMA 560 has up to four:
shoulder left or right, elbow up or down). An elbow arm's (the PUMA 560's) are solved in
closed form (:mod:`campaign.model.robot.elbow`, the robot's ``position_ik``); any other arm's
numerically with Pinocchio's kinematics:

1. damped Newton (Levenberg-Marquardt on ``oMf[impact].translation - target`` with the
   ``LOCAL_WORLD_ALIGNED`` frame Jacobian) from a fixed set of starts spread over the joint
   ranges, turned about the first axis towards the target's azimuth, all starts iterated
   together;
2. each converged pose wrapped by whole turns into the joint limits (a revolute joint's
   angle is defined modulo 2 pi), discarded if no turn fits;
3. poses closer than ``dedup_tol`` in every joint merged.

Either way a pose counts as reaching the point when its forward kinematics (Pinocchio) hits
it within ``tol``. The tests check completeness (the poses of random configurations within
the limits are found again from their own wrist centre) and the closed form against the
iterative solver and forward kinematics.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pinocchio as pin

from ...core.errors import InputError
from . import Robot
from .elbow import POSITION_IK, elbow_candidates, elbow_geometry

__all__ = ["IKResult", "position_branches", "position_branches_many", "impact_point", "reach_starts", "reach_sphere"]

#: Newton stops for a start when its position error is below this [m]
_CONVERGED = 1e-12
#: iterations over which a start must lower its error by 0.1 % to go on
_STALL_WINDOW = 6


@dataclasses.dataclass(frozen=True)
class IKResult:
    """The poses that reach one target point.

    Attributes
    ----------
    q : ndarray, shape (K, nq)
        Distinct poses within the joint limits [rad] (K = 0 when none), sorted by joint
        angles for a deterministic order.
    residual : ndarray, shape (K,)
        ``|FK(q) - target|`` [m].
    reached_outside_limits : bool
        Some start reached the point, but only with angles outside the joint limits.
    """

    q: np.ndarray
    residual: np.ndarray
    reached_outside_limits: bool

    @property
    def n_branches(self) -> int:
        return int(self.q.shape[0])


def impact_point(robot: Robot, q, *, data: pin.Data | None = None) -> np.ndarray:
    """Position of the impact point ``oMf[impact].translation`` at ``q`` [m], base frame."""
    data = robot.model.createData() if data is None else data
    pin.framesForwardKinematics(robot.model, data, np.asarray(q, dtype=float))
    return np.array(data.oMf[robot.impact_frame_id].translation)


def reach_sphere(robot: Robot) -> tuple[np.ndarray, float]:
    """(centre [m], radius [m]) of a sphere the impact point never leaves: centred on the first
    joint's axis point, of radius the sum of the distances between successive joint origins
    and the impact point, which revolute joints keep whatever their angles (an infinite radius
    when a joint of the chain is not revolute)."""
    model = robot.model
    frame = model.frames[robot.impact_frame_id]
    chain = [j for j in model.supports[frame.parentJoint] if j > 0]
    centre = np.zeros(3)
    if not chain:
        return centre, float(np.linalg.norm(frame.placement.translation))
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    centre = np.array(data.oMi[chain[0]].translation)
    if not all(model.joints[j].shortname().startswith("JointModelR") for j in chain):
        return centre, float("inf")
    links = [model.jointPlacements[j].translation for j in chain[1:]] + [frame.placement.translation]
    return centre, float(sum(np.linalg.norm(t) for t in links)) * (1.0 + 1e-9) + 1e-9


def reach_starts(robot: Robot, *, per_joint: int = 3) -> np.ndarray:
    """Start poses of the Newton search, relative to the target's azimuth for joint 1.

    Joint 1 starts at offsets of 0, 90, 180 and 270 deg from the target's azimuth (both
    shoulder sides, and the quarter turns between, from which Newton slides to either);
    every other joint at ``per_joint`` angles spread evenly inside its limits (the midpoints
    of ``per_joint`` equal slices). Returns shape (S, nq) [rad]; joint 1's column holds the
    offsets.
    """
    nq = robot.model.nq
    cols = [np.radians([0.0, 90.0, 180.0, 270.0])]
    for j in range(1, nq):
        lo, hi = float(robot.q_lower[j]), float(robot.q_upper[j])
        cols.append(lo + (np.arange(per_joint) + 0.5) * (hi - lo) / per_joint)
    return np.array(list(itertools.product(*cols)), dtype=float)


def _wrap_into_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, tol: float):
    """Shift each angle by whole turns into ``[lower, upper]``; rows with no fitting turn are
    flagged. Returns (wrapped q, mask of rows within the limits)."""
    two_pi = 2.0 * np.pi
    shifted = lower + np.mod(q - lower, two_pi)
    # an angle just below the lower limit (round-off) maps to the top of the turn: pull it back
    near = shifted - two_pi >= lower - tol
    shifted = np.where(near, shifted - two_pi, shifted)
    ok = np.all(shifted <= upper + tol, axis=1)
    return np.clip(shifted, lower, upper), ok


def position_branches(robot: Robot, target, *, tol: float = 1e-9, dedup_tol: float = 1e-5,
                      max_iter: int = 30, starts: np.ndarray | None = None,
                      data: pin.Data | None = None) -> IKResult:
    """Every pose within the joint limits that puts the impact point at ``target``.

    Parameters
    ----------
    robot : Robot
        A robot whose impact point depends on its ``nq`` joints (the positioning chain).
    target : array_like, shape (3,)
        Target point in the arm's base frame [m].
    tol : float
        Largest forward-kinematics error of an accepted pose [m].
    dedup_tol : float
        Poses closer than this in every joint are one branch [rad].
    max_iter : int
        Newton iterations per start.
    starts : ndarray, shape (S, nq), optional
        Start poses (joint 1 as an offset from the target's azimuth); default
        :func:`reach_starts`.

    Returns
    -------
    IKResult
    """
    p = np.asarray(target, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InputError(f"target point must be 3 finite numbers [m], got {np.asarray(target).tolist()}")
    return position_branches_many(robot, p[None], tol=tol, dedup_tol=dedup_tol, max_iter=max_iter,
                                  starts=starts, data=data)[0]


def position_branches_many(robot: Robot, targets, *, tol: float = 1e-9, dedup_tol: float = 1e-5,
                           max_iter: int = 30, starts: np.ndarray | None = None,
                           data: pin.Data | None = None, method: str | None = None) -> list[IKResult]:
    """:func:`position_branches` of many targets (M, 3) [m] at once.

    ``method``: ``"elbow"``, the closed form of an elbow arm
    (:mod:`campaign.model.robot.elbow`, a few array operations for all targets), or
    ``"iterative"``, the Newton iterations of every (target, start) pair run together (the
    NumPy work of an iteration is paid once for all targets, not once per target); default
    the robot's ``position_ik`` (its drive file), iterative when ``starts`` are given.
    """
    P = np.asarray(targets, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or not np.all(np.isfinite(P)):
        raise InputError(f"target points must be finite 3-vectors, got shape {np.shape(targets)}")
    method = (robot.position_ik if starts is None else "iterative") if method is None else method
    if method not in POSITION_IK:
        raise InputError(f"IK method {method!r} is not one of {', '.join(POSITION_IK)}")
    centre, radius = reach_sphere(robot)
    # beyond the arm's reach no start can converge: such a target gets no branch without an
    # iteration (far enough away, the Newton steps would overflow)
    near = np.abs(P - centre).max(axis=1) <= radius
    if not np.all(near):
        found = iter(position_branches_many(robot, P[near], tol=tol, dedup_tol=dedup_tol, max_iter=max_iter,
                                            starts=starts, data=data, method=method) if np.any(near) else ())
        none = IKResult(np.empty((0, robot.model.nq)), np.empty(0), False)
        return [next(found) if ok else none for ok in near]
    data = robot.model.createData() if data is None else data
    if method == "elbow":
        geo = elbow_geometry(robot.model, robot.impact_frame_id, where=robot.source)
        Q, real = elbow_candidates(geo, P)
        Q = Q.reshape(-1, robot.model.nq)
        hit = real.ravel().copy()
        for i in np.flatnonzero(hit):
            hit[i] = np.linalg.norm(impact_point(robot, Q[i], data=data) - P[i // 4]) <= tol
        return _branches(robot, P, Q, hit, 4, tol=tol, dedup_tol=dedup_tol, data=data)
    return _iterate(robot, P, tol=tol, dedup_tol=dedup_tol, max_iter=max_iter, starts=starts, data=data)


def _iterate(robot: Robot, P: np.ndarray, *, tol: float, dedup_tol: float, max_iter: int,
             starts: np.ndarray | None, data: pin.Data) -> list[IKResult]:
    """The iterative solver of :func:`position_branches_many`."""
    model = robot.model
    fid = robot.impact_frame_id
    S0 = reach_starts(robot) if starts is None else np.asarray(starts, dtype=float)
    M, S, nq = P.shape[0], S0.shape[0], S0.shape[1]
    Q = np.tile(S0, (M, 1))
    Q[:, 0] += np.repeat(np.arctan2(P[:, 1], P[:, 0]), S)
    goal = np.repeat(P, S, axis=0)           # the target of each row
    R = M * S
    err = np.empty((R, 3))
    J = np.empty((R, 3, nq))
    mu = np.full(R, 1e-3)                    # Levenberg-Marquardt damping, per row
    active = np.ones(R, dtype=bool)
    jac, lwa = pin.computeFrameJacobian, pin.LOCAL_WORLD_ALIGNED
    oMf = data.oMf

    def evaluate(rows):
        for i in rows:
            J[i] = jac(model, data, Q[i], fid, lwa)[:3]    # also places oMf[fid] at Q[i]
            err[i] = oMf[fid].translation
        err[rows] -= goal[rows]

    evaluate(np.arange(R))
    cost = np.einsum("ij,ij->i", err, err)
    eye = np.eye(nq)
    history = [cost.copy()]
    for it in range(max_iter):
        active &= cost > _CONVERGED**2
        if it >= _STALL_WINDOW:
            # a start whose error no longer falls is stuck at a non-zero minimum (the point is
            # beyond its reach from there): stop iterating it
            active &= cost < (1.0 - 1e-3) * history[-_STALL_WINDOW]
        rows = np.flatnonzero(active)
        if rows.size == 0:
            break
        Ja, ea = J[rows], err[rows]
        JT = np.swapaxes(Ja, 1, 2)
        A = JT @ Ja + mu[rows, None, None] * eye
        step = -np.linalg.solve(A, (JT @ ea[:, :, None]))[:, :, 0]
        # limit a step to half a radian per joint: Newton far from a solution overshoots
        step *= np.minimum(1.0, 0.5 / np.maximum(np.abs(step).max(axis=1), 1e-300))[:, None]
        Q_old, J_old, err_old, cost_old = Q[rows].copy(), Ja.copy(), ea.copy(), cost[rows].copy()
        Q[rows] += step
        evaluate(rows)
        new = np.einsum("ij,ij->i", err[rows], err[rows])
        better = new < cost_old
        # accepted steps relax the damping, rejected ones are undone with more damping
        mu[rows] = np.where(better, np.maximum(mu[rows] * 0.3, 1e-12), mu[rows] * 10.0)
        bad = rows[~better]
        Q[bad], J[bad], err[bad] = Q_old[~better], J_old[~better], err_old[~better]
        cost[rows] = np.where(better, new, cost_old)
        history.append(cost.copy())
    return _branches(robot, P, Q, np.sqrt(cost) <= tol, S, tol=tol, dedup_tol=dedup_tol, data=data)


def _branches(robot: Robot, P: np.ndarray, Q: np.ndarray, hit: np.ndarray, S: int, *, tol: float,
              dedup_tol: float, data: pin.Data) -> list[IKResult]:
    """The branches of each target from its ``S`` candidate rows of ``Q`` (``hit``: the rows
    that reach it): wrapped into the joint limits, merged within ``dedup_tol``, sorted, and
    checked by forward kinematics."""
    nq = Q.shape[1]
    wrapped, inside = _wrap_into_limits(Q, robot.q_lower, robot.q_upper, 1e-9)
    out = []
    for m in range(P.shape[0]):
        sl = slice(m * S, (m + 1) * S)
        h, ins = hit[sl], inside[sl]
        cand = wrapped[sl][h & ins]
        kept: list[np.ndarray] = []
        for q in cand[np.lexsort(cand.T[::-1])] if cand.size else ():
            if not any(np.all(np.abs(q - k) <= dedup_tol) for k in kept):
                kept.append(q)
        if not kept:
            out.append(IKResult(np.empty((0, nq)), np.empty(0), bool(np.any(h))))
            continue
        q_out = np.array(kept)
        res = np.array([np.linalg.norm(impact_point(robot, q, data=data) - P[m]) for q in q_out])
        good = res <= tol
        out.append(IKResult(q_out[good], res[good], False))
    return out
