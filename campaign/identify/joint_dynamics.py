"""Arm velocity from joint-space dynamics fitted to the encoders."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pinocchio as pin

from .contact import ContactInput, ContactWindow
from .ft_momentum import zoh_integral
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


def joint_dynamics_fit(robot, n: np.ndarray, t: np.ndarray, Q: np.ndarray, c: ContactWindow, cin: ContactInput,
                       ts: np.ndarray, tau: np.ndarray, post_window: float, opt: IdentifyOptions,
                       info: dict | None = None) -> tuple[float, float]:
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
    c : ContactWindow
    cin : ContactInput
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
    joint_model = _LinearJointModel(robot, n, t, Q, c, cin, ts, tau, opt)
    best, iterations = _coulomb_signs(joint_model, opt)
    return _edge_velocities(joint_model, best, iterations, info)


@dataclasses.dataclass(frozen=True)
class _Solution:
    """One least-squares solution of :class:`_LinearJointModel`: the linear unknowns ``p``
    (``q_s`` offsets, then the columns ``names``), the residual's sum of squares ``cost``,
    the node states ``X`` of the columns (the servo's last), the weighted design ``Aw`` and
    the viscous scale ``kB``."""

    p: np.ndarray
    cost: float
    X: np.ndarray
    names: list
    Aw: np.ndarray
    kB: float


class _LinearJointModel:
    """The linear joint-space model of :func:`joint_dynamics_fit` over one trial's window.

    Built at the pre-contact pose ``q_s``: ``H``'s inverse, the gravity stiffness ``G``
    and ``n . J(q_s)``; the integration grid with the force and servo inputs as cell means;
    the cubic Hermite weights that interpolate node states to the sample times.
    """

    def __init__(self, robot, n: np.ndarray, t: np.ndarray, Q: np.ndarray, c: ContactWindow, cin: ContactInput,
                 ts: np.ndarray, tau: np.ndarray, opt: IdentifyOptions):
        self.robot, self.n, self.t, self.Q, self.opt = robot, n, t, Q, opt
        self._linearise(c)
        self._inputs(c, cin, ts, tau)
        self._interpolation(c)

    def _linearise(self, c: ContactWindow) -> None:
        """``q_s``, ``H^-1``, ``G = dg/dq`` and ``n . J(q_s)`` at the pre-contact pose; the
        drive file's friction."""
        robot = self.robot
        model = self.model = robot.model
        data = self.data = model.createData()
        self.nv = model.nv
        q_s = self.q_s = self.Q[self.t < c.start].mean(axis=0)
        H = np.array(pin.crba(model, data, q_s))
        H = np.triu(H) + np.triu(H, 1).T
        self.Minv = np.linalg.inv(H)
        self.G = np.array(pin.computeGeneralizedGravityDerivatives(model, data, q_s))
        pin.framesForwardKinematics(model, data, q_s)
        self.Jn_s = self.n @ pin.computeFrameJacobian(model, data, q_s, robot.impact_frame_id,
                                                      pin.LOCAL_WORLD_ALIGNED)[:3]
        self.visc = np.asarray(robot.viscous, float)
        self.cpos, self.cneg = np.asarray(robot.coulomb_pos, float), np.asarray(robot.coulomb_neg, float)

    def _inputs(self, c: ContactWindow, cin: ContactInput, ts: np.ndarray, tau: np.ndarray) -> None:
        """The integration grid and its inputs, as cell means: the normalised force, the
        servo torque change from its value at t_s."""
        grid = self.grid = _joint_grid(c.start, c.end, max(float(self.t[-1]), c.end) + 1e-9, ts, self.opt)
        self.K = grid.size - 1
        self.steps = np.diff(grid)
        self.i_end = self.opt.joint_contact_steps            # grid[i_end] == c.end
        self.force = _cell_means(grid, lambda x: np.interp(x, cin._tt, cin._I, left=0.0, right=1.0))
        k0 = int(np.searchsorted(ts, c.start, side="right")) - 1
        dtau = tau - tau[max(k0, 0)]
        self.servo = _cell_means(grid, lambda x: zoh_integral(ts, dtau, x))

    def _interpolation(self, c: ContactWindow) -> None:
        """The cells and cubic Hermite weights (positions and velocities at the cell's ends)
        of the samples from the contact start; the pre-contact samples' times from it; each
        joint's weight, the inverse of its encoder resolution."""
        t = self.t
        after = self.after = t >= c.start
        ta = t[after]
        cell = self.cell = np.clip(np.searchsorted(self.grid, ta, side="right") - 1, 0, self.K - 1)
        hstep = self.steps[cell]
        sfrac = (ta - self.grid[cell]) / hstep
        s2, s3 = sfrac * sfrac, sfrac * sfrac * sfrac
        self.hermite = (2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + sfrac) * hstep, -2 * s3 + 3 * s2, (s3 - s2) * hstep)
        self.u_pre = t[~after] - c.start
        self.wres = 1.0 / np.asarray(self.robot.encoder_resolution, float)
        self.N = t.size

    def at_samples(self, X: np.ndarray) -> np.ndarray:
        """Joint positions (N, nv, m) at the sample times from node states X (K+1, 2nv, m)."""
        nv, cell = self.nv, self.cell
        h00, h10, h01, h11 = self.hermite
        P = np.zeros((self.N, nv, X.shape[2]))
        P[self.after] = (h00[:, None, None] * X[cell, :nv] + h10[:, None, None] * X[cell, nv:]
                         + h01[:, None, None] * X[cell + 1, :nv] + h11[:, None, None] * X[cell + 1, nv:])
        return P

    def propagate(self, kB: float, U: np.ndarray, X0: np.ndarray) -> np.ndarray:
        """Node states (K+1, 2nv, m) of m input columns U (K, nv, m) from X0 (2nv, m): the
        model integrated exactly over each step (matrix exponential of the augmented system)."""
        from scipy.linalg import expm  # lazily: see campaign.identify.contact._edge_power

        nv, K, steps, Minv = self.nv, self.K, self.steps, self.Minv
        A = np.zeros((2 * nv, 2 * nv))
        A[:nv, nv:] = np.eye(nv)
        A[nv:, :nv] = -Minv @ self.G
        A[nv:, nv:] = -kB * Minv * self.visc[None, :]
        aug = np.zeros((3 * nv, 3 * nv))
        aug[:2 * nv, :2 * nv] = A
        aug[nv:2 * nv, 2 * nv:] = Minv
        cache = {}
        X = np.empty((K + 1, 2 * nv, U.shape[2]))
        X[0] = X0
        for k in range(K):
            key = round(float(steps[k]) * 1e10)
            if key not in cache:
                E = expm(aug * steps[k])
                cache[key] = (E[:2 * nv, :2 * nv], E[:2 * nv, 2 * nv:])
            Phi, Gam = cache[key]
            X[k + 1] = Phi @ X[k] + Gam @ U[k]
        return X

    def columns(self, signs: np.ndarray):
        """Inputs of the unknown-coefficient columns and the known servo input (last):
        ``(U, X0, names)``, the Coulomb columns for the velocity ``signs`` (K, nv)."""
        nv, K = self.nv, self.K
        cols_u, cols_x0, names = [], [], []
        for j in range(nv):                       # pre-contact velocity of joint j
            x0 = np.zeros(2 * nv)
            x0[nv + j] = 1.0
            cols_u.append(np.zeros((K, nv)))
            cols_x0.append(x0)
            names.append(("v", j))
        for j in range(nv):                       # generalised impulse on joint j
            u = np.zeros((K, nv))
            u[:, j] = self.force
            cols_u.append(u)
            cols_x0.append(np.zeros(2 * nv))
            names.append(("w", j))
        fric = np.where(signs > 0, -self.cpos[None, :], np.where(signs < 0, self.cneg[None, :], 0.0))
        if self.opt.joint_coulomb == "global":     # one scale of the drive file's Coulomb friction
            cols_u.append(fric)
            cols_x0.append(np.zeros(2 * nv))
            names.append(("c", -1))
        elif self.opt.joint_coulomb == "joint":    # one scale per joint
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
        cols_u.append(self.servo)
        cols_x0.append(np.zeros(2 * nv))
        return np.stack(cols_u, axis=2), np.stack(cols_x0, axis=1), names

    def solve(self, kB: float, signs: np.ndarray) -> _Solution:
        """The linear unknowns by weighted least squares at the viscous scale ``kB``, the
        pre-contact samples on their line, the servo's response known."""
        nv, N, after = self.nv, self.N, self.after
        U, X0, names = self.columns(signs)
        X = self.propagate(kB, U, X0)
        P = self.at_samples(X)
        m = len(names)
        D = np.zeros((N, nv, nv + m))
        D[:, np.arange(nv), np.arange(nv)] = 1.0                 # q_s
        D[:, :, nv:] = P[:, :, :m]
        for j in range(nv):
            D[~after, j, nv + j] = self.u_pre                     # the pre-contact line
        y = self.Q - self.q_s - P[:, :, m]                        # the servo part is known
        Aw = (D * self.wres[None, :, None]).reshape(N * nv, nv + m)
        yw = (y * self.wres[None, :]).reshape(-1)
        sc = np.abs(Aw).max(axis=0)
        sc[sc == 0] = 1.0
        p, *_ = np.linalg.lstsq(Aw / sc, yw, rcond=None)
        p = p / sc
        r = Aw @ p - yw
        return _Solution(p=p, cost=float(r @ r), X=X, names=names, Aw=Aw, kB=kB)

    def search(self, signs: np.ndarray) -> float:
        """The viscous scale ``k_B`` in ``[0, joint_viscous_max]`` of least residual (0
        without viscous friction in the drive file)."""
        if not np.any(self.visc > 0):
            return 0.0
        from scipy.optimize import minimize_scalar  # lazily: see campaign.identify.contact._edge_power

        res = minimize_scalar(lambda k: self.solve(k, signs).cost, bounds=(0.0, self.opt.joint_viscous_max),
                              method="bounded", options={"xatol": 1e-3})
        return float(res.x)


def _coulomb_signs(joint_model: _LinearJointModel, opt: IdentifyOptions) -> tuple[_Solution, int]:
    """The solution of least residual over the Coulomb sign iterates, and the iterations run.

    Start with every joint moving one way (the free Coulomb coefficients take either sign),
    then the signs of the fitted velocities; the iterate with the smallest residual is kept
    (near a reversal the signs can cycle between two patterns).
    """
    nv = joint_model.nv
    signs = np.ones((joint_model.K, nv))
    best = None
    for it in range(max(1, opt.joint_coulomb_iterations)):  # noqa: B007 - the count it reaches is returned
        sol = joint_model.solve(joint_model.search(signs), signs)
        if best is None or sol.cost < best.cost:
            best = sol
        m = len(sol.names)
        vel = sol.X[:, nv:, :m] @ sol.p[nv:] + sol.X[:, nv:, m]
        new = np.sign(0.5 * (vel[1:] + vel[:-1]))
        if np.array_equal(new, signs):
            break
        signs = new
    return best, it + 1


def _edge_velocities(joint_model: _LinearJointModel, best: _Solution, iterations: int,
                     info: dict | None) -> tuple[float, float]:
    """``n . J(q_s) qd_s`` and ``n . J(q_e) qd(t_e)`` of the solution; fills ``info``."""
    robot, nv, i_end = joint_model.robot, joint_model.nv, joint_model.i_end
    p, X = best.p, best.X
    m = len(best.names)
    qd_s = p[nv:2 * nv]
    qd_e = X[i_end, nv:, :m] @ p[nv:] + X[i_end, nv:, m]
    q_e = joint_model.q_s + p[:nv] + X[i_end, :nv, :m] @ p[nv:] + X[i_end, :nv, m]
    model, data = joint_model.model, joint_model.data
    pin.framesForwardKinematics(model, data, q_e)
    Jn_e = joint_model.n @ pin.computeFrameJacobian(model, data, q_e, robot.impact_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    v_pre, v_post = float(joint_model.Jn_s @ qd_s), float(Jn_e @ qd_e)
    if info is not None:
        # the end velocities through the start pose's Jacobian: m_eff_estimator="impulse"
        info["v_post_start_jacobian"] = float(joint_model.Jn_s @ qd_e)
        info["sd_delta"] = _delta_sd(joint_model, best, Jn_e)
        info["viscous_scale"] = best.kB
        info["coulomb_iterations"] = iterations
    return v_pre, v_post


def _delta_sd(joint_model: _LinearJointModel, best: _Solution, Jn_e: np.ndarray) -> float:
    """Standard deviation of v'_a - v_a from the residual scatter (linear unknowns at the
    fitted k_B and signs; one more degree of freedom for k_B)."""
    nv, Aw = joint_model.nv, best.Aw
    m = len(best.names)
    gvec = np.zeros(nv + m)
    gvec[nv:] = Jn_e @ best.X[joint_model.i_end, nv:, :m]
    gvec[nv:2 * nv] -= joint_model.Jn_s
    sc = np.abs(Aw).max(axis=0)
    sc[sc == 0] = 1.0
    row = np.linalg.pinv(Aw / sc).T @ (gvec / sc)
    dof = max(Aw.shape[0] - Aw.shape[1] - 1, 1)
    return float(math.sqrt(best.cost / dof) * np.linalg.norm(row) / 1.0)
