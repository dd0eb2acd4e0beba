"""Closed-form stress: Ex-IIT near singular configurations, eq 11 conditioning, the lambda fit."""

from __future__ import annotations

import math
import time
import warnings as _w
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.vocabulary import HIGH
from ..model import exiit
from ..model.paper import load_paper, paper_offset_deg
from ..model.robot import load_robot
from ..model.robot.floating import BaseBody, attach_to_floating_base
from .common import md_table


# ---------------------------------------------------------------------------------------
# closed-form stress: Ex-IIT near singular configurations, eq 11 conditioning, lambda fit
# ---------------------------------------------------------------------------------------
def _q_dh(q_paper_deg) -> np.ndarray:
    return np.radians(np.asarray(q_paper_deg, float) + paper_offset_deg())


def _eq11_diagnostics(robot, q, lam=None, n=(-1.0, 0.0, 0.0)) -> dict[str, float]:
    """Conditioning of eq 11 at one pose: cond(H + lambda), cond(G*_33), and the relative
    condition number of m* = 1 / (n^T G n) with respect to G, ``||G||_2 / (n^T G n)``."""
    data = robot.model.createData()
    G = exiit.exiit_fixed(robot, q, lam, data=data)[:3, :3]
    H = exiit.inertia(robot.model, data, q) + exiit.lambda_matrix(lam, robot.nv)
    nn = exiit.unit_direction(n)
    s = float(nn @ G @ nn)
    sv = np.linalg.svd(G, compute_uv=False)
    return dict(cond_H=float(np.linalg.cond(H)), cond_G=float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf,
                kappa_m=float(sv[0] / s) if s > 0 else math.inf, nGn=s)


def singular_pose(robot=None) -> tuple[float, float, float]:
    """Paper angles (q1*, q2*, q3*) [deg] of the stretched singularity where n = -x leaves the
    range of G*: the elbow straight (smallest singular value of the tip Jacobian), then q1,
    q2 such that ``n^T G* n = 0`` (wrist centre in the x-z plane, arm horizontal)."""
    from scipy.optimize import minimize, minimize_scalar

    robot = robot or load_robot()
    data = robot.model.createData()

    def smin(q3):
        J = exiit.impact_jacobian(robot.model, data, _q_dh((0.0, 172.0, q3)), robot.impact_frame_id)[:3]
        return float(np.linalg.svd(J, compute_uv=False)[-1])

    q3 = float(minimize_scalar(smin, bounds=(-20.0, 20.0), method="bounded", options={"xatol": 1e-12}).x)

    def ratio(x):
        G = exiit.exiit_fixed(robot, _q_dh((x[0], x[1], q3)), data=data)[:3, :3]
        return float(G[0, 0] / np.trace(G))

    r = minimize(ratio, [-10.0, 180.0], method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-22,
                                                                      "maxiter": 4000})
    return float(r.x[0]), float(r.x[1]), q3


def closed_form_stress(*, log: Callable[[str], None] | None = print) -> dict[str, Any]:
    """Ex-IIT (eq 7, 8, 11) towards the stretched singularity (paper q3 -> 0) and along
    random poses: every m* must be finite and positive or exactly ``inf``; scalar and batch
    evaluations agree; plus eq 11's conditioning and the lambda sensitivity of the paper's
    design, and the lambda fit on ill-conditioned designs (when ``campaign.joints.lambda_fit`` exists)."""

    robot = load_robot()
    paper = load_paper()
    lam_hi = np.asarray(paper["table3"][HIGH], float)
    frobot = attach_to_floating_base(robot, BaseBody(mass=150.0, inertia=np.diag([50.0, 50.0, 5.0])))
    rows, problems = [], []

    def check(label, m, kind):
        if isinstance(m, float) and (math.isnan(m) or m <= 0 or (math.isfinite(m) and m > 1e9)):
            problems.append(f"{label} ({kind}): m* = {m!r}")

    # the stretched singularity where n = -x leaves the range of G*: elbow straight (paper
    # q3*), arm horizontal (q2*), and the shoulder turned so the wrist centre lies in the
    # x-z plane (q1*; with the 0.15 m shoulder offset, joint 1 otherwise moves the tip along x)
    qs = singular_pose(robot)
    info_rows = []
    deltas = (1.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-8, 1e-10, 0.0)
    families = [("paper q3 = q3* + d", 2), ("paper q1 = q1* + d", 0),
                ("configuration 2 family: (0, 172, q3* + d)", None)]
    for fam, axis in families:
        poses = []
        for dlt in deltas:
            qp = np.array(qs, float) if axis is not None else np.array([0.0, 172.0, qs[2]])
            qp[2 if axis is None else axis] += dlt
            poses.append(qp)
        Q = np.array([_q_dh(qp) for qp in poses])
        for lam_name, lam in (("0", None), ("High", lam_hi)):
            batch = exiit.effective_mass_batch(robot, Q, lam=lam)
            prev = 0.0
            for dlt, q, mb in zip(deltas, Q, batch, strict=True):
                ms = exiit.effective_mass(robot, q, lam=lam)
                mf = exiit.effective_mass(frobot, q, lam=lam)
                d = _eq11_diagnostics(robot, q, lam)
                label = f"{fam}, d = {dlt:g} deg, lambda {lam_name}"
                for kind, m in (("scalar", ms), ("batch", float(mb)), ("flexible eq 8", mf)):
                    if not (m == math.inf or (math.isfinite(m) and m > 0)):
                        problems.append(f"{label} ({kind}): m* = {m!r} is neither finite > 0 nor inf")
                # a finite value must be meaningful: its rounding error bound eps * kappa * cond(H)
                acc = np.finfo(float).eps * d["kappa_m"] * d["cond_H"] if math.isfinite(ms) else 0.0
                if math.isfinite(ms) and acc > 1e-2:
                    problems.append(f"{label}: finite m* = {ms:.4g} kg with a rounding error bound of {acc:.2g}")
                agree = (math.isinf(ms) and math.isinf(mb)) or (math.isfinite(ms) and math.isfinite(mb)
                                                                  and abs(ms - mb) <= 1e-6 * ms)
                if not agree:
                    problems.append(f"{label}: scalar {ms!r} vs batch {float(mb)!r}")
                if axis is not None and ms < prev:
                    problems.append(f"{label}: m* = {ms:.6g} falls while approaching the singularity")
                prev = ms
                rows.append(dict(family=fam, q3=dlt, lam=lam_name, m_scalar=ms, m_batch=float(mb), m_flex=mf,
                                 acc=acc, **d))
    del info_rows
    # random poses inside the limits, including poses pushed onto the singular set
    rng = np.random.default_rng(8)
    Q = rng.uniform(robot.q_lower, robot.q_upper, size=(2000, robot.nv))
    Q[:500, 2] = -np.pi / 2 + rng.normal(0, 1e-9, 500)     # elbow straight (paper q3 = 0) within 1e-9 rad
    batch = exiit.effective_mass_batch(robot, Q)
    n_inf = int(np.sum(np.isinf(batch)))
    bad = int(np.sum(~(np.isinf(batch) | ((batch > 0) & (batch < 1e9)))))
    if bad:
        problems.append(f"random poses: {bad} of {len(Q)} batch values neither finite positive (< 1e9 kg) nor inf")
    mism = 0
    for q, mb in zip(Q[::10], batch[::10], strict=True):
        ms = exiit.effective_mass(robot, q)
        if not ((math.isinf(ms) and math.isinf(mb)) or abs(ms - mb) <= 1e-9 * ms):
            mism += 1
    if mism:
        problems.append(f"random poses: {mism} scalar/batch disagreements")
    rnd = dict(n=len(Q), n_inf=n_inf, bad=bad, mismatches=mism, max_finite=float(np.max(batch[np.isfinite(batch)])))

    # eq 11 as a lambda estimator: sensitivity of ln m* to ln lambda on the paper's design
    sens = _lambda_sensitivity(robot, [_q_dh(paper["configurations"][c]) for c in (1, 2, 3)], lam_hi)
    fit = _fit_stress(robot, paper, log=log)
    if log:
        log(f"[closed-form] {len(rows)} singular-family evaluations, {len(Q)} random poses; "
            f"{len(problems)} problems; sensitivity cond {sens['cond']:.3g}")
    return dict(rows=rows, random=rnd, problems=problems, sensitivity=sens, fit=fit)


def _lambda_sensitivity(robot, Qs, lam, h: float = 1e-6) -> dict[str, Any]:
    """S_ij = d ln m*_i / d ln lambda_j (central differences) and cond(S)."""
    S = np.zeros((len(Qs), len(lam)))
    for i, q in enumerate(Qs):
        for j in range(len(lam)):
            up, dn = lam.copy(), lam.copy()
            up[j] *= 1 + h
            dn[j] *= 1 - h
            S[i, j] = (math.log(exiit.effective_mass(robot, q, lam=up)) -
                       math.log(exiit.effective_mass(robot, q, lam=dn))) / (2 * h)
    sv = np.linalg.svd(S, compute_uv=False)
    return dict(S=S, cond=float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf, lam=lam)


def _fit_stress(robot, paper, *, log=None) -> dict[str, Any]:
    """The lambda fit (``campaign.joints.lambda_fit``) on a well-posed and on ill-conditioned designs:
    it must report its condition number and not return wild values."""
    try:
        from ..joints import lambda_fit as fitmod
    except ImportError as exc:
        return dict(available=False, note=f"campaign.joints.lambda_fit is not available yet ({exc})")
    return _run_fit_stress(fitmod, robot, paper, log=log)


def _run_fit_stress(fitmod, robot, paper, *, log=None) -> dict[str, Any]:
    """LambdaFit on synthetic m* (eq 11 at the paper's High lambda, lognormal noise): the
    paper's design, and designs that are ill-conditioned by construction. A fit passes when
    every value is finite and inside its bounds, the condition number is reported, and any
    component more than 2x off the truth (or whose CI misses it) is flagged not identifiable."""

    lam_true = np.asarray(paper["table3"][HIGH], float)
    qs = singular_pose(robot)
    c = {k: np.array(v, float) for k, v in paper["configurations"].items()}
    designs = [
        ("paper configurations 1-3, 2 % noise", [c[1], c[2], c[3]], 0.02),
        ("paper configurations 1-3, 20 % noise", [c[1], c[2], c[3]], 0.20),
        ("configuration 2 alone (1 pose, 3 parameters)", [c[2]], 0.02),
        ("three poses within 0.01 deg of configuration 2", [c[2], c[2] + [0, 0, 0.01], c[2] + [0, 0.01, 0]], 0.02),
        ("three poses near the stretched singularity", [np.array(qs) + [0, 0, 0.5], np.array(qs) + [0, 0, 1.0],
                                                         np.array(qs) + [1.0, 0, 0.5]], 0.02),
        ("configurations 1 and 3 (folded / intermediate only)", [c[1], c[3]], 0.02),
    ]
    rng = np.random.default_rng(15)
    out = []
    for label, poses, noise in designs:
        Q = np.repeat(np.array([_q_dh(p) for p in poses]), 5, axis=0)
        m = np.array([exiit.effective_mass(robot, q, lam=lam_true) for q in Q])
        m = m * np.exp(rng.normal(0.0, noise, m.size))
        est = fitmod.LambdaFit(robot, n_bootstrap=100, random_state=1, warn=True)
        with _w.catch_warnings(record=True) as caught:
            _w.simplefilter("always")
            t0 = time.perf_counter()
            try:
                est.fit(Q, m)
                err = ""
            except Exception as exc:  # noqa: BLE001
                err = f"{type(exc).__name__}: {exc}"
            sec = time.perf_counter() - t0
        row = dict(design=label, noise=noise, seconds=sec, warnings=len(caught))
        if err:
            row.update(ok=isinstance(err, str) and err.startswith("InputError"), error=err)
            out.append(row)
            continue
        lam = np.asarray(est.lambda_, float)
        ci = np.asarray(est.lambda_ci_, float)
        ident = np.asarray(getattr(est, "identifiable_", np.ones(lam.size, bool)), bool)
        cond = float(getattr(est, "condition_number_", math.nan))
        problems = []
        if not np.all(np.isfinite(lam)) or np.any(lam < 0) or np.any(lam > est.lambda_max * (1 + 1e-9)):
            problems.append("lambda not finite / outside its bounds")
        if math.isnan(cond):
            problems.append("no condition number")
        for j in range(lam.size):
            wild = not (0.5 * lam_true[j] <= lam[j] <= 2.0 * lam_true[j])
            missed = np.all(np.isfinite(ci[:, j])) and not (ci[0, j] <= lam_true[j] <= ci[1, j])
            if (wild or missed) and ident[j]:
                problems.append(f"lambda_{j + 1} = {lam[j]:.3g} (true {lam_true[j]:.3g}, CI [{ci[0, j]:.3g}, "
                                f"{ci[1, j]:.3g}]) reported identifiable")
        row.update(ok=not problems, problems=problems, lam=lam, ci=ci, identifiable=ident, cond=cond)
        out.append(row)
        if log:
            log(f"[fit] {label}: cond {cond:.3g}, lambda {np.round(lam, 3).tolist()}, identifiable "
                f"{ident.tolist()}, {len(caught)} warnings, {'ok' if not problems else problems}")
    return dict(available=True, rows=out, lam_true=lam_true,
                note=f"{sum(r['ok'] for r in out)} of {len(out)} designs behave (see the table)")


def format_closed_form(c: dict[str, Any]) -> str:
    rows = []
    for r in c["rows"]:
        if r["lam"] != "0" and r["q3"] not in (40.0, 1e-2, 0.0):
            continue
        def m(x):
            return "inf" if math.isinf(x) else f"{x:.4g}"
        rows.append([r["family"], f"{r['q3']:g}", r["lam"], m(r["m_scalar"]), m(r["m_batch"]), m(r["m_flex"]),
                     f"{r['cond_H']:.3g}", "inf" if math.isinf(r["cond_G"]) else f"{r['cond_G']:.3g}",
                     "inf" if math.isinf(r["kappa_m"]) else f"{r['kappa_m']:.3g}"])
    t1 = md_table(["family", "paper q3 [deg]", "lambda", "m* eq 11 [kg]", "batch [kg]", "flexible eq 8 [kg]",
              "cond(H+lambda)", "cond(G*_33)", "kappa(m*) = ||G||/(n'Gn)"], rows)
    rnd = c["random"]
    s = c["sensitivity"]
    S = s["S"]
    t2 = md_table(["configuration", "d ln m*/d ln lambda_1", "d ln m*/d ln lambda_2", "d ln m*/d ln lambda_3"],
             [[i + 1, *(f"{x:.3g}" for x in S[i])] for i in range(S.shape[0])])
    fit = c["fit"]
    lines = [
        t1, "",
        f"Random poses inside the joint limits (500 of them with the elbow straight to within 1e-9 rad): "
        f"{rnd['n']} evaluated, {rnd['n_inf']} returned inf, {rnd['bad']} neither finite-positive nor inf, "
        f"{rnd['mismatches']} scalar/batch disagreements; largest finite m* {rnd['max_finite']:.3g} kg.", "",
        f"Eq 11 as an estimator of lambda (paper's three configurations, n = -x, at the Table 3 High lambda): "
        f"condition number of the sensitivity matrix **{s['cond']:.3g}**.", "",
        t2, "",
        "Problems: " + ("none." if not c["problems"] else "; ".join(c["problems"])), "",
        "Lambda fit (`campaign.joints.lambda_fit.LambdaFit`, synthetic m* from eq 11 at the Table 3 High lambda "
        "with lognormal noise, 5 trials per pose, 100 bootstrap resamples): " + fit["note"] + ".",
    ]
    if fit.get("rows"):
        frows = []
        for r in fit["rows"]:
            if "error" in r:
                frows.append([r["design"], "-", "-", "-", "-", r["warnings"], ("ok: " if r["ok"] else "") + r["error"][:90]])
                continue
            lam = ", ".join(f"{x:.3g}" for x in r["lam"])
            ci = ", ".join(f"[{a:.3g}, {b:.3g}]" for a, b in zip(r["ci"][0], r["ci"][1], strict=True))
            frows.append([r["design"], "inf" if math.isinf(r["cond"]) else f"{r['cond']:.3g}", lam, ci,
                          "".join("y" if x else "n" for x in r["identifiable"]), r["warnings"],
                          "ok" if r["ok"] else "; ".join(r["problems"])])
        lines += ["", md_table(["design", "condition number", "lambda [kg m^2]", "95 % CI", "identifiable (1,2,3)",
                           "warnings", "verdict"], frows),
                  "", f"True lambda: {', '.join(f'{x:g}' for x in fit['lam_true'])} kg m^2."]
    return "\n".join(lines)
