"""Joint impedance over the contact: eq 11 with the joints' damping, the servo and Coulomb friction.

The Virtual Rotor Inertia (eq 5) treats the joints' resistance during the impact as an
inertia ``lambda``: a generalised impulse proportional to the velocity change, whatever
the pose. On the rig the contact lasts about 70 ms, as long as the joints' own viscous
time constants ``H_jj / b_j``, and the resistance is a damper, the servo's spring
and damper, and Coulomb friction that holds a lightly loaded joint still. None of these
is an inertia, so their equivalent lambda changes with the pose's inertia and with how
much of the impulse each joint sees. This model keeps eq 11's structure and replaces
the inertia by those three terms:

* **Linear part, over the contact.** With the pose's ``H`` held fixed, the joints obey
  ``H qdd + (K_d + beta) qd + K_p q = J_n^T F(t)`` during a force pulse of duration ``T``,
  unit impulse and the shape the piezo channel measures (:func:`measured_pulse_shape`:
  the force peaks at about a fifth of the contact and decays slowly, far from a
  half-sine). The joint velocity at the pulse's end is ``G(T) J_n^T``; ``G(T)``
  (:func:`campaign.joints.pulse.pulse_compliance`) is symmetric and tends to ``H^-1`` (eq 11 with
  ``lambda = 0``) as ``T -> 0``. ``K_p``, ``K_d`` are the servo's known gains
  (:func:`servo_gains`); ``beta`` (one damping per joint: the joints' viscous friction) is
  fitted. Damping and friction belong to the joints, not to the servo, so one fit serves
  every gain set.
* **Coulomb friction, with sticking.** Each joint can lose at most a friction impulse
  ``kappa_j = c Tc_j`` (``Tc_j`` the published joint Coulomb levels for either direction,
  ``c`` [s] fitted). The joints' velocity change minimises
  ``1/2 x^T G^-1 x - x^T J_n^T P + sum_j kappa_j |x_j|`` (:func:`friction_step`): a joint
  whose share of ``J_n^T P`` cannot beat its friction stays still, as a locked joint of
  eq 11 would.
* **The impact** (eqs 10, 12): the impulse ``P`` solves ``n.dv(P) + P / m_b = (1 + e) v``
  (the arm at rest), monotone in ``P``; the apparent effective mass is ``P / n.dv(P)``,
  what the identification's eq 10 measures (:func:`apparent_mass`).

Without servo, damping and friction it is eq 11 with ``lambda = 0`` in the impulsive
limit. :class:`ImpedanceFit` fits ``ln beta`` and ``ln c`` to identified ``ln m*``, with
the pulse's shape and its duration at each speed taken from the fitted trials' measured
channels.
Its measured evidence on the designed campaign: user guide, *Experiment design for
lambda*, "Joint impedance over the contact" (``docs/design.rst``).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..core.errors import InputError
from ..identify import load_trial
from ..rig.controller import joint_gains
from ..scene.description import load_rig
from .lambda_fit import design_arrays
from .params import Params
from .pulse import pulse_compliance

__all__ = ["servo_gains", "half_sine_shape", "measured_pulse_shape", "friction_step",
           "apparent_mass", "ImpedanceFit"]


def servo_gains(robot, gain: str, *, rig=None) -> tuple[np.ndarray, np.ndarray]:
    """The servo's continuous equivalent ``(K_p [N m/rad], K_d [N m s/rad])`` per joint for a
    named gain set of the paper's Table 1 (:func:`campaign.rig.controller.joint_gains`)."""
    kp, kd, _ = joint_gains(gain, values=load_rig(rig)[0], robot=robot)
    return kp, kd


def half_sine_shape(segments: int = 40) -> np.ndarray:
    """A half-sine pulse as the impulse share of each of ``segments`` equal time steps (sums to 1)."""
    edges = np.linspace(0.0, 1.0, int(segments) + 1)
    return 0.5 * (np.cos(np.pi * edges[:-1]) - np.cos(np.pi * edges[1:]))


def measured_pulse_shape(paths, contact_start, contact_end, *, segments: int = 40) -> np.ndarray:
    """The mean force pulse of trials, from their piezo channel (measured), as the impulse
    share of each of ``segments`` equal steps between each trial's contact edges."""

    s = np.linspace(0.0, 1.0, 4 * int(segments) + 1)
    shares = []
    for path, t0, t1 in zip(paths, contact_start, contact_end, strict=True):
        measured, _ = load_trial(path, arrays=True)
        t = np.asarray(measured["t_force"].values, float)
        f = np.clip(np.asarray(measured["f_piezo"].values, float), 0.0, None)
        ft = np.interp(t0 + s * (t1 - t0), t, f)
        seg = 0.5 * (ft[:-1] + ft[1:]).reshape(int(segments), 4).sum(axis=1)   # trapezoids, 4 per step
        if not seg.sum() > 0:
            raise InputError(f"{path}: no force between the contact edges {t0:.6g} and {t1:.6g} s")
        shares.append(seg / seg.sum())
    if not shares:
        raise InputError("measured_pulse_shape needs at least one trial")
    return np.mean(shares, axis=0)


_MODES_CACHE: dict[int, np.ndarray] = {}


def _modes(nv: int) -> np.ndarray:
    if nv not in _MODES_CACHE:
        # stuck first: where a joint is at the boundary, the stuck assignment is taken
        _MODES_CACHE[nv] = np.array(list(itertools.product((0, 1, -1), repeat=nv)), int)
    return _MODES_CACHE[nv]


def friction_step(A, b, *, kappa_pos, kappa_neg) -> np.ndarray:
    """Joint velocity change under Coulomb friction impulses, with sticking.

    ``x = argmin 1/2 x^T A x - b^T x + sum_j (kappa_pos_j max(x_j, 0) + kappa_neg_j max(-x_j, 0))``
    per row (``A`` symmetric positive definite): the stick/slip assignment whose
    conditions hold (slipping joints move in their friction's direction, stuck joints'
    holding impulse within ``[-kappa_neg, kappa_pos]``). ``kappa = 0`` gives ``A^-1 b``.

    Parameters
    ----------
    A : ndarray, shape (N, nv, nv)
    b : ndarray, shape (N, nv)
    kappa_pos, kappa_neg : array_like, shape (nv,)
        Friction impulses [N m s] against positive and negative motion.
    """
    return _friction_modes(A, b, kappa_pos, kappa_neg)[0]


def _friction_modes(A, b, kappa_pos, kappa_neg):
    """:func:`friction_step` and the stick/slip mode of each joint (N, nv): 0 stuck, +-1 slipping."""
    A = np.asarray(A, float)
    b = np.asarray(b, float)
    N, nv = b.shape
    kp = np.asarray(kappa_pos, float)
    kn = np.asarray(kappa_neg, float)
    x_out = np.zeros((N, nv))
    m_out = np.zeros((N, nv), int)
    found = np.zeros(N, bool)
    tol = 1e-12 * (1.0 + np.abs(b).max(axis=1))
    for mode in _modes(nv):
        free = mode != 0
        x = np.zeros((N, nv))
        if free.any():
            f = np.where(mode > 0, kp, -kn)[free]
            Aff = A[:, free][:, :, free]
            x[:, free] = np.linalg.solve(Aff, (b[:, free] - f)[:, :, None])[:, :, 0]
            ok = np.all(x[:, free] * mode[free] >= 0.0, axis=1)
        else:
            ok = np.ones(N, bool)
        if (~free).any():
            hold = (b - np.einsum("nij,nj->ni", A, x))[:, ~free]
            ok &= np.all((hold <= kp[~free] + tol[:, None]) & (hold >= -kn[~free] - tol[:, None]), axis=1)
        take = ok & ~found
        x_out[take] = x[take]
        m_out[take] = mode
        found |= take
        if found.all():
            break
    if not found.all():   # pragma: no cover - the convex problem always has one consistent mode
        raise FloatingPointError("friction_step: no consistent stick/slip assignment")
    return x_out, m_out


def apparent_mass(G, Jn, *, kappa_pos, kappa_neg, speed, e, m_b, iterations: int = 60) -> np.ndarray:
    """The effective mass eq 10 would measure, ``P / n.dv`` [kg]; ``inf`` where friction holds
    every joint that moves the tip.

    Parameters
    ----------
    G : ndarray, shape (N, nv, nv)
        :func:`campaign.joints.pulse.pulse_compliance`.
    Jn : ndarray, shape (N, nv)
        ``n^T J_lin``.
    kappa_pos, kappa_neg : array_like, shape (nv,)
        Coulomb friction impulses [N m s].
    speed, e, m_b : array_like, shape (N,) or scalar
        Hammer speed [m/s], restitution, hammer effective mass [kg].
    """
    G = np.asarray(G, float)
    Jn = np.asarray(Jn, float)
    A = np.linalg.inv(G)
    A = 0.5 * (A + np.swapaxes(A, 1, 2))
    n = Jn.shape[0]
    v, e, m_b = (np.broadcast_to(np.asarray(z, float), (n,)) for z in (speed, e, m_b))
    target = (1.0 + e) * v
    kp, kn = np.asarray(kappa_pos, float), np.asarray(kappa_neg, float)
    eye = np.eye(Jn.shape[1])

    def tip(P):
        """n.dv at impulses P, and the line n.dv = a P - c of the stick/slip mode there."""
        x, mode = _friction_modes(A, Jn * P[:, None], kp, kn)
        free = mode != 0
        both = free[:, :, None] & free[:, None, :]
        Am = np.where(both, A, eye)                      # stuck joints decoupled and held
        Jm = np.where(free, Jn, 0.0)
        fm = np.where(mode > 0, kp, 0.0) - np.where(mode < 0, kn, 0.0)
        y = np.linalg.solve(Am, np.stack([Jm, fm], axis=2))
        return (np.einsum("ij,ij->i", Jn, x), np.einsum("ij,ij->i", Jm, y[:, :, 0]),
                np.einsum("ij,ij->i", Jm, y[:, :, 1]))

    # n.dv(P) + P/m_b is continuous, increasing and piecewise linear in P: Newton on the
    # line of the current stick/slip mode, safeguarded by the bracket [lo, hi]
    lo, hi = np.zeros(n), target * m_b                   # dv >= 0, so P <= (1 + e) v m_b
    P = 0.5 * hi
    for _ in range(iterations):
        dv, a, c = tip(P)
        over = dv + P / m_b > target
        hi = np.where(over, P, hi)
        lo = np.where(over, lo, P)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = (target + c) / (a + 1.0 / m_b)
        done = np.isfinite(newton) & (np.abs(newton - P) <= 1e-13 * target * m_b)   # P on its mode's line
        inside = np.isfinite(newton) & (newton > lo) & (newton < hi)
        P = np.where(done | inside, newton, 0.5 * (lo + hi))
        if done.all():
            break
    dv = tip(P)[0]
    out = np.full(n, np.inf)
    ok = dv > 1e-12 * np.maximum(target, 1e-300)
    out[ok] = P[ok] / dv[ok]
    return out


class ImpedanceFit(Params):
    """Fit the joints' damping and the Coulomb friction scale to identified effective masses.

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    coulomb_pos, coulomb_neg : array_like, shape (nv,), optional
        Published joint Coulomb friction levels [N m] (default: the robot's drive file);
        the fit scales them by one duration ``c``.
    ci : float
        Confidence level of the asymptotic intervals.
    max_relative_ci : float
        A parameter whose interval half-width exceeds this multiple of its value is not
        identifiable.

    Attributes
    ----------
    damping_ : ndarray, shape (nv,)
        ``beta`` [N m s/rad].
    friction_scale_ : float
        ``c`` [s]; the friction impulses are ``c * coulomb_pos``, ``c * coulomb_neg``.
    params_ci_ : ndarray, shape (2, nv + 1)
        95 % (``ci``) intervals of ``[beta, c]`` from the log-parameter Jacobian.
    relative_ci_ : ndarray, shape (nv + 1,)
    identifiable_ : ndarray of bool, shape (nv + 1,)
    condition_number_ : float
        Of the Jacobian ``d ln m* / d ln [beta, c]`` over the fitted trials.
    pulse_shape_ : ndarray, shape (K,)
        Impulse share of each equal step of the contact.
    speeds_, durations_ : ndarray
        The fitted trials' speeds and their mean measured contact durations [s]
        (interpolated in speed by :meth:`predict`).
    e_ : float
        Mean restitution of the fitted trials.
    rms_log_residual_ : float
    n_trials_ : int
    """

    _PARAMS = ("robot", "coulomb_pos", "coulomb_neg", "ci", "max_relative_ci")

    def __init__(self, robot, *, coulomb_pos=None, coulomb_neg=None, ci: float = 0.95, max_relative_ci: float = 1.0):
        self.robot = robot
        self.coulomb_pos = coulomb_pos
        self.coulomb_neg = coulomb_neg
        self.ci = ci
        self.max_relative_ci = max_relative_ci

    def __repr__(self) -> str:
        return f"ImpedanceFit(robot={getattr(self.robot, 'name', self.robot)!r}, ci={self.ci!r})"

    def _friction(self):
        tp = np.asarray(self.robot.coulomb_pos if self.coulomb_pos is None else self.coulomb_pos, float)
        tn = np.asarray(self.robot.coulomb_neg if self.coulomb_neg is None else self.coulomb_neg, float)
        return tp, tn

    def _mass(self, H, Jn, beta, c, *, stiffness, damping, duration, speed, e, m_b):
        G = pulse_compliance(H, stiffness=stiffness, damping=np.asarray(damping) + beta, duration=duration,
                             shape=self.pulse_shape_)
        tp, tn = self._friction()
        return apparent_mass(G, Jn, kappa_pos=c * tp, kappa_neg=c * tn, speed=speed, e=e, m_b=m_b)

    def fit(self, Q, D, m_eff, *, speed, e, m_b, duration, stiffness, damping, pulse_shape) -> ImpedanceFit:
        """Fit to trials at DH poses ``Q`` (N, nv) struck along ``D`` (N, 3).

        ``m_eff``, ``speed``, ``e``, ``m_b``, ``duration``: per trial (shape (N,)) identified
        m* [kg], hammer speed [m/s], restitution, hammer mass [kg] and measured contact
        duration [s]; ``stiffness``, ``damping``: the servo's ``K_p``, ``K_d`` per trial
        (shape (N, nv), :func:`servo_gains`); ``pulse_shape``: the contact force pulse
        (:func:`measured_pulse_shape` of the same trials).
        """
        from scipy.optimize import least_squares
        from scipy.stats import norm


        Q = np.asarray(Q, float)
        m = np.asarray(m_eff, float)
        if Q.ndim != 2 or m.shape != (Q.shape[0],) or not np.all(np.isfinite(m) & (m > 0)):
            raise InputError("ImpedanceFit needs (N, nv) poses and N finite effective masses > 0")
        nv = Q.shape[1]
        v = np.asarray(speed, float)
        T = np.asarray(duration, float)
        if not np.all(np.isfinite(T) & (T > 0)):
            raise InputError("ImpedanceFit needs a measured contact duration > 0 s for every trial")
        self.pulse_shape_ = np.asarray(pulse_shape, float) / float(np.sum(pulse_shape))
        self.speeds_ = np.unique(v)
        self.durations_ = np.array([T[v == s].mean() for s in self.speeds_])
        self.e_ = float(np.mean(e))
        H, Jn = design_arrays(self.robot, Q, np.asarray(D, float))
        kw = dict(stiffness=np.asarray(stiffness, float), damping=np.asarray(damping, float),
                  duration=self._duration(v), speed=v, e=self.e_, m_b=np.asarray(m_b, float))
        y = np.log(m)

        def resid(theta):
            mm = self._mass(H, Jn, np.exp(theta[:nv]), math.exp(theta[nv]), **kw)
            with np.errstate(divide="ignore"):
                r = np.log(mm) - y
            return np.where(np.isfinite(r), r, 10.0)

        # start: the drive file's viscous friction and a contact-long friction impulse at
        # a tenth of the published level
        t0 = np.log(np.concatenate([np.maximum(np.asarray(self.robot.viscous, float), 1e-3), [0.1 * T.mean()]]))
        r = least_squares(resid, t0, method="trf", x_scale=1.0, diff_step=1e-4, xtol=1e-10, ftol=1e-10,
                          max_nfev=200)
        theta = r.x
        res = resid(theta)
        n, p = len(y), nv + 1
        s2 = float(res @ res) / max(n - p, 1)
        J = r.jac
        sv = np.linalg.svd(J, compute_uv=False)
        self.condition_number_ = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
        z = float(norm.ppf(0.5 + self.ci / 2))
        try:
            sd = np.sqrt(np.clip(np.diag(s2 * np.linalg.inv(J.T @ J)), 0.0, None))
        except np.linalg.LinAlgError:
            sd = np.full(p, np.inf)
        est = np.exp(theta)
        self.params_ci_ = np.array([est * np.exp(-z * sd), est * np.exp(z * sd)])
        self.relative_ci_ = np.expm1(z * sd)
        self.identifiable_ = np.isfinite(self.relative_ci_) & (self.relative_ci_ <= self.max_relative_ci)
        self.damping_ = est[:nv].copy()
        self.friction_scale_ = float(est[nv])
        self.rms_log_residual_ = float(np.sqrt(np.mean(res**2)))
        self.residuals_ = res
        self.n_trials_ = int(n)
        self.success_ = bool(r.success)
        return self

    def _duration(self, speed):
        return np.interp(np.asarray(speed, float), self.speeds_, self.durations_)

    def predict(self, Q, D, *, speed, m_b, stiffness, damping, e=None) -> np.ndarray:
        """Apparent m* [kg] at DH poses ``Q`` along ``D`` for hammer ``speed`` and mass ``m_b``
        (per row) under servo gains ``stiffness``, ``damping`` (shape (N, nv)); the pulse
        duration comes from the fitted trials' contacts, interpolated in speed (held at the
        fitted speeds' ends), the restitution is theirs unless given."""

        if not hasattr(self, "damping_"):
            raise InputError("this ImpedanceFit is not fitted yet")
        Q = np.atleast_2d(np.asarray(Q, float))
        H, Jn = design_arrays(self.robot, Q, np.atleast_2d(np.asarray(D, float)))
        v = np.broadcast_to(np.asarray(speed, float), (Q.shape[0],))
        return self._mass(H, Jn, self.damping_, self.friction_scale_, stiffness=stiffness, damping=damping,
                          duration=self._duration(v), speed=v, e=self.e_ if e is None else e, m_b=m_b)

    def summary(self) -> dict:
        """Fitted values and diagnostics as plain numbers."""
        def js(a):
            a = np.asarray(a, float)
            return [js(x) for x in a] if a.ndim else (float(a) if math.isfinite(a) else None)

        return {"damping": js(self.damping_), "friction_scale": self.friction_scale_,
                "params_ci": js(self.params_ci_), "relative_ci": js(self.relative_ci_),
                "identifiable": [bool(x) for x in self.identifiable_], "condition_number": self.condition_number_,
                "speeds": js(self.speeds_), "durations": js(self.durations_), "pulse_shape": js(self.pulse_shape_),
                "e": self.e_,
                "rms_log_residual": self.rms_log_residual_, "n_trials": self.n_trials_, "ci": self.ci}
