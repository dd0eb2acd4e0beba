"""Lambda from recorded hits: what the recorded poses can determine, and one session's fit
used to predict another.

Input: per-hit rows (:data:`HIT_COLUMNS`, one CSV row per hit: the session it belongs to,
the unit direction ``n`` the object was struck along in the arm's base frame, the joint
angles ``q_1..q_nv`` [rad] at the hit, the identified ``m_eff`` with its interval, and a
``flag`` that is empty or ``ok`` for a hit to use). Linearised at a lambda (zero by
default, the rigid-body model of eq 7), hit ``i`` gives the row

    S_ij = d ln m*_i / d lambda_j = m*_i x_ij^2,     x_i = (H_i + lambda)^-1 J_i^T n_i

[1/(kg m^2)], so the recorded poses determine the combinations of lambda in the row space
of ``S``: its right singular vectors whose singular values exceed ``rtol`` times the
largest (:func:`identifiability`). One pose, struck along one direction, determines one
combination; the hits of one session, at nearly one pose, barely more.

:func:`transfer` fits on one session and predicts another. The fit session's m* determines
only some combinations of lambda; :func:`prediction_range` searches every diagonal lambda in
``[0, lambda_max]`` that reproduces the fit session's mean ``ln m*`` (within 1.96 standard
errors of the hits' scatter) for the least and the greatest m* it predicts for the other
session. A narrow range means the other session's m* is determined whatever the split of
lambda among the joints; a wide one that these poses cannot determine it. Beside the range,
:func:`subspace_fit` fits the combinations the fit session determines and holds the others
at zero, and its prediction is reported.
"""

from __future__ import annotations

import csv
import dataclasses
import math

import numpy as np

from ..core.errors import InputError
from ..core.files import open_regular
from ..joints.lambda_fit import design_arrays

# scipy.optimize is imported by the searches that use it, not with the module (start-up cost)

__all__ = ["HIT_COLUMNS", "HitRows", "read_hit_rows", "log_sensitivity", "identifiability",
           "prediction_range", "subspace_fit", "transfer", "log_sigma", "USABLE_FLAGS"]

#: the columns of a per-hit row before and after the joint angles q_1..q_nv
HIT_COLUMNS = (("hit", "session", "object_mass", "n_x", "n_y", "n_z"),
               ("speed", "m_eff", "m_eff_lo", "m_eff_hi", "e", "e_lo", "e_hi", "m_eff_logged", "flag"))

#: flag values of a hit that is used (anything else names why it is not)
USABLE_FLAGS = ("", "ok")

#: largest lambda component [kg m^2] a single joint is searched up to
LAMBDA_MAX = 1e4


@dataclasses.dataclass(frozen=True)
class HitRows:
    """Per-hit rows of a recording, the usable ones (flag empty or ``ok``).

    Attributes
    ----------
    hit, session : ndarray of str, shape (N,)
    Q : ndarray, shape (N, nv)
        Joint angles at the hit [rad], the robot model's.
    directions : ndarray, shape (N, 3)
        Unit impact direction, base frame.
    m_eff, m_eff_lo, m_eff_hi : ndarray, shape (N,)
        Identified effective mass and its interval [kg].
    m_eff_logged : ndarray, shape (N,)
        The recording's own model of m* [kg] (nan where the recording has none).
    n_flagged : int
        Rows left out for their flag.
    """

    hit: np.ndarray
    session: np.ndarray
    Q: np.ndarray
    directions: np.ndarray
    m_eff: np.ndarray
    m_eff_lo: np.ndarray
    m_eff_hi: np.ndarray
    m_eff_logged: np.ndarray
    n_flagged: int

    def select(self, session: str) -> HitRows:
        """The rows of one session; raises InputError naming the sessions there are."""
        keep = self.session == session
        if not keep.any():
            raise InputError(f"session {session!r} has no usable hit; sessions: {sorted(str(s) for s in set(self.session))}")
        fields = {f.name: getattr(self, f.name)[keep] for f in dataclasses.fields(self) if f.name != "n_flagged"}
        return HitRows(**fields, n_flagged=0)


def _number(row: dict, column: str, where: str, *, empty_nan: bool = False) -> float:
    text = (row.get(column) or "").strip()
    if not text and empty_nan:
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{where}: column {column} = {text!r} is not a number") from None
    if not math.isfinite(value) and not empty_nan:
        raise InputError(f"{where}: column {column} = {text!r} is not finite")
    return value


def read_hit_rows(path, nv: int) -> HitRows:
    """Read per-hit rows (:data:`HIT_COLUMNS` with ``q_1..q_nv``) from a CSV file.

    Raises InputError naming the file and the missing column, or the row and column of a bad
    value (a direction of zero length, an ``m_eff`` not > 0, an interval not around it).
    """
    first, last = HIT_COLUMNS
    needed = [*first, *(f"q_{j + 1}" for j in range(nv)), *last]
    with open_regular(path, "r", encoding="utf-8", newline="") as fh:
        reader = csv.DictReader(fh)
        have = reader.fieldnames or []
        missing = [c for c in needed if c not in have]
        if missing:
            raise InputError(f"{path}: missing column(s) {', '.join(missing)} (a per-hit file of a robot with "
                             f"{nv} joints has {', '.join(needed)})")
        rows = list(reader)
    out: dict[str, list] = {k: [] for k in ("hit", "session", "Q", "directions", "m_eff", "m_eff_lo", "m_eff_hi",
                                              "m_eff_logged")}
    flagged = 0
    for i, row in enumerate(rows):
        where = f"{path}, row {i + 2} (hit {row.get('hit', '')!r})"
        if (row.get("flag") or "").strip() not in USABLE_FLAGS:
            flagged += 1
            continue
        n = np.array([_number(row, c, where) for c in ("n_x", "n_y", "n_z")])
        if np.linalg.norm(n) == 0:
            raise InputError(f"{where}: the direction (n_x, n_y, n_z) is the zero vector")
        m, lo, hi = (_number(row, c, where) for c in ("m_eff", "m_eff_lo", "m_eff_hi"))
        if not m > 0:
            raise InputError(f"{where}: m_eff = {m:g} kg must be > 0")
        if not lo <= m <= hi:
            raise InputError(f"{where}: the interval [{lo:g}, {hi:g}] kg does not hold m_eff = {m:g} kg")
        out["hit"].append(row["hit"].strip())
        out["session"].append(row["session"].strip())
        out["Q"].append([_number(row, f"q_{j + 1}", where) for j in range(nv)])
        out["directions"].append(n / np.linalg.norm(n))
        out["m_eff"].append(m)
        out["m_eff_lo"].append(lo)
        out["m_eff_hi"].append(hi)
        out["m_eff_logged"].append(_number(row, "m_eff_logged", where, empty_nan=True))
    if not out["hit"]:
        raise InputError(f"{path}: no usable hit ({flagged} flagged, {len(rows)} rows)")
    return HitRows(hit=np.array(out["hit"]), session=np.array(out["session"]),
                   Q=np.array(out["Q"], float).reshape(-1, nv), directions=np.array(out["directions"]),
                   m_eff=np.array(out["m_eff"]), m_eff_lo=np.array(out["m_eff_lo"]),
                   m_eff_hi=np.array(out["m_eff_hi"]), m_eff_logged=np.array(out["m_eff_logged"]),
                   n_flagged=flagged)


def _solve(H, Jn, lam):
    x = np.linalg.solve(H + np.diag(lam), Jn[:, :, None])[:, :, 0]
    return x, np.einsum("ij,ij->i", Jn, x)


def log_sensitivity(robot, Q, directions, lam=None):
    """``(S, m)``: ``S_ij = d ln m*_i / d lambda_j`` [1/(kg m^2)] and eq 11's m* [kg] at ``lam``
    (default zero: the rigid-body model of eq 7), one row per pose and direction."""
    H, Jn = design_arrays(robot, np.asarray(Q, float), np.asarray(directions, float))
    lam = np.zeros(robot.nv) if lam is None else np.asarray(lam, float)
    x, s = _solve(H, Jn, lam)
    return x**2 / s[:, None], 1.0 / s


def identifiability(S, *, rtol: float = 0.1, sigma: float | None = None) -> dict:
    """Which combinations of lambda the rows of ``S`` determine.

    Returns a dict: ``singular_values`` (of ``S`` [1/(kg m^2)]), ``rank`` (those above
    ``rtol`` times the largest), ``combinations`` (the right singular vectors, rows, unit
    length, strongest first; the first ``rank`` are determined, the rest are not),
    ``condition_number`` of the determined part, ``n_rows`` and, given ``sigma`` (the
    standard deviation of one row's ``ln m*``), ``standard_errors``: ``sigma / s_k`` [kg m^2]
    per combination (``null`` for a zero singular value).
    """
    S = np.asarray(S, float)
    _, sv, Vt = np.linalg.svd(S, full_matrices=True)
    smax = float(sv[0]) if sv.size else 0.0
    rank = int(np.sum(sv > rtol * smax)) if smax > 0 else 0
    signs = np.where(Vt[np.arange(Vt.shape[0]), np.argmax(np.abs(Vt), axis=1)] < 0, -1.0, 1.0)
    out = {"singular_values": sv.tolist(), "rank": rank, "rtol": rtol, "n_rows": int(S.shape[0]),
           "combinations": (Vt * signs[:, None]).tolist(),
           "condition_number": float(sv[0] / sv[rank - 1]) if rank else None}
    if sigma is not None:
        full = np.zeros(Vt.shape[0])
        full[:sv.size] = sv
        out["standard_errors"] = [float(sigma / v) if v > 0 else None for v in full]
    return out


def log_sigma(rows: HitRows) -> float:
    """The typical standard deviation of one hit's ``ln m*``: the median of its 95 % interval's
    log width over 2 x 1.96."""
    return float(np.median(np.log(rows.m_eff_hi / rows.m_eff_lo)) / (2 * 1.96))


def _mean_log_m(H, Jn, lam) -> float:
    _, s = _solve(H, Jn, lam)
    return float(np.mean(-np.log(s)))


def _mean_log_grad(H, Jn, lam):
    """Mean ln m* over the rows and its gradient in lambda (``d ln m*/d lambda_j = x_j^2 / s``)."""
    x, s = _solve(H, Jn, lam)
    return float(np.mean(-np.log(s))), np.mean(x**2 / s[:, None], axis=0)


def prediction_range(robot, fit_rows: HitRows, predict_rows: HitRows, *, targets=None, starts=(),
                     lambda_max: float = LAMBDA_MAX) -> dict:
    """The least and the greatest mean ``ln m*`` of ``predict_rows`` over every diagonal
    lambda in ``[0, lambda_max]`` [kg m^2] with which eq 11 reproduces the mean ``ln m_eff`` of
    ``fit_rows`` (each of ``targets``, default that mean alone).

    Returns ``{"least": (m*, lambda), "greatest": (m*, lambda)}`` with m* the geometric mean [kg],
    or ``None`` for both where no lambda reproduces the fit rows (their m* below the
    rigid-body model's, or above the arm with every joint locked).
    """
    from scipy.optimize import brentq, minimize

    nv = robot.nv
    Ha, Ja = design_arrays(robot, fit_rows.Q, fit_rows.directions)
    Hb, Jb = design_arrays(robot, predict_rows.Q, predict_rows.directions)
    if targets is None:
        targets = [float(np.mean(np.log(fit_rows.m_eff)))]
    lo_all = _mean_log_m(Ha, Ja, np.zeros(nv))
    hi_all = _mean_log_m(Ha, Ja, np.full(nv, lambda_max))
    scale = 0.1                                  # kg m^2: the optimiser's unit of lambda
    best = {"least": None, "greatest": None}
    for target in targets:
        if not lo_all <= target <= hi_all:
            continue
        # a uniform lambda that meets the target: every search starts from it and from the given starts
        c = brentq(lambda v, t=target: _mean_log_m(Ha, Ja, np.full(nv, v)) - t, 0.0, lambda_max, xtol=1e-12)
        x0s = [np.full(nv, c)] + [np.clip(np.asarray(s0, float), 0, lambda_max) for s0 in starts]
        cons = {"type": "eq", "fun": lambda u, t=target: _mean_log_grad(Ha, Ja, u * scale)[0] - t,
                "jac": lambda u: _mean_log_grad(Ha, Ja, u * scale)[1] * scale}
        for key, sign in (("least", 1.0), ("greatest", -1.0)):
            def fun(u, sign=sign):
                f, g = _mean_log_grad(Hb, Jb, u * scale)
                return sign * f, sign * g * scale
            for x0 in x0s:
                r = minimize(fun, x0 / scale, jac=True, method="SLSQP", constraints=[cons],
                             bounds=[(0.0, lambda_max / scale)] * nv, options={"maxiter": 500, "ftol": 1e-12})
                lam = np.clip(r.x * scale, 0.0, lambda_max)
                if abs(_mean_log_m(Ha, Ja, lam) - target) > 1e-6:
                    continue                     # the search left the constraint: not a consistent lambda
                value = _mean_log_m(Hb, Jb, lam)
                if best[key] is None or sign * value < sign * best[key][0]:
                    best[key] = (value, lam)
    return {k: (None if v is None else (float(math.exp(v[0])), v[1].tolist())) for k, v in best.items()}


def subspace_fit(robot, rows: HitRows, *, rtol: float = 0.1, lam0=None):
    """Fit lambda along the combinations the rows determine (:func:`identifiability` at
    ``lam0``, default zero), the others held at ``lam0``: ``lambda = lam0 + V_r^T c`` >= 0
    (eq 15) with ``c`` from least squares on ``ln m*`` (eq 11).

    Returns ``(lambda, rms log residual, rank)``.
    """
    from scipy.optimize import least_squares, minimize

    lam0 = np.zeros(robot.nv) if lam0 is None else np.asarray(lam0, float)
    S, _ = log_sensitivity(robot, rows.Q, rows.directions, lam0)
    ident = identifiability(S, rtol=rtol)
    r = ident["rank"]
    V = np.asarray(ident["combinations"])[:r]
    H, Jn = design_arrays(robot, rows.Q, rows.directions)
    y = np.log(rows.m_eff)

    def resid(c):
        _, s = _solve(H, Jn, np.clip(lam0 + c @ V, 0.0, None))
        return -np.log(s) - y

    def jac(c):
        x, s = _solve(H, Jn, np.clip(lam0 + c @ V, 0.0, None))
        return (x**2 / s[:, None]) @ V.T

    def cost(c):
        res = resid(c)
        return float(res @ res), 2.0 * res @ jac(c)

    c = np.zeros(r)
    if r == robot.nv:
        # every combination determined: lambda itself, bounded below by 0 (a basis change of V)
        c = least_squares(lambda lam: resid((lam - lam0) @ V.T), lam0.copy(), jac=lambda lam: jac((lam - lam0) @ V.T) @ V,
                          bounds=(0.0, np.inf), method="trf", x_scale="jac", xtol=1e-15, ftol=1e-15,
                          gtol=1e-15, max_nfev=2000).x
        c = (c - lam0) @ V.T
    elif r:
        # Levenberg-Marquardt along the determined combinations; where it leaves lambda >= 0,
        # the constrained minimum (SLSQP) instead
        c = least_squares(resid, c, jac=jac, method="lm", x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        if np.min(lam0 + c @ V) < -1e-12 * max(1.0, float(np.max(np.abs(lam0 + c @ V)))):
            c = minimize(cost, np.zeros(r), jac=True, method="SLSQP", options={"maxiter": 500, "ftol": 1e-15},
                         constraints=[{"type": "ineq", "fun": lambda c: lam0 + c @ V, "jac": lambda c: V.T}]).x
    lam = np.clip(lam0 + c @ V, 0.0, None) if r else lam0.copy()
    return lam, float(np.sqrt(np.mean(resid(c) ** 2))), r


def _geomean(m) -> float:
    return float(np.exp(np.mean(np.log(m))))


def transfer(robot, rows: HitRows, *, fit: str, predict: str, rtol: float = 0.1,
             lambda_max: float = LAMBDA_MAX, lam0=None) -> dict:
    """Fit lambda on session ``fit`` and predict session ``predict`` (see the module).

    Returns a JSON-safe dict: per session the rigid-body m* (eq 7) and the identified and
    logged m* (geometric means over the hits), the identifiability of each session and of
    both together, the fit of the fit session's determined combinations (:func:`subspace_fit`) with its
    prediction, and the range of predictions of every lambda that reproduces the fit session
    (:func:`prediction_range`).
    """
    if fit == predict:
        raise InputError(f"the fit and the predicted session are both {fit!r}: name two sessions")
    A, B = rows.select(fit), rows.select(predict)
    lam0 = np.zeros(robot.nv) if lam0 is None else np.asarray(lam0, float)
    out: dict = {"robot": robot.name, "fit": fit, "predict": predict, "at": lam0.tolist(), "sessions": {}}
    for name, r in ((fit, A), (predict, B)):
        S, _ = log_sensitivity(robot, r.Q, r.directions, lam0)
        _, m0 = log_sensitivity(robot, r.Q, r.directions)
        sigma = log_sigma(r)
        logged = r.m_eff_logged[np.isfinite(r.m_eff_logged)]
        out["sessions"][name] = {
            "n_hits": int(r.hit.size), "m_eff": _geomean(r.m_eff),
            "m_eff_range": [float(np.min(r.m_eff_lo)), float(np.max(r.m_eff_hi))],
            "m_rigid": _geomean(m0), "m_logged": _geomean(logged) if logged.size else None,
            "ratio_to_rigid": _geomean(r.m_eff / m0), "log_sigma": sigma,
            "identifiability": identifiability(S, rtol=rtol, sigma=sigma)}
    S_all, _ = log_sensitivity(robot, np.vstack([A.Q, B.Q]), np.vstack([A.directions, B.directions]), lam0)
    both = HitRows(**{f.name: np.concatenate([getattr(A, f.name), getattr(B, f.name)])
                      for f in dataclasses.fields(A) if f.name != "n_flagged"}, n_flagged=0)
    out["both"] = identifiability(S_all, rtol=rtol, sigma=log_sigma(both))

    lam, rms, r = subspace_fit(robot, A, rtol=rtol, lam0=lam0)
    _, m_pred = log_sensitivity(robot, B.Q, B.directions, lam)
    out["fit_lambda"] = {"lambda": lam.tolist(), "rank": r, "rms_log_residual": rms, "predicted": _geomean(m_pred)}
    # the fit session's mean ln m* and its standard error (the hits' scatter)
    y = np.log(A.m_eff)
    se = float(np.std(y, ddof=1) / math.sqrt(y.size)) if y.size > 1 else 0.0
    rng = prediction_range(robot, A, B, targets=[float(y.mean()) - 1.96 * se, float(y.mean()) + 1.96 * se],
                           starts=[np.clip(lam, 0.0, None)], lambda_max=lambda_max)
    out["prediction_range"] = {"least": rng["least"], "greatest": rng["greatest"], "fit_log_se": se}
    return out
