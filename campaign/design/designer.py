"""Experiment design for the Virtual Rotor Inertia: which poses and impact directions to strike.

The fit (:mod:`campaign.joints.lambda_fit`) estimates ``theta = ln lambda`` (diagonal, eq 15) from
``y_i = ln m*_i`` (eq 11 with eq 7). Linearised at a prior ``lambda_0``, trial ``i``
contributes the row ``s_i = d ln m*_i / d ln lambda`` (:func:`campaign.joints.lambda_fit.sensitivity_matrix`)
and the Fisher information is

    F = sum_i s_i s_i^T / var_i,      cov(ln lambda) ~ F^-1,

so the predicted 95 % interval of ``lambda_j`` is ``lambda_j exp(+-1.96 sqrt((F^-1)_jj))``.
:class:`ExperimentDesign` picks ``K`` poses (each with its horizontal impact direction)
from a candidate set (:mod:`campaign.design.candidates`) to maximise ``ln det F``
(D-optimal), ``-trace F^-1`` (A) or the smallest eigenvalue of ``F`` (E): a greedy start,
then exchange passes (Fedorov) until no swap of a chosen candidate for another improves the
criterion. ``var_i`` is the measurement error model's (:mod:`campaign.design.error_model`).

Candidates that carry the same information are offered once: m* (eq 7) depends on n only
through ``n^T J (H + lambda)^-1 J^T n``, so it is even in n (the model gives a pose struck
along -n the m* and sensitivities it gives along n), and it is unchanged when the arm and n turn
together about a vertical joint 1 (``H`` does not depend on that joint's angle). A design
offered both would spend a second pose on the same measurement.

The method, the designed campaign and its measured results: user guide, *Experiment design
for lambda* (``docs/design.rst``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.stats import Z95
from ..core.vocabulary import direction_azimuth
from ..joints.lambda_fit import design_arrays
from ..model.paper import paper_q
from .error_model import ErrorModel

__all__ = ["ExperimentDesign", "CRITERIA"]

#: optimality criteria
CRITERIA = ("D", "A", "E")


def _arrays(robot, Q_paper, D):
    Q = paper_q(Q_paper) if len(Q_paper) else np.empty((0, robot.nv))
    return design_arrays(robot, Q, D)


def _rows(H, Jn, lam):
    """(sensitivity rows d ln m*/d ln lambda, m* at lambda) per candidate."""
    lam = np.asarray(lam, float)
    x = np.linalg.solve(H + np.diag(lam), Jn[:, :, None])[:, :, 0]
    s = np.einsum("ij,ij->i", Jn, x)
    return lam[None, :] * x**2 / s[:, None], 1.0 / s


def _distinct(S, m) -> np.ndarray:
    """The first candidate of each group with the same m* and sensitivities (to 1e-9), as a mask."""
    keys = np.round(np.column_stack([np.log(m), S]), 9) + 0.0   # + 0.0: -0.0 and 0.0 are one value
    _, first = np.unique(keys, axis=0, return_index=True)
    mask = np.zeros(len(m), bool)
    mask[first] = True
    return mask


def _criterion(F: np.ndarray, kind: str) -> float:
    if kind == "D":
        sign, logdet = np.linalg.slogdet(F)
        return float(logdet) if sign > 0 else -math.inf
    ev = np.linalg.eigvalsh(F)
    if ev[0] <= 0:
        return -math.inf
    return float(-np.sum(1.0 / ev)) if kind == "A" else float(ev[0])


class ExperimentDesign:
    """Choose poses and directions that identify ln lambda best (scikit-learn shape).

    Parameters
    ----------
    n_poses : int
        K, the number of poses (each with its direction) to choose.
    criterion : {"D", "A", "E"}
        D-optimal (``ln det F``), A-optimal (``trace F^-1``) or E-optimal (smallest
        eigenvalue of ``F``).
    lambda_prior : array_like, shape (nv,)
        The lambda the design is optimal at [kg m^2] (> 0).
    speeds : sequence of float
        Hammer speeds every pose is struck at [m/s].
    trials_per_speed : int
        Trials per pose and speed (repeats x gain sets pooled in the class).
    error_model : ErrorModel
    m_b : float
        Hammer effective mass [kg] (eq 10).
    robot : campaign.model.robot.Robot
    repeat_information : bool
        Offer every candidate, also one whose m* and sensitivities equal an earlier one's (the
        same pose along -n, or the arm and n turned together about joint 1): the design may
        then choose the same measurement twice. Default: only the first of each such group.

    Attributes
    ----------
    chosen_ : ndarray of int
        Indices of the chosen candidates.
    n_offered_ : int
        Candidates offered to the search (all, or the first of each group with the same
        information).
    q_paper_deg_, directions_ : ndarray
        Their poses [deg] and directions.
    sensitivity_ : ndarray, shape (K, nv)
        ``d ln m*/d ln lambda`` at the prior, per chosen pose.
    m_eff_ : ndarray, shape (K,)
        Predicted m* at the prior [kg].
    information_ : ndarray, shape (nv, nv)
        Fisher information of ln lambda.
    relative_ci_ : ndarray, shape (nv,)
        Predicted 95 % half-width of each component, relative (``exp(1.96 sd) - 1``).
    lambda_ci_ : ndarray, shape (2, nv)
        Predicted 95 % interval around the prior [kg m^2].
    condition_number_ : float
        2-norm condition number of ``sensitivity_``.
    criterion_value_ : float
    """

    def __init__(self, *, n_poses: int = 6, criterion: str = "D", lambda_prior, speeds: Sequence[float] = (1.5, 2.5),
                 trials_per_speed: int = 1, error_model: ErrorModel, m_b: float, robot,
                 repeat_information: bool = False):
        self.n_poses = n_poses
        self.criterion = criterion
        self.lambda_prior = lambda_prior
        self.speeds = speeds
        self.trials_per_speed = trials_per_speed
        self.error_model = error_model
        self.m_b = m_b
        self.robot = robot
        self.repeat_information = repeat_information

    def _check(self):
        if self.criterion not in CRITERIA:
            raise InputError(f"criterion must be one of {CRITERIA}, got {self.criterion!r}")
        if not (isinstance(self.n_poses, (int, np.integer)) and self.n_poses >= 1):
            raise InputError(f"n_poses must be an integer >= 1, got {self.n_poses!r}")
        lam = np.asarray(self.lambda_prior, float)
        if lam.shape != (self.robot.nv,) or not np.all(np.isfinite(lam) & (lam > 0)):
            raise InputError(f"lambda_prior must be {self.robot.nv} values > 0 kg m^2, got {lam.tolist()}")
        v = np.asarray(self.speeds, float)
        if v.ndim != 1 or not v.size or not np.all(np.isfinite(v) & (v > 0)):
            raise InputError(f"speeds must be values > 0 m/s, got {list(self.speeds)}")
        if not (isinstance(self.trials_per_speed, (int, np.integer)) and self.trials_per_speed >= 1):
            raise InputError(f"trials_per_speed must be an integer >= 1, got {self.trials_per_speed!r}")
        return lam, v

    def _information(self, S, m):
        """Per-candidate information matrices ``sum_v w s s^T / var``, shape (N, nv, nv)."""
        _, v = self._check()
        ratio = m / float(self.m_b)
        w = sum(self.trials_per_speed / self.error_model.variance(ratio, vi) for vi in v)
        return w[:, None, None] * S[:, :, None] * S[:, None, :]

    def evaluate(self, Q_paper, D) -> dict[str, Any]:
        """The predicted numbers of a given design (e.g. the paper's three configurations)."""
        lam, _ = self._check()
        H, Jn = _arrays(self.robot, np.asarray(Q_paper, float), np.asarray(D, float))
        S, m = _rows(H, Jn, lam)
        F = self._information(S, m).sum(axis=0)
        return self._summary(np.asarray(Q_paper, float), np.asarray(D, float), S, m, F, lam)

    def _summary(self, Q, D, S, m, F, lam) -> dict[str, Any]:
        try:
            C = np.linalg.inv(F)
            sd = np.sqrt(np.clip(np.diag(C), 0.0, None))
            if not np.all(np.isfinite(sd)) or np.linalg.cond(F) > 1e14:
                raise np.linalg.LinAlgError
        except np.linalg.LinAlgError:
            sd = np.full(lam.size, np.inf)
        sv = np.linalg.svd(S, compute_uv=False)
        cond = float(sv[0] / sv[-1]) if S.shape[0] >= S.shape[1] and sv[-1] > 1e-12 * sv[0] else math.inf
        with np.errstate(over="ignore"):
            rel = np.expm1(Z95 * sd)
            ci = np.array([lam * np.exp(-Z95 * sd), lam * np.exp(Z95 * sd)])
        return {
            "q_paper_deg": Q.tolist(), "directions": D.tolist(),
            "azimuth_deg": [direction_azimuth(n) for n in D],
            "sensitivity": S.tolist(), "m_eff": m.tolist(), "m_ratio": (m / float(self.m_b)).tolist(),
            "information": F.tolist(), "relative_ci": rel.tolist(), "lambda_ci": ci.tolist(),
            "condition_number": cond, "criterion_value": _criterion(F, self.criterion),
        }

    def fit(self, Q_paper, D) -> ExperimentDesign:
        """Choose ``n_poses`` of the candidates (rows of ``Q_paper`` [deg] and ``D``)."""
        lam, _ = self._check()
        Q_paper = np.asarray(Q_paper, float)
        D = np.asarray(D, float)
        if Q_paper.ndim != 2 or Q_paper.shape[1] != self.robot.nv or D.shape != (Q_paper.shape[0], 3):
            raise InputError(f"candidates must be (N, {self.robot.nv}) poses and (N, 3) directions, got "
                             f"{Q_paper.shape} and {D.shape}")
        K = int(self.n_poses)
        if Q_paper.shape[0] < K:
            raise InputError(f"{Q_paper.shape[0]} feasible candidates cannot give a design of {K} poses")
        H, Jn = _arrays(self.robot, Q_paper, D)
        S, m = _rows(H, Jn, lam)
        offered = np.arange(len(m)) if self.repeat_information else np.flatnonzero(_distinct(S, m))
        if offered.size < K:
            raise InputError(f"{Q_paper.shape[0]} feasible candidates hold {offered.size} different measurements "
                             f"(n and -n of a pose give the same), too few for a design of {K} poses")
        Fi = self._information(S[offered], m[offered])
        kind = self.criterion
        nv = lam.size
        # a small ridge lets the greedy start rank candidates before F has full rank
        ridge = 1e-9 * np.eye(nv) * float(np.max(np.trace(Fi, axis1=1, axis2=2)))
        chosen: list[int] = []
        F = ridge.copy()
        for _ in range(K):
            scores = np.array([_criterion(F + Fi[i], kind) if i not in chosen else -math.inf
                               for i in range(len(Fi))])
            best = int(np.argmax(scores))
            chosen.append(best)
            F = F + Fi[best]
        # exchange passes: swap a chosen candidate for any other while the criterion improves
        current = _criterion(F - ridge, kind)
        for _ in range(20):
            improved = False
            for k in range(K):
                base = F - Fi[chosen[k]]
                scores = np.array([_criterion(base + Fi[i] - ridge, kind) if i not in chosen else -math.inf
                                   for i in range(len(Fi))])
                best = int(np.argmax(scores))
                if scores[best] > current * (1 + 1e-12) + 1e-12:
                    chosen[k] = best
                    F = base + Fi[best]
                    current = float(scores[best])
                    improved = True
            if not improved:
                break
        F = Fi[np.array(chosen, int)].sum(axis=0)
        idx = offered[np.array(chosen, int)]
        summ = self._summary(Q_paper[idx], D[idx], S[idx], m[idx], F, lam)
        self.chosen_ = idx
        self.n_offered_ = int(offered.size)
        self.q_paper_deg_ = Q_paper[idx]
        self.directions_ = D[idx]
        self.sensitivity_ = S[idx]
        self.m_eff_ = m[idx]
        self.information_ = F
        self.relative_ci_ = np.array(summ["relative_ci"])
        self.lambda_ci_ = np.array(summ["lambda_ci"])
        self.condition_number_ = summ["condition_number"]
        self.criterion_value_ = summ["criterion_value"]
        self.summary_ = summ
        return self
