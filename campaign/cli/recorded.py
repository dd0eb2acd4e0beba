"""``campaign recorded-lambda``: what recorded hits determine of lambda, and one session's
fit used to predict another (:func:`campaign.design.transfer`)."""

from __future__ import annotations

import json
import math

from ..core.errors import InputError
from ..design.recorded import LAMBDA_MAX, read_hit_rows, transfer
from ..model.robot import load_robot
from .commands import HELP

__all__ = ["register", "run_recorded_lambda", "format_report"]


def register(sub) -> None:
    p = sub.add_parser(
        "recorded-lambda",
        help=HELP["recorded-lambda"],
        description="Read per-hit rows of recorded impacts (columns hit, session, object_mass, n_x, n_y, n_z, "
        "q_1..q_N [rad], speed, m_eff, m_eff_lo, m_eff_hi, e, e_lo, e_hi, m_eff_logged, flag; a hit is used when "
        "its flag is empty or 'ok'), compare each session's identified m* with the robot's rigid-body model "
        "(eq 7) and the recording's logged model, report which combinations of lambda the poses of each session "
        "and of both determine (singular values of d ln m*/d lambda at lambda = 0), fit lambda (eq 11, 15) on "
        "the --fit session and predict the --predict session, with the range of m* that every lambda "
        "reproducing the fit session predicts.",
    )
    p.add_argument("hits", metavar="HITS", help="per-hit CSV file")
    p.add_argument("--robot", required=True, metavar="ROBOT",
                   help="the arm: a shipped robot's name, its folder or its drive file (URDF + drives.yaml)")
    p.add_argument("--fit", required=True, metavar="SESSION", help="the session lambda is fitted on")
    p.add_argument("--predict", required=True, metavar="SESSION", help="the session the fit predicts")
    p.add_argument("--rtol", type=float, default=0.1, metavar="R",
                   help="a combination of lambda is determined when its singular value exceeds R times the "
                   "largest (default 0.1)")
    p.add_argument("--lambda-max", type=float, default=LAMBDA_MAX, metavar="KGM2",
                   help=f"upper bound of each lambda component [kg m^2] for the fit and the range "
                   f"(default {LAMBDA_MAX:g}: no bound in practice)")
    p.add_argument("--at", metavar="LAMBDA", default=None,
                   help="the lambda [kg m^2] the sensitivity is linearised at and the fit starts from, one value "
                   "per joint, comma-separated (default all zero: the rigid-body model)")
    p.add_argument("--json", action="store_true", help="print the report as JSON (non-finite numbers as null)")
    p.set_defaults(func=run_recorded_lambda)


def _check(args, nv: int):
    """The checked options; returns ``--at`` as an array (None when not given)."""
    at = None
    if args.at is not None:
        try:
            at = [float(v) for v in args.at.split(",")]
        except ValueError:
            raise InputError(f"--at {args.at}: expected {nv} comma-separated values [kg m^2]") from None
        if len(at) != nv or not all(math.isfinite(v) and v >= 0 for v in at):
            raise InputError(f"--at {args.at}: expected {nv} comma-separated values >= 0 [kg m^2], one per joint")
    if not (math.isfinite(args.rtol) and 0 < args.rtol < 1):
        raise InputError(f"--rtol {args.rtol:g}: must be in (0, 1)")
    if not (math.isfinite(args.lambda_max) and args.lambda_max > 0):
        raise InputError(f"--lambda-max {args.lambda_max:g}: must be > 0 kg m^2")
    return at


def _vec(values, spec: str = ".3g") -> str:
    return "[" + ", ".join("-" if v is None else format((float(v) if abs(float(v)) > 1e-12 else 0.0) + 0.0, spec) for v in values) + "]"


def _session_lines(name: str, s: dict) -> list[str]:
    lo, hi = s["m_eff_range"]
    logged = "" if s["m_logged"] is None else f"; logged model {s['m_logged']:.4g} kg"
    return [f"session {name}: {s['n_hits']} hits, m* = {s['m_eff']:.4g} kg (hits' intervals {lo:.4g}-{hi:.4g} kg); "
            f"rigid-body model (eq 7) {s['m_rigid']:.4g} kg, ratio {s['ratio_to_rigid']:.3f}{logged}"]


def _ident_lines(label: str, ident: dict, nv: int) -> list[str]:
    sv = ident["singular_values"]
    return [f"  {label}: {ident['rank']} of {nv} combinations determined ({ident['n_rows']} hits), "
            f"singular values {_vec(sv)} 1/(kg m^2)"]


def format_report(rep: dict, nv: int) -> list[str]:
    """The text report of :func:`campaign.design.transfer`'s dict."""
    fit, pred = rep["fit"], rep["predict"]
    lines = []
    for name in (fit, pred):
        lines += _session_lines(name, rep["sessions"][name])
    rtol = rep["both"]["rtol"]
    at = "0" if not any(rep["at"]) else _vec(rep["at"]) + " kg m^2"
    lines.append(f"identifiability (d ln m*/d lambda at lambda = {at}; determined: singular value > {rtol:g} x the "
                 f"largest):")
    lines += _ident_lines(fit, rep["sessions"][fit]["identifiability"], nv)
    lines += _ident_lines(pred, rep["sessions"][pred]["identifiability"], nv)
    both = rep["both"]
    lines += _ident_lines("both", both, nv)
    names = ", ".join(f"lambda_{j + 1}" for j in range(nv))
    lines.append(f"  combinations of ({names}) by both sessions, standard error from the hits' intervals:")
    for k, (v, se) in enumerate(zip(both["combinations"], both["standard_errors"], strict=True)):
        state = "determined" if k < both["rank"] else "not determined"
        sd = "" if se is None else f" +- {se:.3g} kg m^2"
        lines.append(f"    {_vec(v, '+.2f')}{sd}  {state}")
    fl = rep["fit_lambda"]
    lines.append(f"lambda fitted on {fit} along its {fl['rank']} determined combinations (the others at --at): "
                 f"{_vec(fl['lambda'])} kg m^2, rms log residual {fl['rms_log_residual']:.3g}")
    lines.append(f"  predicts {pred}: m* = {fl['predicted']:.4g} kg (identified {rep['sessions'][pred]['m_eff']:.4g} kg)")
    rng = rep["prediction_range"]
    if rng["least"] is None:
        lines.append(f"no lambda in [0, {rep['lambda_max']:g}] kg m^2 reproduces {fit}'s m*")
    else:
        lo, hi = rng["least"][0], rng["greatest"][0]
        lines.append(f"every lambda in [0, {rep['lambda_max']:g}] kg m^2 reproducing {fit}'s m* (+-1.96 standard "
                     f"errors) predicts {pred} between {lo:.4g} and {hi:.4g} kg (spread {100 * (hi / lo - 1):.3g} %)")
    return lines


def _json_safe(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def run_recorded_lambda(args) -> int:
    try:
        robot = load_robot(args.robot)
    except ValueError as exc:
        raise InputError(f"--robot {args.robot}: {exc}") from None
    at = _check(args, robot.nv)
    rows = read_hit_rows(args.hits, robot.nv)
    rep = transfer(robot, rows, fit=args.fit, predict=args.predict, rtol=args.rtol, lambda_max=args.lambda_max,
                   lam0=at)
    rep["lambda_max"] = args.lambda_max
    rep["n_flagged"] = rows.n_flagged
    if args.json:
        print(json.dumps(_json_safe(rep), indent=1))
        return 0
    print(f"robot {robot.name}: {robot.nv} joints; {rows.hit.size} hits used, {rows.n_flagged} flagged, "
          f"from {args.hits}")
    print("\n".join(format_report(rep, robot.nv)))
    return 0
