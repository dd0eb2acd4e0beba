"""Lambda plus a Coulomb impulse per joint: the smallest model beyond a constant lambda.

The Virtual Rotor Inertia models the joints' resistance during the impact as an inertia:
a generalised impulse ``lambda dq`` proportional to the velocity change (eq 5). Coulomb
friction does not scale so: over a contact of duration ``T`` a slipping joint loses the
impulse ``Tc T`` whatever the blow. With the joint-space impact equation (eq 5) extended
by that term,

    (H + lambda) dq = J_n^T P - kappa o s,      s = sign((H + lambda)^-1 J_n^T),

(``kappa_j >= 0`` the Coulomb impulse of joint j, ``P`` the impulse along n, ``o`` the
element-wise product), the tip's velocity change is ``dv_a = a P - c`` with
``a = J_n (H + lambda)^-1 J_n^T`` (``1/m*`` of eq 11) and ``c = J_n (H + lambda)^-1 (kappa o s)``.
With the hammer's momentum ``P = m_b (v_b - v'_b)`` (eq 10) and the restitution
``v'_a - v'_b = e (v_b - v_a)`` (eq 12; the arm at rest, ``v_a = 0``), the impulse and the
apparent effective mass of eq 10 follow in closed form:

    P = ((1 + e) v + c) / (a + 1/m_b),      m*_apparent = P / (a P - c).

A light blow (slow hammer, heavy effective mass) loses a larger share to friction and
shows a larger m*: the apparent lambda drifts with the impact speed and the pose, which a
constant lambda cannot follow. ``kappa = 0`` gives eq 11 back.

:class:`CoulombLambdaFit` fits ``ln lambda`` and ``ln kappa`` (bounded, >= 0 through
``lambda``, ``kappa`` themselves) by least squares on ``ln m*`` over trials with their
speed, restitution and hammer mass, with asymptotic 95 % intervals from the Jacobian.
What it changes on the designed campaign: user guide, *Experiment design for lambda*,
"Lambda plus a Coulomb impulse" (``docs/design.rst``).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError
from .lambda_fit import design_arrays

__all__ = ["CoulombLambdaFit", "apparent_mass"]


def apparent_mass(H, Jn, lam, kappa, *, speed, e, m_b) -> np.ndarray:
    """``m*_apparent`` of each trial (see the module docstring) [kg]; ``inf`` where friction
    would stop the tip.

    Parameters
    ----------
    H : ndarray, shape (N, nv, nv)
    Jn : ndarray, shape (N, nv)
    lam, kappa : ndarray, shape (nv,)
        Diagonal lambda [kg m^2] and Coulomb impulses [N m s].
    speed, e, m_b : array_like, shape (N,) or scalar
        Hammer speed [m/s], restitution, hammer effective mass [kg].
    """
    Hl = H + np.diag(np.asarray(lam, float))
    x = np.linalg.solve(Hl, Jn[:, :, None])[:, :, 0]            # (H + lambda)^-1 J_n^T
    a = np.einsum("ij,ij->i", Jn, x)
    fr = np.sign(x) * np.asarray(kappa, float)[None, :]
    c = np.einsum("ij,ij->i", Jn, np.linalg.solve(Hl, fr[:, :, None])[:, :, 0])
    v, e, m_b = (np.broadcast_to(np.asarray(z, float), a.shape) for z in (speed, e, m_b))
    P = ((1.0 + e) * v + c) / (a + 1.0 / m_b)
    dv = a * P - c
    out = np.full(a.shape, np.inf)
    ok = dv > 0
    out[ok] = P[ok] / dv[ok]
    return out


class CoulombLambdaFit:
    """Fit diagonal lambda and per-joint Coulomb impulses to identified effective masses.

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    ci : float
        Confidence level of the asymptotic intervals.
    upper : float
        Upper bound of every parameter (lambda [kg m^2], kappa [N m s]).

    Attributes
    ----------
    lambda_, kappa_ : ndarray, shape (nv,)
    lambda_ci_, kappa_ci_ : ndarray, shape (2, nv)
        Asymptotic intervals (``nan`` where a parameter sits on a bound).
    e_ : float
        Mean restitution of the fitted trials (used by :meth:`predict` by default).
    m_b_ : float
        Hammer effective mass of the fitted trials [kg].
    rms_log_residual_ : float
    n_trials_ : int
    """

    def __init__(self, robot, *, ci: float = 0.95, upper: float = 1e4):
        self.robot = robot
        self.ci = ci
        self.upper = upper

    def fit(self, Q, D, m_eff, *, speed, e, m_b) -> CoulombLambdaFit:
        """Fit to trials at DH poses ``Q`` (N, nv) struck along ``D`` (N, 3).

        ``m_eff``, ``speed``, ``e``, ``m_b``: per trial (shape (N,)) identified m* [kg],
        hammer speed [m/s], restitution and hammer mass [kg].
        """
        from scipy.optimize import least_squares
        from scipy.stats import norm


        Q = np.asarray(Q, float)
        m = np.asarray(m_eff, float)
        if Q.ndim != 2 or m.shape != (Q.shape[0],) or not np.all(np.isfinite(m) & (m > 0)):
            raise InputError("CoulombLambdaFit needs (N, nv) poses and N finite effective masses > 0")
        nv = Q.shape[1]
        H, Jn = design_arrays(self.robot, Q, np.asarray(D, float))
        y = np.log(m)
        v, ee, mb = (np.asarray(z, float) for z in (speed, e, m_b))

        def resid(theta):
            mm = apparent_mass(H, Jn, theta[:nv], theta[nv:], speed=v, e=ee, m_b=mb)
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.log(mm) - y
            return np.where(np.isfinite(r), r, 10.0)

        arm = np.maximum(np.asarray(self.robot.armature, float), 1e-3)
        best = None
        for f in (0.1, 1.0):
            t0 = np.concatenate([arm * f, np.full(nv, 0.1)])
            r = least_squares(resid, t0, bounds=(np.zeros(2 * nv), np.full(2 * nv, float(self.upper))),
                              method="trf", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
            if best is None or r.cost < best.cost:
                best = r
        theta = best.x
        n, p = len(y), 2 * nv
        res = resid(theta)
        s2 = float(res @ res) / max(n - p, 1)
        J = best.jac
        z = float(norm.ppf(0.5 + self.ci / 2))
        try:
            cov = s2 * np.linalg.inv(J.T @ J)
            sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        except np.linalg.LinAlgError:
            sd = np.full(p, np.nan)
        on_bound = (theta <= 1e-9) | (theta >= (1 - 1e-6) * self.upper)
        lo, hi = theta - z * sd, theta + z * sd
        lo[on_bound] = np.nan
        hi[on_bound] = np.nan
        self.lambda_, self.kappa_ = theta[:nv].copy(), theta[nv:].copy()
        self.lambda_ci_ = np.array([lo[:nv], hi[:nv]])
        self.kappa_ci_ = np.array([lo[nv:], hi[nv:]])
        self.e_ = float(np.mean(ee))
        self.m_b_ = float(np.mean(mb))
        self.rms_log_residual_ = float(np.sqrt(np.mean(res**2)))
        self.n_trials_ = int(n)
        self.success_ = bool(best.success)
        return self

    def predict(self, Q, D, *, speed, e=None, m_b=None) -> np.ndarray:
        """Apparent m* [kg] at DH poses ``Q`` along ``D`` for hammer ``speed`` (per row);
        restitution and hammer mass default to the fitted trials'."""

        if not hasattr(self, "lambda_"):
            raise InputError("this CoulombLambdaFit is not fitted yet")
        H, Jn = design_arrays(self.robot, np.atleast_2d(np.asarray(Q, float)), np.atleast_2d(np.asarray(D, float)))
        return apparent_mass(H, Jn, self.lambda_, self.kappa_, speed=speed, e=self.e_ if e is None else e,
                             m_b=self.m_b_ if m_b is None else m_b)

    def summary(self) -> dict:
        def js(a):
            a = np.asarray(a, float)
            return [js(x) for x in a] if a.ndim else (float(a) if math.isfinite(a) else None)

        return {"lambda": js(self.lambda_), "lambda_ci": js(self.lambda_ci_), "kappa": js(self.kappa_),
                "kappa_ci": js(self.kappa_ci_), "e": self.e_, "m_b": self.m_b_,
                "rms_log_residual": self.rms_log_residual_, "n_trials": self.n_trials_, "ci": self.ci}
