"""Virtual Rotor Inertia lambda from identified effective masses (paper eqs 11, 15).

:class:`LambdaFit` is a scikit-learn-shaped estimator: construct it with its settings,
``fit(Q, m_eff)`` does the work, fitted values end in ``_``, ``predict(Q)`` gives m*
from eq 11. It fits ``ln m*`` of eq 11 (with eq 7) over the trials of one gain class by
nonlinear least squares on the log, with an analytic Jacobian; ``lambda`` is diagonal and
>= 0 by default (eq 15), or a full symmetric positive semi-definite matrix. Confidence
intervals come from a bootstrap stratified by configuration; a component the design cannot
determine is flagged (:class:`IdentifiabilityWarning`, ``identifiable_``).

The objective, the bootstrap, the identifiability test and the measured recovery: user
guide, *The lambda fit* (``docs/lambda_fit.rst``).
"""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import pinocchio as pin

from ..core.errors import InputError
from ..model.exiit import effective_mass_batch, impact_jacobian, inertia
from ..model.paper import impact_direction, load_paper
from ..model.robot import Robot, load_robot
from .params import Params

# scipy.optimize (about 0.4 s of imports) is imported by the fit itself, not with the module:
# Tables 3-4 and the calibration report only read fitted values back (LambdaFit.from_summary).

__all__ = ["IdentifiabilityWarning", "LambdaFit", "design_arrays", "sensitivity_matrix"]


class IdentifiabilityWarning(UserWarning):
    """A lambda component is not identifiable from the fitted trials."""


def design_arrays(robot, Q, n):
    """Joint-space inertia and the impact row of the Jacobian for each configuration.

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    Q : array_like, shape (N, nv)
        DH joint angles [rad].
    n : array_like, shape (3,) or (N, 3)
        Unit impact direction, base frame: one for all configurations, or one per row.

    Returns
    -------
    H : ndarray, shape (N, nv, nv)
        ``H(q)`` with the reflected rotor inertia [kg m^2].
    Jn : ndarray, shape (N, nv)
        ``n^T J_lin(q)`` [m].
    """


    model = robot.model
    data = model.createData()
    Q = np.asarray(Q, float)
    N = np.broadcast_to(np.asarray(n, float), (Q.shape[0], 3))
    H = np.empty((Q.shape[0], model.nv, model.nv))
    Jn = np.empty((Q.shape[0], model.nv))
    for i, q in enumerate(Q):
        H[i] = inertia(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        Jn[i] = N[i] @ impact_jacobian(model, data, q, robot.impact_frame_id)[:3]
    return H, Jn


def _solve(H, Jn, lam_m):
    """x = (H + lambda)^-1 Jn and s = Jn . x (= 1/m*) for every configuration."""
    x = np.linalg.solve(H + lam_m, Jn[:, :, None])[:, :, 0]
    s = np.einsum("ij,ij->i", Jn, x)
    return x, s


def sensitivity_matrix(H, Jn, lam) -> np.ndarray:
    """``d ln m* / d ln lambda_j`` for a diagonal lambda, one row per configuration.

    ``= lambda_j x_j^2 / s`` with ``x = (H + lambda)^-1 J^T n`` and ``s = 1/m*``.
    """
    lam = np.asarray(lam, float)
    x, s = _solve(H, Jn, np.diag(lam))
    return lam[None, :] * x**2 / s[:, None]


def _checked_trials(Q, m_eff, sample_weight, nv: int):
    """``(Q, m_eff, weights)`` as float arrays, checked: shapes, finite, m* and weights > 0."""
    Q = np.asarray(Q, float)
    m = np.asarray(m_eff, float)
    if Q.ndim != 2 or Q.shape[1] != nv:
        raise InputError(f"Q must have shape (N, {nv}) (DH radians), got {Q.shape}")
    if m.shape != (Q.shape[0],):
        raise InputError(f"m_eff must have shape ({Q.shape[0]},), got {m.shape}")
    if Q.shape[0] == 0:
        raise InputError("no trials to fit lambda to")
    bad = ~(np.isfinite(m) & (m > 0))
    if bad.any():
        raise InputError(f"m_eff must be finite and > 0 kg; bad values {m[bad].tolist()} at rows "
                         f"{np.flatnonzero(bad).tolist()}")
    if not np.all(np.isfinite(Q)):
        raise InputError("Q has non-finite joint angles")
    w = np.ones(Q.shape[0]) if sample_weight is None else np.asarray(sample_weight, float)
    if w.shape != (Q.shape[0],) or not np.all(np.isfinite(w) & (w > 0)):
        raise InputError("sample_weight must hold one finite weight > 0 per trial")
    return Q, m, w


def _configurations(Q: np.ndarray, directions: np.ndarray):
    """The distinct configurations, pose and direction (strata of the bootstrap, rows of the
    sensitivity matrix): ``(poses, directions, group of each trial)``."""
    nv = Q.shape[1]
    keys = np.round(np.hstack([Q, directions]), 9)
    cells, groups = np.unique(keys, axis=0, return_inverse=True)
    groups = np.ravel(groups)
    return cells[:, :nv], cells[:, nv:], groups


class LambdaFit(Params):
    """Fit the Virtual Rotor Inertia lambda to identified effective masses (eq 11, 15).

    Parameters
    ----------
    robot : campaign.model.robot.Robot or str, optional
        The arm (default: the paper's robot, ``config/paper.yaml``).
    direction : array_like, shape (3,), optional
        Impact direction n in the arm's base frame (default: the paper's, -x).
    structure : {"diagonal", "full"}
        Diagonal lambda >= 0 (eq 15), or a full symmetric PSD matrix.
    n_bootstrap : int
        Bootstrap resamples for the confidence intervals (0: none).
    ci : float
        Confidence level of the percentile intervals.
    random_state : int or numpy.random.Generator, optional
        Seed of the bootstrap.
    min_sensitivity : float
        A component whose largest ``|d ln m*/d ln lambda_j|`` is below this is not
        identifiable.
    max_relative_ci : float
        A component whose CI width exceeds this multiple of its value is not identifiable.
    lambda_max : float
        Upper bound of each diagonal component [kg m^2] (default 1e4, thousands of times
        the arm's joint inertia): a joint the trials show as locked (its lambda running to
        infinity) stops there and is reported as "at its upper bound".
    warn : bool
        Issue :class:`IdentifiabilityWarning` (the findings are stored either way).

    Attributes
    ----------
    lambda_ : ndarray, shape (nv,) or (nv, nv)
        Fitted lambda [kg m^2] (diagonal as a vector, full as a matrix).
    lambda_matrix_ : ndarray, shape (nv, nv)
    lambda_ci_ : ndarray, shape (2, nv) or (2, nv, nv)
        Lower and upper percentile bounds [kg m^2] (nan without bootstrap).
    lambda_boot_ : ndarray
        The bootstrap estimates.
    sensitivity_ : ndarray, shape (n_configurations, nv)
        ``d ln m*/d ln lambda_j`` at the solution per distinct configuration (diagonal
        structure; for ``full``, per independent element ``j <= k``).
    configurations_ : ndarray, shape (n_configurations, nv)
        The distinct configurations (rows of ``sensitivity_``).
    directions_ : ndarray, shape (n_configurations, 3)
        The impact direction of each distinct configuration (a pose struck along two
        directions is two configurations).
    condition_number_ : float
        2-norm condition number of ``sensitivity_`` (``inf`` if rank deficient).
    residuals_ : ndarray, shape (N,)
        ``ln m*_model - ln m*_identified`` per trial.
    rms_log_residual_ : float
    n_trials_ : int
    identifiable_ : ndarray of bool
    identifiability_ : list of str
        One finding per component ("ok" or why not).
    warnings_ : list of str
    """

    def __init__(self, robot=None, *, direction=None, structure: str = "diagonal", n_bootstrap: int = 200,
                 ci: float = 0.95, random_state=None, min_sensitivity: float = 0.05,
                 max_relative_ci: float = 1.0, lambda_max: float = 1e4, warn: bool = True):
        self.robot = robot
        self.direction = direction
        self.structure = structure
        self.n_bootstrap = n_bootstrap
        self.ci = ci
        self.random_state = random_state
        self.min_sensitivity = min_sensitivity
        self.max_relative_ci = max_relative_ci
        self.lambda_max = lambda_max
        self.warn = warn

    # -- scikit-learn protocol ---------------------------------------------------------
    _PARAMS = ("robot", "direction", "structure", "n_bootstrap", "ci", "random_state", "min_sensitivity",
               "max_relative_ci", "lambda_max", "warn")

    def __repr__(self) -> str:
        name = getattr(self.robot, "name", self.robot)
        return f"LambdaFit(robot={name!r}, structure={self.structure!r}, n_bootstrap={self.n_bootstrap})"

    # -- helpers ---------------------------------------------------------------------
    def _setup(self):

        robot = self.robot
        if robot is None:
            robot = load_paper()["robot"]
        if not isinstance(robot, Robot):
            try:
                robot = load_robot(str(robot))
            except ValueError as exc:
                raise InputError(str(exc)) from None
        n = impact_direction() if self.direction is None else np.asarray(self.direction, float)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            raise InputError(f"direction = {np.asarray(self.direction).tolist()} must be a non-zero 3-vector")
        if self.structure not in ("diagonal", "full"):
            raise InputError(f"structure must be 'diagonal' or 'full', got {self.structure!r}")
        if not (isinstance(self.n_bootstrap, (int, np.integer)) and self.n_bootstrap >= 0):
            raise InputError(f"n_bootstrap must be an integer >= 0, got {self.n_bootstrap!r}")
        if not (0 < self.ci < 1):
            raise InputError(f"ci must be in (0, 1), got {self.ci!r}")
        if not (isinstance(self.lambda_max, (int, float)) and self.lambda_max > 0):
            raise InputError(f"lambda_max must be > 0 kg m^2, got {self.lambda_max!r}")
        return robot, n / np.linalg.norm(n)

    def _unpack(self, theta, nv):
        """Parameters -> lambda matrix."""
        if self.structure == "diagonal":
            return np.diag(theta)
        L = np.zeros((nv, nv))
        L[np.tril_indices(nv)] = theta
        return L @ L.T

    def _fit_once(self, H, Jn, y, w, theta0):
        """Least squares on log m*; returns the optimizer result."""
        from scipy.optimize import least_squares

        nv = Jn.shape[1]
        sw = np.sqrt(w)
        tril = np.tril_indices(nv)

        def resid(theta):
            _, s = _solve(H, Jn, self._unpack(theta, nv))
            with np.errstate(divide="ignore", invalid="ignore"):
                return sw * (-np.log(s) - y)

        def jac(theta):
            lam_m = self._unpack(theta, nv)
            x, s = _solve(H, Jn, lam_m)
            if self.structure == "diagonal":
                g = x**2 / s[:, None]                      # d ln m*/d lambda_j
            else:
                L = np.zeros((nv, nv))
                L[tril] = theta
                # d ln m*/dL_ab = (1/s) d(x^T lambda x)/dL_ab with lambda = L L^T:
                # x^T (E_ab L^T + L E_ba) x = 2 x_a (L^T x)_b
                Ltx = L.T @ x.T                            # (nv, N)
                g = np.stack([2 * x[:, a] * Ltx[b] / s for a, b in zip(*tril, strict=True)], axis=1)
            return sw[:, None] * g

        if self.structure == "diagonal":
            bounds = (np.zeros(nv), np.full(nv, float(self.lambda_max)))
        else:
            bounds = (-np.inf, np.inf)
        best = None
        for t0 in theta0:
            r = least_squares(resid, t0, jac=jac, bounds=bounds, method="trf", x_scale="jac",
                              xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=500)
            if best is None or r.cost < best.cost:
                best = r
        return best

    def _starts(self, robot, nv):
        arm = np.maximum(np.asarray(robot.armature, float), 1e-3)
        diag = [arm * f for f in (0.1, 1.0, 10.0)]
        if self.structure == "diagonal":
            return diag
        out = []
        for d in diag:
            L = np.diag(np.sqrt(d))
            out.append(L[np.tril_indices(nv)])
        return out

    # -- public --------------------------------------------------------------------------
    def fit(self, Q, m_eff, sample_weight=None, *, directions=None) -> LambdaFit:
        """Fit lambda to effective masses identified at configurations ``Q``.

        Parameters
        ----------
        Q : array_like, shape (N, nv)
            DH joint angles of the trials [rad] (their commanded configurations).
        m_eff : array_like, shape (N,)
            Identified effective masses [kg], finite and > 0.
        sample_weight : array_like, shape (N,), optional
            Weights of the log residuals (e.g. inverse variances), > 0.
        directions : array_like, shape (N, 3), optional
            Unit impact direction of each trial, base frame; by default every trial is
            struck along the estimator's ``direction``.

        Returns
        -------
        self
        """
        robot, n = self._setup()
        nv = robot.nv
        Q, m, w = _checked_trials(Q, m_eff, sample_weight, nv)
        Nd = self._directions(directions, Q.shape[0], n)
        H, Jn = design_arrays(robot, Q, Nd)
        y = np.log(m)
        n_par = nv if self.structure == "diagonal" else nv * (nv + 1) // 2
        configs, cdirs, groups = _configurations(Q, Nd)
        self.configurations_ = configs
        self.directions_ = cdirs
        theta = self._least_squares(robot, H, Jn, y, w)
        self.n_trials_ = int(Q.shape[0])
        self.n_configurations_ = int(configs.shape[0])
        self.robot_ = robot
        self.direction_ = n
        self._sensitivity(robot, configs, cdirs)
        self._bootstrap(H, Jn, y, w, groups, theta)
        self._assess(n_par, nv)
        return self

    # -- the steps of fit ------------------------------------------------------------------
    def _least_squares(self, robot, H, Jn, y, w) -> np.ndarray:
        """Fit ``ln m*`` of eq 11 from the starts of :meth:`_starts`; sets ``lambda_``,
        ``lambda_matrix_``, the residuals and ``success_``, returns the parameters."""
        nv = robot.nv
        res = self._fit_once(H, Jn, y, w, self._starts(robot, nv))
        theta = res.x
        lam_m = self._unpack(theta, nv)
        lam_m = 0.5 * (lam_m + lam_m.T)
        self.lambda_matrix_ = lam_m
        self.lambda_ = np.diag(lam_m).copy() if self.structure == "diagonal" else lam_m.copy()
        _, s = _solve(H, Jn, lam_m)
        self.residuals_ = -np.log(s) - y
        self.rms_log_residual_ = float(np.sqrt(np.mean(self.residuals_**2)))
        self.success_ = bool(res.success)
        return theta

    def _sensitivity(self, robot, configs, cdirs) -> None:
        """``sensitivity_``, d ln m*/d ln lambda at the solution per distinct configuration,
        and its ``condition_number_``."""
        nv = robot.nv
        lam_m = self.lambda_matrix_
        Hc, Jc = design_arrays(robot, configs, cdirs)
        xc, sc = _solve(Hc, Jc, lam_m)
        if self.structure == "diagonal":
            S = self.lambda_[None, :] * xc**2 / sc[:, None]
        else:
            idx = np.tril_indices(nv)
            S = np.stack([(1.0 if a == b else 2.0) * lam_m[a, b] * xc[:, a] * xc[:, b] / sc for a, b in zip(*idx, strict=True)],
                         axis=1)
        self.sensitivity_ = S
        sv = np.linalg.svd(S, compute_uv=False)
        rank_ok = S.shape[0] >= S.shape[1] and sv.size and sv[-1] > 1e-12 * max(sv[0], 1e-300)
        self.condition_number_ = float(sv[0] / sv[-1]) if rank_ok else float("inf")

    def _bootstrap(self, H, Jn, y, w, groups, theta) -> None:
        """``lambda_ci_`` and ``lambda_boot_`` from a bootstrap over trials, stratified by
        configuration (``groups``: each trial's), each resample fitted from ``theta``."""
        B = int(self.n_bootstrap)
        shape = self.lambda_.shape
        if B == 0:
            self.lambda_ci_ = np.full((2,) + shape, np.nan)
            self.lambda_boot_ = np.empty((0,) + shape)
            return
        nv = Jn.shape[1]
        rng = self.random_state if isinstance(self.random_state, np.random.Generator) \
            else np.random.default_rng(self.random_state)
        members = [np.flatnonzero(groups == g) for g in range(self.n_configurations_)]
        boot = np.empty((B,) + shape)
        # a resample drawn again (same trials in the same order) has the same fit: with few
        # trials per configuration (2 in the reduced campaign: 64 orderings for 3 poses)
        # many of the B draws repeat one already fitted
        fitted: dict[bytes, np.ndarray] = {}
        for b in range(B):
            idx = np.concatenate([rng.choice(mb, size=mb.size, replace=True) for mb in members])
            key = idx.tobytes()
            if key not in fitted:
                rb = self._fit_once(H[idx], Jn[idx], y[idx], w[idx], [theta])
                Lb = self._unpack(rb.x, nv)
                Lb = 0.5 * (Lb + Lb.T)
                fitted[key] = np.diag(Lb) if self.structure == "diagonal" else Lb
            boot[b] = fitted[key]
        alpha = (1 - self.ci) / 2
        self.lambda_ci_ = np.quantile(boot, [alpha, 1 - alpha], axis=0)
        self.lambda_boot_ = boot

    def _assess(self, n_par: int, nv: int) -> None:
        """Identifiability findings per component; warns."""
        S = self.sensitivity_
        msgs: list[str] = []
        findings: list[str] = []
        ok = np.ones(S.shape[1], bool)
        names = ([f"lambda_{j + 1}" for j in range(nv)] if self.structure == "diagonal"
                 else [f"lambda_{a + 1}{b + 1}" for a, b in zip(*np.tril_indices(nv), strict=True)])
        est = self.lambda_ if self.structure == "diagonal" else self.lambda_matrix_[np.tril_indices(nv)]
        lo = self.lambda_ci_[0] if self.structure == "diagonal" else self.lambda_ci_[0][np.tril_indices(nv)]
        hi = self.lambda_ci_[1] if self.structure == "diagonal" else self.lambda_ci_[1][np.tril_indices(nv)]
        if self.n_configurations_ < n_par:
            msgs.append(f"{self.n_configurations_} distinct configurations cannot determine {n_par} lambda "
                        f"parameters ({self.structure} structure)")
        for j, name in enumerate(names):
            why = []
            smax = float(np.max(np.abs(S[:, j]))) if S.size else 0.0
            if est[j] == 0:
                why.append("at its bound 0 (no measurable effect on m*)")
            elif self.structure == "diagonal" and est[j] >= (1 - 1e-6) * self.lambda_max:
                why.append(f"at its upper bound {self.lambda_max:g} kg m^2 (the joint behaves as locked)")
            elif smax < self.min_sensitivity:
                why.append(f"max |d ln m*/d ln {name}| = {smax:.3g} < {self.min_sensitivity:g} "
                           f"(doubling it changes m* by < {100 * smax:.2g} %)")
            if np.isfinite(lo[j]) and np.isfinite(hi[j]) and est[j] != 0:
                rel = (hi[j] - lo[j]) / abs(est[j])
                if rel > self.max_relative_ci:
                    why.append(f"{100 * self.ci:.0f} % CI [{lo[j]:.3g}, {hi[j]:.3g}] is {rel:.2g} times its "
                               f"value {est[j]:.3g}")
            if why:
                ok[j] = False
                findings.append(f"{name}: not identifiable: " + "; ".join(why))
                msgs.append(f"{name} is not identifiable from these trials: " + "; ".join(why))
            else:
                findings.append(f"{name}: ok (max |d ln m*/d ln {name}| = {smax:.3g})")
        if self.n_configurations_ < n_par or not np.isfinite(self.condition_number_):
            # too few distinct poses, or a rank-deficient sensitivity: no component is pinned
            # down by the data, whatever its bootstrap spread (resamples of one pose agree
            # with each other and say nothing about the truth)
            cause = (f"{self.n_configurations_} distinct configuration(s) for {n_par} parameters"
                     if self.n_configurations_ < n_par else "the sensitivity matrix is rank deficient")
            for j, name in enumerate(names):
                if ok[j]:
                    ok[j] = False
                    findings[j] = f"{name}: not identifiable: {cause}"
        if np.isfinite(self.condition_number_) and self.condition_number_ > 100:
            msgs.append(f"sensitivity matrix condition number {self.condition_number_:.3g}: the components are "
                        f"poorly separated by these configurations")
        self.identifiable_ = ok
        self.identifiability_ = findings
        self.warnings_ = msgs
        if self.warn:
            for m in msgs:
                warnings.warn(m, IdentifiabilityWarning, stacklevel=3)

    def _check_fitted(self):
        if not hasattr(self, "lambda_"):
            raise InputError("this LambdaFit is not fitted yet; call fit(Q, m_eff) first")

    def predict(self, Q, *, directions=None) -> np.ndarray:
        """Effective mass from eq 11 with the fitted lambda [kg], shape (N,); ``directions``
        (shape (N, 3)) strikes each configuration along its own direction."""

        self._check_fitted()
        Q = np.asarray(Q, float)
        if Q.ndim == 1:
            Q = Q[None, :]
        if directions is None:
            return effective_mass_batch(self.robot_, Q, self.direction_, self.lambda_matrix_)
        Nd = self._directions(directions, Q.shape[0], self.direction_)
        H, Jn = design_arrays(self.robot_, Q, Nd)
        _, s = _solve(H, Jn, self.lambda_matrix_)
        with np.errstate(divide="ignore"):
            return np.where(s > 0, 1.0 / s, np.inf)

    @staticmethod
    def _directions(directions, N: int, default) -> np.ndarray:
        """Per-trial unit directions, shape (N, 3), checked."""
        if directions is None:
            return np.broadcast_to(np.asarray(default, float), (N, 3)).copy()
        D = np.asarray(directions, float)
        if D.shape != (N, 3) or not np.all(np.isfinite(D)):
            raise InputError(f"directions must have shape ({N}, 3) and be finite, got shape {D.shape}")
        norm = np.linalg.norm(D, axis=1)
        if np.any(norm == 0):
            raise InputError(f"directions has zero vectors at rows {np.flatnonzero(norm == 0).tolist()}")
        return D / norm[:, None]

    @classmethod
    def from_summary(cls, summary: dict, *, robot=None, direction=None) -> LambdaFit:
        """A fitted estimator holding the values of :meth:`summary` (read back from JSON).

        Everything Tables 3-4 and the reports read comes back (``lambda_``,
        ``lambda_matrix_``, ``lambda_ci_``, the sensitivity, identifiability and warnings;
        ``null`` as NaN, or inf for the condition number); the bootstrap samples and
        residuals do not. :meth:`predict` needs ``robot`` and ``direction``.
        """
        def arr(value):
            return np.array(value if value is not None else np.nan, dtype=float)

        try:
            est = cls(robot, direction=direction, structure=str(summary["structure"]), ci=float(summary["ci"]),
                      n_bootstrap=int(summary["n_bootstrap"]))
            est.lambda_ = arr(summary["lambda"])
            est.lambda_matrix_ = np.diag(est.lambda_) if est.structure == "diagonal" else est.lambda_.copy()
            est.lambda_ci_ = arr(summary["lambda_ci"])
            est.sensitivity_ = arr(summary["sensitivity"])
            est.configurations_ = arr(summary["configurations"])
            cond = summary["condition_number"]
            est.condition_number_ = float("inf") if cond is None else float(cond)
            est.rms_log_residual_ = float(summary["rms_log_residual"])
            est.n_trials_ = int(summary["n_trials"])
            est.n_configurations_ = int(est.configurations_.shape[0])
            est.identifiable_ = np.array([bool(x) for x in summary["identifiable"]])
            est.identifiability_ = list(summary["identifiability"])
            est.warnings_ = [str(w) for w in summary["warnings"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"not a LambdaFit summary: {type(exc).__name__} {exc}") from None
        if robot is not None:
            est.robot_, est.direction_ = robot, direction
        return est

    def summary(self) -> dict:
        """JSON-safe dict of the fitted values."""
        self._check_fitted()

        def js(a):
            a = np.asarray(a, float)
            return [js(x) for x in a] if a.ndim else (float(a) if math.isfinite(a) else None)

        return {
            "structure": self.structure, "lambda": js(self.lambda_), "lambda_ci": js(self.lambda_ci_),
            "ci": self.ci, "n_bootstrap": int(self.n_bootstrap), "sensitivity": js(self.sensitivity_),
            "configurations": js(self.configurations_), "directions": js(getattr(self, "directions_", np.empty((0, 3)))),
            "condition_number": js(self.condition_number_),
            "rms_log_residual": self.rms_log_residual_, "n_trials": self.n_trials_,
            "identifiable": [bool(x) for x in self.identifiable_], "identifiability": list(self.identifiability_),
            "warnings": list(self.warnings_),
        }


def load_fits(results: Mapping[str, str | os.PathLike]) -> dict[str, Any]:
    """The fitted :class:`campaign.joints.lambda_fit.LambdaFit` of each gain class, read back from
    :func:`campaign.pipeline.fit.fit_lambda`'s JSON (:meth:`campaign.joints.lambda_fit.LambdaFit.from_summary`)."""
    out = {}
    for gain_class, path in results.items():
        with open(path, encoding="utf-8") as fh:
            try:
                out[gain_class] = LambdaFit.from_summary(json.load(fh))
            except (ValueError, InputError) as exc:
                raise InputError(f"{path}: {exc}") from None
    return out

