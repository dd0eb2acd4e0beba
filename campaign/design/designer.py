"""Experiment design for the Virtual Rotor Inertia: which poses and impact directions to strike.

The fit (:mod:`campaign.joints.lambda_fit`) estimates ``theta = ln lambda`` (diagonal, eq 15) from
``y_i = ln m*_i`` (eq 11 with eq 7). Linearised at a prior ``lambda_0``, trial ``i``
contributes the row ``s_i = d ln m*_i / d ln lambda`` (:func:`campaign.joints.lambda_fit.sensitivity_matrix`)
and the Fisher information is

    F = sum_i s_i s_i^T / var_i,      cov(ln lambda) ~ F^-1,

so the predicted 95 % interval of ``lambda_j`` is ``lambda_j exp(+-1.96 sqrt((F^-1)_jj))``.
:class:`ExperimentDesign` picks ``K`` poses (each with its horizontal impact direction)
from a candidate set to maximise ``ln det F`` (D-optimal), ``-trace F^-1`` (A) or the
smallest eigenvalue of ``F`` (E): a greedy start, then exchange passes (Fedorov) until no
swap of a chosen candidate for another improves the criterion.

Measurement error model (:class:`ErrorModel`): ``var(ln m*) = a^2 + b^2 x^2`` with
``x = (1 + m*/m_b) / v``. The arm's velocity change along n is
``(1 + e) m_b v / (m* + m_b)`` (eq 13), measured through 20 ms joint-encoder samples to a
roughly constant velocity error; its relative error, hence that of m* (eq 10), grows as
``(1 + m*/m_b) / v``: a heavy effective mass or a slow hammer leaves the arm almost still.
``a`` is the floor (pendulum encoder, contact edges). ``a^2, b^2 >= 0`` are fitted by
non-negative, iteratively reweighted least squares to the squared errors ``(ln m*_identified - ln m*_truth)^2`` of
a campaign's own fixed-base trials, where ``m*_truth`` is eq 10 on the simulator's true
contact-edge velocities (the trial file's ``truth`` group): identification's error alone,
not the model's (:func:`calibrate_error_model`; by default on the committed reference
archive).

Candidates (:func:`grid_candidates`, :func:`random_candidates`, :func:`read_candidates`)
are paper-degree poses with directions; :func:`feasible` keeps those the rig can strike
(joint limits, the pendulum's placement, :mod:`campaign.rig.placement`, and a hammer
lighter than the arm's free effective mass) and the chosen ones are checked again by
assembling their rig (:func:`campaign.rig.simulate.build`) for every gain and speed, which
also refuses a pose whose servo would be unstable.

The method, the designed campaign and its measured results: user guide, *Experiment design
for lambda* (``docs/design.rst``).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..archive import open_trial_arrays
from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.vocabulary import direction_azimuth
from ..core.yamlfile import PROJECT_DIR
from ..identify.table import read_identification
from ..joints.lambda_fit import design_arrays
from ..model.exiit import effective_mass
from ..model.paper import impact_direction, load_paper, paper_q
from ..model.robot import load_robot
from ..rig.pendulum import Pendulum
from ..rig.placement import place_pendulum, placement_params
from ..rig.simulate import build
from ..scene.description import (
    check_direction,
    direction_from_azimuth,
    load_rig,
    make_scene,
)

__all__ = ["ErrorModel", "calibrate_error_model", "grid_candidates", "random_candidates", "read_candidates", "run_design", "write_design",
           "feasible", "ExperimentDesign", "paper_design", "design_markdown", "CRITERIA", "Z95"]

#: optimality criteria
CRITERIA = ("D", "A", "E")
#: two-sided 95 % normal quantile
Z95 = 1.959963984540054


# ----------------------------------------------------------------------------------------
# measurement error model
# ----------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ErrorModel:
    """``var(ln m*) = a^2 + b^2 ((1 + m*/m_b) / v)^2`` (see the module docstring).

    Attributes
    ----------
    a : float
        Error floor of ln m* (relative error of m*).
    b : float
        Coefficient of ``(1 + m*/m_b) / v`` [m/s].
    n_trials : int
        Trials it was calibrated on.
    source : str
        Where those trials came from.
    rms : float
        Root mean square of the calibration errors ``ln m*_identified - ln m*_truth``.
    """

    a: float
    b: float
    n_trials: int = 0
    source: str = ""
    rms: float = float("nan")

    def variance(self, m_ratio, speed) -> np.ndarray:
        """``var(ln m*)`` at ``m*/m_b`` and hammer speed [m/s] (broadcast)."""
        x = (1.0 + np.asarray(m_ratio, float)) / np.asarray(speed, float)
        return self.a**2 + (self.b * x) ** 2

    @classmethod
    def fit(cls, m_identified, m_truth, m_b, speed, *, source: str = "") -> "ErrorModel":
        """Fit ``a^2, b^2 >= 0`` to ``(ln m*_identified - ln m*_truth)^2`` by non-negative
        least squares (one row per trial)."""
        from scipy.optimize import nnls

        mi, mt, mb, v = (np.asarray(x, float) for x in (m_identified, m_truth, m_b, speed))
        ok = np.isfinite(mi) & np.isfinite(mt) & (mi > 0) & (mt > 0) & np.isfinite(mb) & (v > 0)
        if ok.sum() < 2:
            raise InputError(f"the error model needs at least 2 trials with identified and true m*, got {int(ok.sum())}")
        r = np.log(mi[ok] / mt[ok])
        x = (1.0 + mt[ok] / mb[ok]) / v[ok]
        A = np.column_stack([np.ones_like(x), x**2])
        coef, _ = nnls(A, r**2)
        # r^2 has variance 2 var^2: reweight by the fitted variance (iteratively reweighted
        # least squares), so the many small errors pin the floor down as well as the large ones
        for _ in range(5):
            var = np.maximum(A @ coef, 1e-30)
            coef, _ = nnls(A / var[:, None], r**2 / var)
        return cls(a=float(math.sqrt(coef[0])), b=float(math.sqrt(coef[1])), n_trials=int(ok.sum()), source=source,
                   rms=float(np.sqrt(np.mean(r**2))))

    def to_dict(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "n_trials": self.n_trials, "source": self.source, "rms": self.rms,
                "formula": "var(ln m*) = a^2 + b^2 ((1 + m*/m_b) / v)^2"}


def _truth_m_eff(path: Path, m_b: float) -> float:
    """Eq 10 on the simulator's true contact-edge velocities of one trial."""

    t = open_trial_arrays(path, group="truth")
    g = lambda k: float(t[k].values)  # noqa: E731
    dv_a = g("v_a_post") - g("v_a_pre")
    return m_b * (g("v_b_pre") - g("v_b_post")) / dv_a if dv_a > 0 else float("nan")


def calibrate_error_model(ident_tables: Sequence[str | Path] | None = None, *,
                          archive_dir: str | Path | None = None) -> ErrorModel:
    """Calibrate :class:`ErrorModel` on a campaign's identified fixed-base trials vs their truth.

    Parameters
    ----------
    ident_tables : sequence of path-like, optional
        Identification CSVs (:func:`campaign.identify.table.identify_trials`); their rows name the
        trial files, whose ``truth`` groups give ``m*_truth``. Default: the committed
        reference archive's (``archive/reference.identification.csv``).
    archive_dir : path-like, optional
        Where the trial files are when the CSV's paths are not there (the last five parts of
        each path are taken relative to it). Default: ``archive/reference`` with the default
        table.
    """
    root = PROJECT_DIR / "archive"
    if ident_tables is None:
        ident_tables = [root / "reference.identification.csv"]
        archive_dir = root / "reference" if archive_dir is None else archive_dir
    for t in ident_tables:
        if not Path(t).is_file():
            raise InputError(f"identification table {t} does not exist (the error model is calibrated from it)")
    rows = [r for r in read_identification(ident_tables) if r["base"] == "fixed" and not r["excluded"]]
    mi, mt, mb, v = [], [], [], []
    for r in rows:
        path = Path(r["path"])
        if not path.is_file() and archive_dir is not None:
            path = Path(archive_dir).joinpath(*Path(r["path"]).parts[-5:])
        if not path.is_file():
            raise InputError(f"trial file {r['path']} of the identification table is missing")
        mi.append(r["m_eff"])
        mt.append(_truth_m_eff(path, r["hammer_mass"]))
        mb.append(r["hammer_mass"])
        v.append(r["speed"])
    names = ", ".join(str(t) for t in ident_tables)
    return ErrorModel.fit(mi, mt, mb, v, source=names)


# ----------------------------------------------------------------------------------------
# candidates
# ----------------------------------------------------------------------------------------
def _directions_from(azimuths) -> np.ndarray:

    return np.array([direction_from_azimuth(a) for a in azimuths], float)


def grid_candidates(*, q1=(-45.0, 0.0, 45.0), q2=tuple(range(90, 226, 15)), q3=tuple(range(-30, 136, 15)),
                    azimuths=tuple(range(-150, 181, 30))) -> tuple[np.ndarray, np.ndarray]:
    """Every combination of paper-degree joint angles and direction azimuths (from -x about +z).

    Returns
    -------
    Q : ndarray, shape (N, 3)
        Poses, paper degrees.
    D : ndarray, shape (N, 3)
        Horizontal unit directions.
    """
    grid = np.array(np.meshgrid(q1, q2, q3, azimuths, indexing="ij"), float).reshape(4, -1).T
    return grid[:, :3].copy(), _directions_from(grid[:, 3])


def random_candidates(n: int, *, robot, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` poses uniform within the joint limits (paper degrees) with uniform azimuths, seeded."""

    if not (isinstance(n, (int, np.integer)) and n > 0):
        raise InputError(f"number of random candidates must be an integer > 0, got {n!r}")
    rng = np.random.default_rng(seed)
    off = np.asarray(load_paper()["offset_deg"], float)
    lo, hi = np.degrees(robot.q_lower) - off, np.degrees(robot.q_upper) - off
    Q = rng.uniform(lo, hi, size=(n, robot.nv))
    return Q, _directions_from(rng.uniform(-180.0, 180.0, size=n))


def read_candidates(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Candidates from a CSV with columns ``q1,q2,q3`` (paper degrees) and either ``azimuth``
    (deg from -x about +z) or ``nx,ny,nz``; each direction is checked (horizontal, unit)."""


    path = Path(path)
    if not path.is_file():
        raise InputError(f"candidate file {path} does not exist")
    Q, D = [], []
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        cols = set(reader.fieldnames or ())
        if not {"q1", "q2", "q3"} <= cols or not ({"azimuth"} <= cols or {"nx", "ny", "nz"} <= cols):
            raise InputError(f"{path}: needs columns q1,q2,q3 and azimuth or nx,ny,nz; has {sorted(cols)}")
        for line, row in enumerate(reader, 2):
            try:
                Q.append([float(row[k]) for k in ("q1", "q2", "q3")])
                if "azimuth" in cols and row.get("azimuth", "") != "":
                    D.append(_directions_from([float(row["azimuth"])])[0])
                else:
                    D.append(check_direction([float(row[k]) for k in ("nx", "ny", "nz")]))
            except (ValueError, InputError) as exc:
                raise InputError(f"{path}, line {line}: {exc}") from None
    if not Q:
        raise InputError(f"{path} lists no candidate")
    return np.array(Q, float), np.array(D, float)


def _rig_values(rig=None) -> dict[str, Any]:

    values, _ = load_rig(rig)
    return values


def feasible(robot, Q_paper, D, *, speed: float, rig=None) -> tuple[np.ndarray, list[str]]:
    """Which candidates the rig can strike at ``speed`` (the largest of the campaign).

    Returns
    -------
    ok : ndarray of bool, shape (N,)
    reasons : list of str
        Why each refused candidate is refused ("" where ok).
    """

    p = _rig_values(rig)
    pend = Pendulum(float(p["pendulum.head_mass"]), float(p["pendulum.rod_mass"]), float(p["pendulum.radius"]),
                    float(p["gravity"]), float(p["pendulum.max_release_deg"]))
    theta0 = pend.release_angle(speed)
    place = placement_params(p)
    data = robot.model.createData()
    ok = np.zeros(len(Q_paper), bool)
    reasons = []
    for i, (qp, n) in enumerate(zip(Q_paper, D)):
        try:
            q = paper_q(qp)
            if place is not None:
                place_pendulum(robot, q, n, radius=pend.radius, release_angle=theta0, data=data, **place)
            else:
                robot.check_q(q)
            if pend.m_b >= effective_mass(robot, q, n, data=data):
                raise InputError("hammer not lighter than the arm's free effective mass")
        except (InputError, ValueError) as exc:
            reasons.append(str(exc))
            continue
        ok[i] = True
        reasons.append("")
    return ok, reasons


# ----------------------------------------------------------------------------------------
# the design
# ----------------------------------------------------------------------------------------
def _arrays(robot, Q_paper, D):

    Q = np.array([paper_q(q) for q in Q_paper]) if len(Q_paper) else np.empty((0, robot.nv))
    return design_arrays(robot, Q, D)


def _rows(H, Jn, lam):
    """(sensitivity rows d ln m*/d ln lambda, m* at lambda) per candidate."""
    lam = np.asarray(lam, float)
    x = np.linalg.solve(H + np.diag(lam), Jn[:, :, None])[:, :, 0]
    s = np.einsum("ij,ij->i", Jn, x)
    return lam[None, :] * x**2 / s[:, None], 1.0 / s


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

    Attributes
    ----------
    chosen_ : ndarray of int
        Indices of the chosen candidates.
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
                 trials_per_speed: int = 1, error_model: ErrorModel, m_b: float, robot):
        self.n_poses = n_poses
        self.criterion = criterion
        self.lambda_prior = lambda_prior
        self.speeds = speeds
        self.trials_per_speed = trials_per_speed
        self.error_model = error_model
        self.m_b = m_b
        self.robot = robot

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

    def fit(self, Q_paper, D) -> "ExperimentDesign":
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
        Fi = self._information(S, m)
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
        idx = np.array(chosen, int)
        F = Fi[idx].sum(axis=0)
        summ = self._summary(Q_paper[idx], D[idx], S[idx], m[idx], F, lam)
        self.chosen_ = idx
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


def paper_design() -> tuple[np.ndarray, np.ndarray]:
    """The paper's three configurations (paper degrees) and its impact direction."""

    table = load_paper()["configurations"]
    Q = np.array([table[k] for k in sorted(table)], float)
    return Q, np.repeat(impact_direction()[None, :], len(Q), axis=0)


def design_markdown(result: Mapping[str, Any]) -> str:
    """Markdown tables of a :func:`campaign.cli.design` result (both gain classes)."""
    lines = ["# Experiment design for lambda", ""]
    em = result["error_model"]
    lines += [f"Criterion {result['criterion']}-optimal, K = {result['n_poses']} poses from "
              f"{result['n_candidates']} candidates ({result['n_feasible']} the rig can strike), speeds "
              f"{', '.join(f'{v:g}' for v in result['speeds'])} m/s. Error model {em['formula']}: a = {em['a']:.4g}, "
              f"b = {em['b']:.4g} m/s from {em['n_trials']} trials (identified vs true m*, rms {em['rms']:.3g}).", ""]
    for name, cls in result["classes"].items():
        lam = cls["lambda_prior"]
        lines += [f"## {name} (gains {', '.join(cls['gains'])}; prior lambda = "
                  f"[{', '.join(f'{x:g}' for x in lam)}] kg m^2, {cls['trials_per_speed']} trial(s) per pose and speed)",
                  "", "| pose | q paper [deg] | azimuth of n [deg] | m* [kg] | m*/m_b | "
                  "d ln m*/d ln lambda_1 | _2 | _3 |", "|---|---|---|---|---|---|---|---|"]
        d = cls["designed"]
        for i, (q, az, m, r, s) in enumerate(zip(d["q_paper_deg"], d["azimuth_deg"], d["m_eff"], d["m_ratio"],
                                                 d["sensitivity"]), 1):
            lines.append(f"| {i} | {', '.join(f'{x:g}' for x in q)} | {az:.1f} | {m:.3f} | {r:.2f} | "
                         + " | ".join(f"{x:.3f}" for x in s) + " |")
        lines += ["", "| design | poses | condition number | " + " | ".join(
            f"95 % CI lambda_{j + 1} [kg m^2] (+-%)" for j in range(len(lam))) + " |",
            "|---|---|---|" + "---|" * len(lam)]
        for label, key in (("paper (configurations 1-3, n = -x)", "paper"), ("designed", "designed")):
            e = cls[key]
            cells = [f"[{lo:.4g}, {hi:.4g}] (+-{100 * rel:.3g} %)" if math.isfinite(rel) else "unbounded"
                     for lo, hi, rel in zip(e["lambda_ci"][0], e["lambda_ci"][1], e["relative_ci"])]
            lines.append(f"| {label} | {len(e['m_eff'])} | {e['condition_number']:.3g} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------------------
# the command's work
# ----------------------------------------------------------------------------------------
def _rig_refusal(q_paper, n, *, gains: Sequence[str], speeds: Sequence[float], rig=None) -> str:
    """Why the rig refuses to assemble a pose for some gain set and speed ("" if it never does)."""

    for gain in gains:
        for v in speeds:
            try:
                build(make_scene(base="fixed", config=0, q_paper_deg=[float(x) for x in q_paper],
                                 direction=[float(x) for x in n], gain=gain, speed=float(v), rig=rig))
            except (InputError, ValueError) as exc:
                return f"{gain} gains, {v:g} m/s: {exc}"
    return ""


def run_design(*, n_poses: int = 6, criterion: str = "D", candidates: str = "grid", n_random: int = 2000,
               seed: int = 0, speeds: Sequence[float] = (1.5, 2.5), repeats: int = 1,
               calibration: Sequence[str] | None = None, rig=None,
               lambda_prior: Mapping[str, Sequence[float]] | None = None,
               gain_classes: Mapping[str, Sequence[str]] | None = None) -> dict[str, Any]:
    """Design poses and directions for every gain class; the paper's design evaluated beside.

    Parameters
    ----------
    n_poses, criterion
        :class:`ExperimentDesign` settings.
    candidates : str
        ``"grid"``, ``"random"`` (``n_random`` poses, ``seed``) or a CSV path
        (:func:`read_candidates`).
    speeds, repeats
        Every pose is struck at each speed ``repeats`` times per gain set of its class.
    calibration : sequence of path-like, optional
        Identification tables for :func:`calibrate_error_model`.
    rig : path-like, optional
        Rig parameter file.
    lambda_prior : mapping, optional
        Class -> lambda the design is optimal at; a class not given takes the paper's Table 3.
    gain_classes : mapping, optional
        Class -> gain sets; default the paper's.

    Returns
    -------
    dict
        JSON-safe: the settings, the error model, and per class the designed and the
        paper's numbers (:meth:`ExperimentDesign.evaluate`) and the chosen poses.
    """

    paper = load_paper()
    robot = load_robot(paper["robot"])
    p = _rig_values(rig)
    pend = Pendulum(float(p["pendulum.head_mass"]), float(p["pendulum.rod_mass"]), float(p["pendulum.radius"]),
                    float(p["gravity"]), float(p["pendulum.max_release_deg"]))
    errors = calibrate_error_model(calibration)
    if candidates == "grid":
        Q, D = grid_candidates()
    elif candidates == "random":
        Q, D = random_candidates(n_random, robot=robot, seed=seed)
    else:
        Q, D = read_candidates(candidates)
    ok, _ = feasible(robot, Q, D, speed=max(speeds), rig=rig)
    classes = dict(gain_classes or paper["gain_classes"])
    priors = {**paper["table3"], **dict(lambda_prior or {})}
    out: dict[str, Any] = {
        "criterion": criterion, "n_poses": int(n_poses), "candidates": str(candidates), "n_candidates": int(len(Q)),
        "n_feasible": int(ok.sum()), "speeds": [float(v) for v in speeds], "repeats": int(repeats),
        "hammer_mass": pend.m_b, "error_model": errors.to_dict(), "classes": {},
        "units": {"lambda": "kg m^2", "m_eff": "kg", "q_paper_deg": "deg", "azimuth_deg": "deg from -x about +z"},
    }
    Qp, Dp = paper_design()
    for name, gains in classes.items():
        est = ExperimentDesign(n_poses=n_poses, criterion=criterion, lambda_prior=priors[name], speeds=speeds,
                               trials_per_speed=int(repeats) * len(gains), error_model=errors, m_b=pend.m_b,
                               robot=robot)
        usable = ok.copy()
        refused = []
        for _ in range(4 * int(n_poses) + 1):
            idx = np.flatnonzero(usable)
            est.fit(Q[idx], D[idx])
            bad = [int(idx[i]) for i in est.chosen_
                   if _rig_refusal(Q[idx[i]], D[idx[i]], gains=gains, speeds=speeds, rig=rig)]
            if not bad:
                break
            for b in bad:
                usable[b] = False
                refused.append({"q_paper_deg": Q[b].tolist(), "direction": D[b].tolist(),
                                "reason": _rig_refusal(Q[b], D[b], gains=gains, speeds=speeds, rig=rig)})
        else:
            raise InputError(f"{name}: the rig refused every design tried ({len(refused)} poses refused)")
        out["classes"][name] = {
            "gains": list(gains), "lambda_prior": [float(x) for x in priors[name]],
            "trials_per_speed": int(repeats) * len(gains), "designed": est.summary_,
            "paper": est.evaluate(Qp, Dp), "refused_by_rig": refused,
        }
    return out


def write_design(result: Mapping[str, Any], *, out_json=None, out_md=None) -> str:
    """Write a :func:`run_design` result as JSON and/or Markdown (atomically); returns the Markdown."""


    md = design_markdown(result)

    def clean(x):
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    if out_json is not None:
        write_atomic(out_json, json.dumps(clean(result), indent=2, sort_keys=True) + "\n")
    if out_md is not None:
        write_atomic(out_md, md)
    return md
