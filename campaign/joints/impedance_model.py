"""The joints' impedance over the contact as a fitted model: damping and Coulomb friction.

:class:`JointImpedance` predicts m* as eq 10 measures it with the arm's response to the
contact law's pulse (:func:`campaign.joints.response.respond`: the servo's known gains, the
joints' damping ``beta`` and Coulomb friction with sticking, gravity, the pose's motion;
on the flexible base the named structure and the VES-II loop). It fits ``ln beta`` (one per
joint) and ``ln s``, the scale of the robot's published Coulomb levels (drive file), to
identified ``ln m*`` of fixed-base trials by least squares. Damping and friction belong to
the joints, not to the servo, so one fit on the trials of every gain set serves all of
them, and both bases. The restitution of eq 14 is the fitted trials' mean.

Intervals: the parameters' covariance ``s^2 (J^T J)^-1`` (Gauss-Newton, ``s^2`` the
residual variance) carried to ``ln m*`` through its finite-difference gradient, plus the
residual scatter: the scatter model the designed campaign fits (``scatter_model_``,
:mod:`campaign.joints.scatter`), else ``s`` itself. The measured accuracy: user guide, *The response model*.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from ..core.errors import InputError
from ..core.stats import Z95
from ..core.vocabulary import FIXED, FLEXIBLE
from .estimator import ResponseModel, json_numbers
from .impacts import Impacts
from .response import STEPS_PER_CONTACT, WINDOW_SAMPLES, Response, respond
from .setting import Setting
from .terms import arm_terms

__all__ = ["JointImpedance", "DIFF_STEP"]

#: relative step of the finite differences on the log parameters (fit and interval gradients)
DIFF_STEP = 1e-4


class JointImpedance(ResponseModel):
    """The joints' damping and Coulomb friction fitted to identified m* (see the module notes).

    Parameters
    ----------
    setting : Setting, optional
        The rig and robot (default ``config/rig.yaml``).
    steps, samples : int
        Steps over the shortest contact; per first-mode period after it
        (:func:`campaign.joints.response.respond`).
    coupling : {"ideal", "loop"}, optional
        The flexible base's coupling; default the rig's (``ves.mode``).
    max_relative_ci : float
        A parameter whose 95 % interval half-width exceeds this multiple of its value is
        reported not identifiable.

    Attributes
    ----------
    damping_ : ndarray, shape (nv,)
        ``beta`` [N m s/rad].
    friction_scale_ : float
        ``s``: the joints' Coulomb levels are ``s`` times the drive file's.
    coulomb_pos_, coulomb_neg_ : ndarray, shape (nv,)
        The fitted Coulomb levels [N m].
    restitution_ : float
        The fitted trials' mean restitution (eq 14's e).
    covariance_ : ndarray, shape (nv + 1, nv + 1)
        Of ``[ln beta, ln s]``.
    params_ci_ : ndarray, shape (2, nv + 1)
        95 % intervals of ``[beta, s]``.
    relative_ci_, identifiable_ : ndarray, shape (nv + 1,)
    condition_number_ : float
        Of the Jacobian ``d ln m* / d [ln beta, ln s]`` over the fitted trials.
    residuals_, rms_log_residual_, residual_scatter_, n_trials_, keys_
    """

    kind: ClassVar[str] = "joint_impedance"
    _PARAMS = ("setting", "steps", "samples", "coupling", "max_relative_ci")

    def __init__(self, setting: Setting | None = None, *, steps: int = STEPS_PER_CONTACT,
                 samples: int = WINDOW_SAMPLES, coupling: str | None = None, max_relative_ci: float = 1.0):
        super().__init__(setting)
        self.steps = steps
        self.samples = samples
        self.coupling = coupling
        self.max_relative_ci = max_relative_ci
        self._structures: dict = {}

    def __repr__(self) -> str:
        return f"JointImpedance(robot={self._the_setting().robot.name!r}, steps={self.steps!r})"

    # -- the response ----------------------------------------------------------------------
    def setting_for(self, structure: str | None):
        """The setting whose flexible base is the named structure."""
        setting = self._the_setting()
        if structure is None or structure == setting.structure:
            return setting
        if structure not in self._structures:
            self._structures[structure] = Setting.from_rig(setting.rig_path(), structure=structure, robot=setting.robot)
        return self._structures[structure]

    def respond_terms(self, terms, gains, directions, *, speed, mass, pendulum: bool = True, theta=None,
                      window: bool = True, structure: str | None = None, restitution=None,
                      coupling: str | None = None) -> Response:
        """The response of C cases (``terms``: one pose each, from
        :func:`campaign.joints.terms.arm_terms`, with its base on the flexible base) under the
        gain sets ``gains`` (C names) x D variants (``directions`` (D, 3) or (C, D, 3); ``speed``,
        ``mass`` scalars or (C, D)), the object the rig's pendulum hammer or (``pendulum=False``)
        a free body; ``theta`` overrides ``[ln beta, ln s]``, ``coupling`` the flexible base's
        (``ideal`` or ``loop``)."""
        setting = self.setting_for(structure)
        th = self._theta() if theta is None else np.asarray(theta, float)
        nv = setting.robot.nv
        beta, s = np.exp(th[:nv]), math.exp(th[nv])
        kp, kd = setting.servo(gains)
        e = self.restitution_ if restitution is None else restitution
        if terms.base is None:
            coupling = None
        elif coupling is None:
            coupling = self.coupling or ("loop" if setting.loop is not None else "ideal")
        return respond(terms, kp=kp, kd=kd, damping=beta, coulomb_pos=s * setting.robot.coulomb_pos,
                       coulomb_neg=s * setting.robot.coulomb_neg, directions=directions, speed=speed, mass=mass,
                       restitution=e, contact=setting.contact, gravity=setting.gravity,
                       servo_period=setting.servo_period, coupling=coupling, loop=setting.loop, window=window,
                       steps=int(self.steps), samples=int(self.samples),
                       object_stiffness=setting.hammer_stiffness if pendulum else 0.0)

    def respond(self, impacts: Impacts, *, theta=None, window: bool = True, terms=None) -> Response:
        """The full response of each impact (one case each): m*, impulse, duration, velocities
        and, on the flexible base, the structure's peak displacement (shapes (N, 1, ...))."""
        impacts = self._check_impacts(impacts)
        setting = self.setting_for(impacts.structure)
        if terms is None:
            terms = arm_terms(setting.robot, impacts.q, beam=setting.beam if impacts.base == FLEXIBLE else None)
        return self.respond_terms(terms, impacts.gain, impacts.direction[:, None, :], speed=impacts.speed[:, None],
                                  mass=self._masses(impacts)[:, None], pendulum=impacts.pendulum, theta=theta,
                                  window=window, structure=impacts.structure)

    def _theta(self) -> np.ndarray:
        if not hasattr(self, "damping_"):
            raise InputError("this JointImpedance is not fitted yet; call fit(impacts) first")
        return np.concatenate([np.log(self.damping_), [math.log(self.friction_scale_)]])

    def predict(self, impacts: Impacts) -> np.ndarray:
        """m* [kg] of each impact as eq 10 measures it."""
        return self.respond(impacts, window=False).m_eff[:, 0]

    def parameter_sd(self, impacts: Impacts) -> np.ndarray:
        """``sqrt(g^T cov g)`` with ``g = d ln m* / d [ln beta, ln s]`` per impact (finite differences;
        0 where m* has no finite value)."""
        impacts = self._check_impacts(impacts)
        setting = self.setting_for(impacts.structure)
        terms = arm_terms(setting.robot, impacts.q, beam=setting.beam if impacts.base == FLEXIBLE else None)
        th = self._theta()
        base = np.log(self.respond(impacts, theta=th, window=False, terms=terms).m_eff[:, 0])
        G = np.zeros((len(impacts), th.size))
        for j in range(th.size):
            t = th.copy()
            t[j] += DIFF_STEP
            moved = np.log(self.respond(impacts, theta=t, window=False, terms=terms).m_eff[:, 0])
            ok = np.isfinite(base) & np.isfinite(moved)      # m* without a value has no gradient (sd 0)
            G[ok, j] = (moved[ok] - base[ok]) / DIFF_STEP
        return np.sqrt(np.clip(np.einsum("ni,ij,nj->n", G, self.covariance_, G), 0.0, None))

    # -- the fit ---------------------------------------------------------------------------
    def fit(self, impacts: Impacts) -> JointImpedance:
        """Fit ``ln beta`` and ``ln s`` to the identified ``ln m*`` of fixed-base ``impacts``."""
        from scipy.optimize import least_squares  # scipy.optimize costs ~0.4 s to import: the fit only

        impacts = self._check_impacts(impacts, fitting=True)
        if impacts.base != FIXED:
            raise InputError("JointImpedance fits on fixed-base impacts (the flexible base adds the structure)")
        setting = self._the_setting()
        nv = setting.robot.nv
        self.restitution_ = (float(np.mean(impacts.restitution)) if impacts.restitution is not None
                             else float(setting.contact.restitution))
        terms = arm_terms(setting.robot, impacts.q)
        y = np.log(impacts.m_eff)

        def resid(theta):
            m = self.respond(impacts, theta=theta, window=False, terms=terms).m_eff[:, 0]
            with np.errstate(divide="ignore"):
                r = np.log(m) - y
            return np.where(np.isfinite(r), r, 10.0)

        # start: the drive file's viscous friction and a tenth of its Coulomb levels
        t0 = np.log(np.concatenate([np.maximum(np.asarray(setting.robot.viscous, float), 1e-3), [0.1]]))
        r = least_squares(resid, t0, method="trf", x_scale=1.0, diff_step=DIFF_STEP, xtol=1e-10, ftol=1e-10,
                          max_nfev=200)
        self._store_fit(r.x, resid(r.x), r.jac, bool(r.success))
        self._record_fit(impacts, np.exp(y + resid(r.x)), nv + 1)
        return self

    def _store_fit(self, theta, res, J, success: bool) -> None:
        """The fitted values, their covariance and intervals, the Jacobian's condition."""
        setting = self._the_setting()
        nv = setting.robot.nv
        n, p = res.size, theta.size
        s2 = float(res @ res) / max(n - p, 1)
        sv = np.linalg.svd(J, compute_uv=False)
        self.condition_number_ = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
        try:
            cov = s2 * np.linalg.inv(J.T @ J)
        except np.linalg.LinAlgError:
            cov = np.full((p, p), np.inf)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        est = np.exp(theta)
        self.covariance_ = cov
        self.params_ci_ = np.array([est * np.exp(-Z95 * sd), est * np.exp(Z95 * sd)])
        self.relative_ci_ = np.expm1(Z95 * sd)
        self.identifiable_ = np.isfinite(self.relative_ci_) & (self.relative_ci_ <= self.max_relative_ci)
        self.damping_ = est[:nv].copy()
        self.friction_scale_ = float(est[nv])
        self.coulomb_pos_ = self.friction_scale_ * np.asarray(setting.robot.coulomb_pos, float)
        self.coulomb_neg_ = self.friction_scale_ * np.asarray(setting.robot.coulomb_neg, float)
        self.success_ = success

    def parameters(self) -> dict:
        return {"damping": json_numbers(self.damping_), "friction_scale": self.friction_scale_,
                "restitution": self.restitution_, "covariance": json_numbers(self.covariance_),
                "params_ci": json_numbers(self.params_ci_), "relative_ci": json_numbers(self.relative_ci_),
                "identifiable": [bool(x) for x in self.identifiable_], "condition_number": json_numbers(self.condition_number_),
                "coulomb_pos": json_numbers(self.coulomb_pos_), "coulomb_neg": json_numbers(self.coulomb_neg_)}

    def set_fitted(self, parameters: dict) -> JointImpedance:
        """Hold the fitted values of :meth:`parameters` (read back from a model file)."""
        setting = self._the_setting()
        nv = setting.robot.nv
        damping = np.asarray(parameters["damping"], float)
        cov = np.asarray(parameters["covariance"], float)
        if damping.shape != (nv,) or cov.shape != (nv + 1, nv + 1):
            raise InputError(f"joint_impedance parameters do not fit a robot with {nv} joints")
        theta = np.concatenate([np.log(damping), [math.log(float(parameters["friction_scale"]))]])
        self.restitution_ = float(parameters["restitution"])
        self.damping_ = damping
        self.friction_scale_ = float(parameters["friction_scale"])
        self.covariance_ = cov
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        est = np.exp(theta)
        self.params_ci_ = np.array([est * np.exp(-Z95 * sd), est * np.exp(Z95 * sd)])
        self.relative_ci_ = np.expm1(Z95 * sd)
        self.identifiable_ = np.isfinite(self.relative_ci_) & (self.relative_ci_ <= self.max_relative_ci)
        cond = parameters.get("condition_number")
        self.condition_number_ = math.inf if cond is None else float(cond)
        self.coulomb_pos_ = self.friction_scale_ * np.asarray(setting.robot.coulomb_pos, float)
        self.coulomb_neg_ = self.friction_scale_ * np.asarray(setting.robot.coulomb_neg, float)
        return self
