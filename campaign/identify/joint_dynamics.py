"""Arm velocity from joint-space dynamics fitted to the encoders."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
from scipy.linalg import expm as _expm

from .contact import Contact, _ContactInput
from .ft_momentum import _zoh_integral
from .options import IdentifyOptions


# ----------------------------------------------------------------------------------------
# arm: joint-space dynamics driven by the measured servo torque (arm_model="joint")
# ----------------------------------------------------------------------------------------
def _joint_grid(t_s: float, t_e: float, t_stop: float, ticks: np.ndarray, opt: IdentifyOptions) -> np.ndarray:
    """Integration nodes of the joint model: ``joint_contact_steps`` equal steps over the
    contact, then the servo ticks after it (each tick interval split into equal steps of at
    most ``joint_post_step``) up to ``t_stop``: the servo torque is constant on every step
    after the contact, so those steps are exact."""
    contact = t_s + (t_e - t_s) * np.arange(opt.joint_contact_steps + 1) / opt.joint_contact_steps
    tk = ticks[(ticks > t_e + 1e-9) & (ticks < t_stop - 1e-9)]
    edges = np.concatenate([[t_e], tk, [t_stop]])
    nodes = []
    for a, b in itertools.pairwise(edges):
        k = max(1, math.ceil((b - a) / opt.joint_post_step - 1e-9))
        nodes.append(a + (b - a) * np.arange(1, k + 1) / k)
    return np.concatenate([contact] + nodes)


def _cell_means(grid: np.ndarray, cum) -> np.ndarray:
    """Mean of a signal over each grid cell from its cumulative integral ``cum(t)``."""
    C = cum(grid)
    return np.diff(C, axis=0) / np.diff(grid).reshape((-1,) + (1,) * (C.ndim - 1))


def _joint_dynamics_fit(robot, n: np.ndarray, t: np.ndarray, Q: np.ndarray, c: Contact, cin: _ContactInput,
                        ts: np.ndarray, tau: np.ndarray, post_window: float, opt: IdentifyOptions,
                        info: dict | None = None):
    """Tip velocities along n at the contact edges from a joint-space dynamics fit.

    The arm moves by milliradians over the identification window, so its joint motion
    ``x = q - q_s`` obeys the linear model::

        M x'' = [tau_cmd(t) - tau_cmd(t_s)] - G x - k_B B x' + f(t) w - c(sign x')

    about the pre-contact pose ``q_s`` (the mean of the pre-window samples), with

    * ``M`` the joint-space inertia (armature included) and ``G = dg/dq`` the gravity
      stiffness of the robot model at ``q_s``;
    * ``tau_cmd`` the measured servo torque (zero-order hold between ticks; integrated
      exactly: the steps after the contact end on the ticks, the steps inside it take the
      torque's exact mean);
    * ``B`` the drive file's viscous friction times one unknown scale ``k_B >= 0`` (the
      only nonlinear unknown: bounded scalar search on the residual);
    * ``f`` the measured piezo force normalised to unit impulse and ``w`` one unknown
      generalised impulse per joint: the joint-space direction of the impact response is
      measured, not taken from ``M`` (so ``m*`` is not the model's eq 11);
    * ``c`` Coulomb friction for the sign of each joint's velocity (``joint_coulomb``:
      by default an unknown constant per joint and direction), the signs taken from the fitted
      velocities (fixed-point iteration from "all joints one way", at most
      ``joint_coulomb_iterations``; the iterate with the smallest residual is kept).

    The pre-contact samples lie on ``q_s + qd_s (t - t_s)``; ``q_s``, ``qd_s``, ``w`` and
    the Coulomb scale enter linearly (least squares inside the search over ``k_B``). The
    model is integrated exactly over each step (matrix exponential of the augmented
    system, inputs constant per step), ``joint_contact_steps`` steps over the contact and
    at most ``joint_post_step`` after it, and interpolated to the sample times by cubic
    Hermite. Each joint's samples are weighted by the inverse of its encoder resolution
    (the same noise in counts on every joint): no joint's noise is mixed into another's,
    as it is in the tip-position series of ``arm_model="lti"``.

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    n : ndarray, shape (3,)
        Unit impact direction, base frame.
    t, Q : ndarray, shapes (N,), (N, nv)
        Joint samples of the window (pre-contact, contact and post-contact).
    c : Contact
    cin : _ContactInput
        The measured force shape.
    ts, tau : ndarray, shapes (S,), (S, nv)
        Servo tick times and commanded torques.
    post_window : float
        Post-contact window [s] (the samples ``Q`` already end there).
    opt : IdentifyOptions
    info : dict, optional
        Receives ``sd_delta`` (standard deviation of ``v'_a - v_a`` from the residual
        scatter), ``viscous_scale`` (``k_B``), ``coulomb_iterations`` and
        ``v_post_start_jacobian``, ``n . J(q_s) qd(t_e)`` (``m_eff_estimator="impulse"``).

    Returns
    -------
    v_a, v_a_post : float
        ``n . J(q_s) qd_s`` and ``n . J(q_e) qd(t_e)`` [m/s], ``q_e`` the fitted pose at
        the contact end (the Jacobian moves by ~1 % over the contact at High gains).
    """
    model = robot.model
    data = model.createData()
    nv = model.nv
    pre = t < c.start
    q_s = Q[pre].mean(axis=0)
    H = np.array(pin.crba(model, data, q_s))
    H = np.triu(H) + np.triu(H, 1).T
    Minv = np.linalg.inv(H)
    G = np.array(pin.computeGeneralizedGravityDerivatives(model, data, q_s))
    pin.framesForwardKinematics(model, data, q_s)
    Jn_s = n @ pin.computeFrameJacobian(model, data, q_s, robot.impact_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    visc = np.asarray(robot.viscous, float)
    cpos, cneg = np.asarray(robot.coulomb_pos, float), np.asarray(robot.coulomb_neg, float)

    grid = _joint_grid(c.start, c.end, max(float(t[-1]), c.end) + 1e-9, ts, opt)
    K = grid.size - 1
    steps = np.diff(grid)
    i_end = opt.joint_contact_steps                      # grid[i_end] == c.end
    # inputs, as cell means: normalised force, servo torque change from its value at t_s
    force = _cell_means(grid, lambda x: np.interp(x, cin._tt, cin._I, left=0.0, right=1.0))
    k0 = int(np.searchsorted(ts, c.start, side="right")) - 1
    dtau = tau - tau[max(k0, 0)]
    servo = _cell_means(grid, lambda x: _zoh_integral(ts, dtau, x))

    after = t >= c.start
    ta = t[after]
    cell = np.clip(np.searchsorted(grid, ta, side="right") - 1, 0, K - 1)
    hstep = steps[cell]
    sfrac = (ta - grid[cell]) / hstep
    # cubic Hermite weights (positions and velocities at the cell's ends)
    s2, s3 = sfrac * sfrac, sfrac * sfrac * sfrac
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + sfrac) * hstep, -2 * s3 + 3 * s2, (s3 - s2) * hstep
    u_pre = t[~after] - c.start
    wres = 1.0 / np.asarray(robot.encoder_resolution, float)
    N = t.size

    def at_samples(X):
        """Joint positions (N, nv, m) at the sample times from node states X (K+1, 2nv, m)."""
        P = np.zeros((N, nv, X.shape[2]))
        P[after] = (h00[:, None, None] * X[cell, :nv] + h10[:, None, None] * X[cell, nv:]
                    + h01[:, None, None] * X[cell + 1, :nv] + h11[:, None, None] * X[cell + 1, nv:])
        return P

    def propagate(kB: float, U: np.ndarray, X0: np.ndarray) -> np.ndarray:
        """Node states (K+1, 2nv, m) of m input columns U (K, nv, m) from X0 (2nv, m)."""
        A = np.zeros((2 * nv, 2 * nv))
        A[:nv, nv:] = np.eye(nv)
        A[nv:, :nv] = -Minv @ G
        A[nv:, nv:] = -kB * Minv * visc[None, :]
        aug = np.zeros((3 * nv, 3 * nv))
        aug[:2 * nv, :2 * nv] = A
        aug[nv:2 * nv, 2 * nv:] = Minv
        cache = {}
        X = np.empty((K + 1, 2 * nv, U.shape[2]))
        X[0] = X0
        for k in range(K):
            key = round(float(steps[k]) * 1e10)
            if key not in cache:
                E = _expm(aug * steps[k])
                cache[key] = (E[:2 * nv, :2 * nv], E[:2 * nv, 2 * nv:])
            Phi, Gam = cache[key]
            X[k + 1] = Phi @ X[k] + Gam @ U[k]
        return X

    def columns(signs):
        """Inputs of the unknown-coefficient columns and the known servo input."""
        cols_u, cols_x0, names = [], [], []
        for j in range(nv):                       # pre-contact velocity of joint j
            x0 = np.zeros(2 * nv)
            x0[nv + j] = 1.0
            cols_u.append(np.zeros((K, nv)))
            cols_x0.append(x0)
            names.append(("v", j))
        for j in range(nv):                       # generalised impulse on joint j
            u = np.zeros((K, nv))
            u[:, j] = force
            cols_u.append(u)
            cols_x0.append(np.zeros(2 * nv))
            names.append(("w", j))
        fric = np.where(signs > 0, -cpos[None, :], np.where(signs < 0, cneg[None, :], 0.0))
        if opt.joint_coulomb == "global":          # one scale of the drive file's Coulomb friction
            cols_u.append(fric)
            cols_x0.append(np.zeros(2 * nv))
            names.append(("c", -1))
        elif opt.joint_coulomb == "joint":         # one scale per joint
            for j in range(nv):
                u = np.zeros((K, nv))
                u[:, j] = fric[:, j]
                cols_u.append(u)
                cols_x0.append(np.zeros(2 * nv))
                names.append(("c", j))
        else:                                      # a free constant per joint and sign
            for j in range(nv):
                for sg in (1.0, -1.0):
                    on = signs[:, j] == sg
                    if on.any():
                        u = np.zeros((K, nv))
                        u[on, j] = -sg
                        cols_u.append(u)
                        cols_x0.append(np.zeros(2 * nv))
                        names.append(("c", j))
        cols_u.append(servo)
        cols_x0.append(np.zeros(2 * nv))
        return np.stack(cols_u, axis=2), np.stack(cols_x0, axis=1), names

    def solve(kB, signs):
        U, X0, names = columns(signs)
        X = propagate(kB, U, X0)
        P = at_samples(X)
        m = len(names)
        D = np.zeros((N, nv, nv + m))
        D[:, np.arange(nv), np.arange(nv)] = 1.0                 # q_s
        D[:, :, nv:] = P[:, :, :m]
        for j in range(nv):
            D[~after, j, nv + j] = u_pre                          # the pre-contact line
        y = Q - q_s - P[:, :, m]                                  # the servo part is known
        Aw = (D * wres[None, :, None]).reshape(N * nv, nv + m)
        yw = (y * wres[None, :]).reshape(-1)
        sc = np.abs(Aw).max(axis=0)
        sc[sc == 0] = 1.0
        p, *_ = np.linalg.lstsq(Aw / sc, yw, rcond=None)
        p = p / sc
        r = Aw @ p - yw
        return p, float(r @ r), X, names, Aw

    def search(signs):
        if not np.any(visc > 0):
            return 0.0
        from scipy.optimize import minimize_scalar
        res = minimize_scalar(lambda k: solve(k, signs)[1], bounds=(0.0, opt.joint_viscous_max), method="bounded",
                              options={"xatol": 1e-3})
        return float(res.x)

    # Coulomb signs: start with every joint moving one way (the free Coulomb coefficients
    # take either sign), then the signs of the fitted velocities; the iterate with the
    # smallest residual is kept (near a reversal the signs can cycle between two patterns)
    signs = np.ones((K, nv))
    best = None
    for it in range(max(1, opt.joint_coulomb_iterations)):
        kB = search(signs)
        p, cost, X, names, Aw = solve(kB, signs)
        if best is None or cost < best[1]:
            best = (p, cost, X, names, Aw, kB)
        m = len(names)
        vel = X[:, nv:, :m] @ p[nv:] + X[:, nv:, m]
        new = np.sign(0.5 * (vel[1:] + vel[:-1]))
        if np.array_equal(new, signs):
            break
        signs = new
    p, cost, X, names, Aw, kB = best
    m = len(names)
    qd_s = p[nv:2 * nv]
    qd_e = X[i_end, nv:, :m] @ p[nv:] + X[i_end, nv:, m]
    q_e = q_s + p[:nv] + X[i_end, :nv, :m] @ p[nv:] + X[i_end, :nv, m]
    pin.framesForwardKinematics(model, data, q_e)
    Jn_e = n @ pin.computeFrameJacobian(model, data, q_e, robot.impact_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    v_pre, v_post = float(Jn_s @ qd_s), float(Jn_e @ qd_e)
    if info is not None:
        # the end velocities through the start pose's Jacobian: m_eff_estimator="impulse"
        info["v_post_start_jacobian"] = float(Jn_s @ qd_e)
        # standard deviation of v'_a - v_a from the residual scatter (linear unknowns at
        # the fitted k_B and signs; one more degree of freedom for k_B)
        gvec = np.zeros(nv + m)
        gvec[nv:] = Jn_e @ X[i_end, nv:, :m]
        gvec[nv:2 * nv] -= Jn_s
        sc = np.abs(Aw).max(axis=0)
        sc[sc == 0] = 1.0
        row = np.linalg.pinv(Aw / sc).T @ (gvec / sc)
        dof = max(Aw.shape[0] - Aw.shape[1] - 1, 1)
        info["sd_delta"] = float(math.sqrt(cost / dof) * np.linalg.norm(row) / 1.0)
        info["viscous_scale"] = kB
        info["coulomb_iterations"] = it + 1
    return v_pre, v_post
