"""The estimator interface of the joint-resistance models (:class:`ResponseModel`) and its eq 11 kinds.

Every model takes a :class:`campaign.joints.setting.Setting` (the rig and robot it works
on) and keyword-only options; ``fit(impacts)`` estimates its parameters from identified m*
(:class:`campaign.joints.impacts.Impacts`), fitted values end in ``_``; ``predict(impacts)``
gives m* [kg] as eq 10 measures it; ``predict_interval(impacts)`` a 95 % interval (the
parameters' uncertainty and the residual scatter: the scatter model's where the model has
one, :mod:`campaign.joints.scatter`, else the fit's); ``summary()`` plain numbers.
:mod:`campaign.joints.modelfile` saves and loads any of them as JSON.

* :class:`Eq11Model`  eq 11 with a given lambda per gain class (the paper's Table 3 by
  default); eq 7 on the fixed base, eq 8 on the flexible base. ``fit`` only records the
  residuals on the trials given.
* :class:`LambdaModel`  lambda fitted per gain class (eq 11, 15; :class:`campaign.joints.lambda_fit.LambdaFit`).
* :class:`CoulombModel`  lambda plus a Coulomb impulse per joint, per gain class
  (:class:`campaign.joints.coulomb.CoulombLambdaFit`); fixed base only.
* :class:`campaign.joints.impedance_model.JointImpedance`  the joints' impedance over the contact's
  pulse (:mod:`campaign.joints.response`), one fit for every gain set, both bases.

The models and their measured accuracy: user guide, *The response model*
(``docs/response_model.rst``).
"""

from __future__ import annotations

import math
import warnings
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, FLEXIBLE, gain_classes
from ..model.paper import load_paper
from .coulomb import CoulombLambdaFit
from .domain import Domain
from .impacts import Impacts
from .lambda_fit import IdentifiabilityWarning, LambdaFit
from .params import Params
from .scatter import tip_velocity_change
from .setting import Setting
from .terms import arm_terms

__all__ = ["ResponseModel", "Eq11Model", "LambdaModel", "CoulombModel", "class_of", "json_numbers"]


def class_of(gain: str) -> str:
    """The paper's gain class of a gain set (``zero`` -> ``zero_low``); a set in no class is its own."""
    for cls, members in gain_classes().items():
        if gain in members:
            return cls
    return gain


def _z(level: float) -> float:
    from scipy.stats import norm  # scipy.stats costs ~0.3 s to import; only intervals need it

    if not (0.0 < float(level) < 1.0):
        raise InputError(f"interval level must be in (0, 1), got {level!r}")
    return float(norm.ppf(0.5 + float(level) / 2.0))


class ResponseModel(Params, ABC):
    """The interface of the joint-resistance models (see the module notes).

    Parameters
    ----------
    setting : Setting, optional
        The rig and robot (default :meth:`Setting.from_rig` of ``config/rig.yaml``).
    """

    kind: ClassVar[str] = ""
    #: the bases the model predicts on
    supported_bases: ClassVar[tuple[str, ...]] = (FIXED, FLEXIBLE)
    _PARAMS = ("setting",)

    def __init__(self, setting: Setting | None = None):
        self.setting = setting

    # -- helpers -------------------------------------------------------------------------
    def _the_setting(self) -> Setting:
        if self.setting is None:
            self.setting = Setting.from_rig()
        return self.setting

    def _check_impacts(self, impacts: Impacts, *, fitting: bool = False) -> Impacts:
        if not isinstance(impacts, Impacts):
            raise InputError(f"{type(self).__name__} takes an Impacts table, got {type(impacts).__name__}")
        nv = self._the_setting().robot.nv
        if impacts.q.shape[1] != nv:
            raise InputError(f"impacts have {impacts.q.shape[1]} joint angles; the robot has {nv}")
        if impacts.base not in self.supported_bases:
            raise InputError(f"{type(self).__name__} predicts on the {' and '.join(self.supported_bases)} base only, "
                             f"not the {impacts.base} base")
        if fitting and impacts.m_eff is None:
            raise InputError(f"{type(self).__name__}.fit needs identified m* (impacts.m_eff)")
        return impacts

    def _masses(self, impacts: Impacts) -> np.ndarray:
        return impacts.mass if impacts.mass is not None else np.full(len(impacts), self._the_setting().hammer_mass)

    def _restitution(self) -> float:
        """Eq 14's restitution of the model's predictions (the fitted one, else the contact law's)."""
        return float(getattr(self, "restitution_", self._the_setting().contact.restitution))

    def _record_fit(self, impacts: Impacts, predicted: np.ndarray, n_parameters: int) -> None:
        """Residuals ``ln m*_model - ln m*_identified`` per fitted impact, their rms and scatter."""
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.log(np.asarray(predicted, float)) - np.log(impacts.m_eff)
        r = np.where(np.isfinite(r), r, np.nan)
        self.residuals_ = r
        self.keys_ = impacts.keys if impacts.keys is not None else tuple(str(i) for i in range(len(impacts)))
        self.n_trials_ = len(impacts)
        ok = np.isfinite(r)
        self.rms_log_residual_ = float(np.sqrt(np.mean(r[ok] ** 2))) if ok.any() else math.nan
        dof = max(int(ok.sum()) - int(n_parameters), 1)
        self.residual_scatter_ = float(np.sqrt(np.sum(r[ok] ** 2) / dof)) if ok.any() else math.nan
        structure = impacts.structure or (self._the_setting().structure if impacts.base == FLEXIBLE else None)
        self.domain_ = Domain.from_impacts(impacts, masses=self._masses(impacts), structure=structure)

    def _check_fitted(self) -> None:
        if not hasattr(self, "residuals_"):
            raise InputError(f"this {type(self).__name__} is not fitted yet; call fit(impacts) first")

    # -- the interface -------------------------------------------------------------------
    @abstractmethod
    def fit(self, impacts: Impacts) -> ResponseModel:
        """Fit the model to ``impacts`` with identified m*; returns ``self``."""

    @abstractmethod
    def predict(self, impacts: Impacts) -> np.ndarray:
        """m* [kg] of each impact."""

    def parameter_sd(self, impacts: Impacts) -> np.ndarray:
        """Standard deviation of ``ln m*`` from the parameters' uncertainty, per impact (0 here)."""
        return np.zeros(len(impacts))

    def scatter(self, impacts: Impacts, m_eff=None):
        """The residual scatter of ``ln m*`` the intervals carry: with a scatter model
        (``scatter_model_``, :mod:`campaign.joints.scatter`) per impact from its gain set, its
        structure, its speed, the predicted ``m_eff`` and the tip velocity change it gives; without one the
        fit's, or on the flexible base the one measured under the impacts' structure where the
        model has it (``structure_scatter_``)."""
        sm = getattr(self, "scatter_model_", None)
        if sm is not None and m_eff is not None:
            dv = tip_velocity_change(m_eff, impacts.speed, self._masses(impacts), self._restitution())
            structure = (impacts.structure or self._the_setting().structure) if impacts.base == FLEXIBLE else None
            return sm.sd(impacts.gain, dv, impacts.speed, m_eff, structure=structure)
        if impacts.base == FLEXIBLE:
            name = impacts.structure or self._the_setting().structure
            extra = getattr(self, "structure_scatter_", {})
            if name in extra:
                return float(extra[name])
        return float(self.residual_scatter_)

    def interval_quantile(self, level: float) -> float:
        """The multiple of the sd of ``ln m*`` a two-sided interval of ``level`` spans: the
        scatter model's (its residuals' tails) where the model has one, else the normal's."""
        sm = getattr(self, "scatter_model_", None)
        return sm.quantile(level) if sm is not None else _z(level)

    def predict_interval(self, impacts: Impacts, *, level: float = 0.95):
        """``(m*, lower, upper)`` [kg]: the prediction and its interval from the parameters'
        uncertainty and the residual scatter (:meth:`scatter`), combined on ``ln m*``; its
        width the scatter model's quantile of ``level`` where the model has one, else the
        normal distribution's."""
        self._check_fitted()
        m = self.predict(impacts)
        sd = np.sqrt(self.parameter_sd(impacts) ** 2 + self.scatter(impacts, m) ** 2)
        z = self.interval_quantile(level)
        with np.errstate(invalid="ignore", over="ignore"):
            lo, hi = m * np.exp(-z * sd), m * np.exp(z * sd)
        valueless = ~np.isfinite(m)          # recoil or unbounded: no interval, the value itself
        return m, np.where(valueless, m, lo), np.where(valueless, m, hi)

    def summary(self) -> dict:
        """The fitted values and the fit's diagnostics as plain numbers."""
        self._check_fitted()
        return {"kind": self.kind, "parameters": self.parameters(), "n_trials": self.n_trials_,
                "rms_log_residual": self.rms_log_residual_, "residual_scatter": self.residual_scatter_}

    @abstractmethod
    def parameters(self) -> dict:
        """The fitted parameters as plain numbers."""


def json_numbers(a):
    """Nested lists of floats (``None`` for a non-finite number)."""
    a = np.asarray(a, float)
    return [json_numbers(x) for x in a] if a.ndim else (float(a) if math.isfinite(a) else None)


def _eq11(setting: Setting, impacts: Impacts, lam_of_gain) -> np.ndarray:
    """Eq 11 with each impact's lambda (diagonal): eq 7 on the fixed base, eq 8 on the flexible
    base (the arm on the structure's tip body, lambda added to its joints)."""
    flexible = impacts.base == FLEXIBLE
    beam = setting.beam if impacts.structure is None or impacts.structure == setting.structure else \
        Setting.from_rig(setting.rig_path(), structure=impacts.structure, robot=setting.robot).beam
    terms = arm_terms(setting.robot, impacts.q, beam=beam if flexible else None)
    lam = np.array([np.asarray(lam_of_gain(g), float) for g in impacts.gain])          # (N, nv)
    nv = lam.shape[1]
    if flexible:
        M = terms.base.M.copy()
        M[:, 6:, 6:] += lam[:, :, None] * np.eye(nv)
        Jn = np.einsum("ni,nij->nj", impacts.direction, terms.base.J)
    else:
        M = terms.H + lam[:, :, None] * np.eye(nv)
        Jn = np.einsum("ni,nij->nj", impacts.direction, terms.J)
    s = np.einsum("ni,ni->n", Jn, np.linalg.solve(M, Jn[:, :, None])[:, :, 0])
    with np.errstate(divide="ignore"):
        return np.where(s > 0, 1.0 / s, np.inf)


class Eq11Model(ResponseModel):
    """Eq 11 with a given lambda per gain class (eq 7 fixed, eq 8 flexible).

    Parameters
    ----------
    setting : Setting, optional
    lambdas : mapping of str to 3 floats, optional
        Gain class (or gain set) -> diagonal lambda [kg m^2]; default the paper's Table 3.

    Attributes
    ----------
    lambdas_ : dict of str to list of float
    residuals_, rms_log_residual_, residual_scatter_, n_trials_, keys_
        On the impacts ``fit`` was given (nothing is estimated).
    """

    kind = "eq11"
    _PARAMS = ("setting", "lambdas")

    def __init__(self, setting: Setting | None = None, *, lambdas=None):
        super().__init__(setting)
        self.lambdas = lambdas

    def _lambdas(self) -> dict:
        src = self.lambdas if self.lambdas is not None else load_paper()["table3"]
        nv = self._the_setting().robot.nv
        out = {}
        for k, v in dict(src).items():
            a = np.asarray(v, float)
            if a.shape != (nv,) or not np.all(np.isfinite(a) & (a >= 0)):
                raise InputError(f"lambda of {k!r} must be {nv} values >= 0 kg m^2, got {np.asarray(v).tolist()}")
            out[str(k)] = a
        return out

    def _lam(self, gain: str):
        lams = self.lambdas_ if hasattr(self, "lambdas_") else self._lambdas()
        for key in (gain, class_of(gain)):
            if key in lams:
                return lams[key]
        raise InputError(f"no lambda for gain set {gain!r} (class {class_of(gain)!r}); the model has {sorted(lams)}")

    def fit(self, impacts: Impacts) -> Eq11Model:
        """Record the residuals of the given lambda on ``impacts`` (nothing is estimated)."""
        impacts = self._check_impacts(impacts, fitting=True)
        self.lambdas_ = self._lambdas()
        self._record_fit(impacts, self.predict(impacts), 0)
        return self

    def predict(self, impacts: Impacts) -> np.ndarray:
        impacts = self._check_impacts(impacts)
        return _eq11(self._the_setting(), impacts, self._lam)

    def parameters(self) -> dict:
        return {"lambda": {k: json_numbers(v) for k, v in (self.lambdas_ if hasattr(self, "lambdas_") else self._lambdas()).items()}}


class LambdaModel(Eq11Model):
    """Lambda fitted per gain class (eq 11, 15), predicting with eq 7 or eq 8.

    Parameters
    ----------
    setting : Setting, optional
    n_bootstrap : int
        Bootstrap resamples of each class's fit (its interval).
    random_state : int
        The bootstrap's seed.

    Attributes
    ----------
    lambdas_ : dict of str to ndarray
        Gain class -> fitted diagonal lambda [kg m^2].
    lambda_boot_ : dict of str to ndarray (B, nv)
        The bootstrap estimates (the parameter part of the intervals).
    """

    kind = "lambda"
    _PARAMS = ("setting", "n_bootstrap", "random_state")

    def __init__(self, setting: Setting | None = None, *, n_bootstrap: int = 200, random_state: int = 0):
        super().__init__(setting)
        self.n_bootstrap = n_bootstrap
        self.random_state = random_state

    def fit(self, impacts: Impacts) -> LambdaModel:
        """Fit lambda per gain class on the fixed-base ``impacts``."""
        impacts = self._check_impacts(impacts, fitting=True)
        if impacts.base != FIXED:
            raise InputError("LambdaModel fits on fixed-base impacts (eq 11 with eq 7)")
        setting = self._the_setting()
        classes = np.array([class_of(g) for g in impacts.gain])
        self.lambdas_, self.lambda_boot_ = {}, {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentifiabilityWarning)
            for cls in sorted(set(classes)):
                sel = classes == cls
                est = LambdaFit(setting.robot, direction=impacts.direction[sel][0], n_bootstrap=int(self.n_bootstrap),
                                random_state=int(self.random_state), warn=False)
                est.fit(impacts.q[sel], impacts.m_eff[sel], directions=impacts.direction[sel])
                self.lambdas_[cls] = np.asarray(est.lambda_, float)
                self.lambda_boot_[cls] = np.asarray(est.lambda_boot_, float)
        self._record_fit(impacts, self.predict(impacts), len(self.lambdas_) * setting.robot.nv)
        return self

    def parameter_sd(self, impacts: Impacts) -> np.ndarray:
        """The spread of ``ln m*`` over the bootstrap's lambdas, per impact."""
        self._check_fitted()
        sd = np.zeros(len(impacts))
        classes = np.array([class_of(g) for g in impacts.gain])
        for cls, boot in self.lambda_boot_.items():
            sel = classes == cls
            if not sel.any() or len(boot) < 2:
                continue
            sub = impacts.take(sel)
            logs = np.array([np.log(_eq11(self._the_setting(), sub, lambda _g, b=b: b)) for b in boot])
            sd[sel] = np.std(logs, axis=0, ddof=1)
        return sd

    def parameters(self) -> dict:
        return {"lambda": {k: json_numbers(v) for k, v in self.lambdas_.items()},
                "lambda_bootstrap": {k: json_numbers(v) for k, v in self.lambda_boot_.items()}}


class CoulombModel(ResponseModel):
    """Lambda plus a Coulomb impulse per joint, fitted per gain class (fixed base only).

    Attributes
    ----------
    fits_ : dict of str to CoulombLambdaFit
        Per gain class: ``lambda_``, ``kappa_`` and their intervals.
    """

    kind = "lambda_coulomb"
    supported_bases = (FIXED,)

    def fit(self, impacts: Impacts) -> CoulombModel:
        impacts = self._check_impacts(impacts, fitting=True)
        robot = self._the_setting().robot
        classes = np.array([class_of(g) for g in impacts.gain])
        self.fits_ = {}
        e_paper = float(load_paper()["restitution_mean"])   # where the impacts carry no e
        for cls in sorted(set(classes)):
            sel = classes == cls
            e = impacts.restitution[sel] if impacts.restitution is not None else np.full(sel.sum(), e_paper)
            self.fits_[cls] = CoulombLambdaFit(robot).fit(impacts.q[sel], impacts.direction[sel], impacts.m_eff[sel],
                                                          speed=impacts.speed[sel], e=e, m_b=self._masses(impacts)[sel])
        self._record_fit(impacts, self.predict(impacts), 2 * len(self.fits_) * robot.nv)
        return self

    def predict(self, impacts: Impacts) -> np.ndarray:
        impacts = self._check_impacts(impacts)
        if not hasattr(self, "fits_"):
            raise InputError("this CoulombModel is not fitted yet; call fit(impacts) first")
        out = np.empty(len(impacts))
        classes = np.array([class_of(g) for g in impacts.gain])
        mb = self._masses(impacts)
        for cls in set(classes):
            if cls not in self.fits_:
                raise InputError(f"no fit for gain class {cls!r}; the model has {sorted(self.fits_)}")
            sel = classes == cls
            out[sel] = self.fits_[cls].predict(impacts.q[sel], impacts.direction[sel], speed=impacts.speed[sel],
                                               m_b=mb[sel])
        return out

    def parameters(self) -> dict:
        return {cls: f.summary() for cls, f in self.fits_.items()}
