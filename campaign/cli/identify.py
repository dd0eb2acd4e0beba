"""``campaign identify``, ``campaign fit-lambda``, ``campaign tables``: the analysis stages.

* ``identify PATH... [--json]``  m* (eq 10), e (eq 12) and the edge velocities of each
  trial file, from its measured channels only; excluded trials carry the reason.
* ``fit-lambda ARCHIVE [--json]``  lambda per gain class (eq 11, 15) over the fixed-base
  trials of an archive folder (``*.nc`` found recursively), with bootstrap CIs, the
  sensitivity matrix, its condition number and identifiability warnings.
* ``tables ARCHIVE --out DIR``  Tables 2-4 as CSV and Markdown beside the paper's values.
"""

from __future__ import annotations

import json
import math
import sys
import warnings

from ..archive import check_listed_digests
from ..core.errors import InputError
from ..core.files import check_output_dir
from ..core.progress import progress
from ..identify import find_trials, identify_files
from ..joints.lambda_fit import IdentifiabilityWarning
from ..model.paper import load_paper
from ..report.tables import TABLE_FILES, fit_gain_classes, write_tables
from ..scene.checks import check_seed
from .commands import HELP


def register(sub) -> None:
    p = sub.add_parser(
        "identify",
        help=HELP["identify"],
        description="Identify each trial from its measured channels only: the contact interval from the piezo "
        "force, hammer velocities from the pendulum encoder, the arm tip's velocities along n from the base F/T "
        "momentum when the joint encoders are sampled coarser than 5 ms, else from the joint encoders through "
        "the arm's dynamics (campaign.identify.options.IdentifyOptions), then m* (eq 10), e (eq 12) and "
        "the piezo impulse beside m_b (v_b - v'_b). Trials that cannot give a trustworthy m* are flagged "
        "'excluded' with the reason.",
    )
    p.add_argument("paths", nargs="+", metavar="PATH", help="trial files (.nc)")
    p.add_argument("--json", action="store_true",
                   help="print a JSON array, one object per trial (non-finite numbers as null)")
    p.set_defaults(func=run_identify)

    p = sub.add_parser(
        "fit-lambda",
        help=HELP["fit-lambda"],
        description="Identify every trial under ARCHIVE (*.nc, recursively), then fit a diagonal lambda >= 0 "
        "(eq 11, 15) per gain class (the paper's: Zero+Low, High) to the fixed-base trials that were not "
        "excluded, by least squares on log m*, with stratified bootstrap confidence intervals, the "
        "sensitivity matrix d ln m*/d ln lambda and identifiability warnings.",
    )
    p.add_argument("archive", metavar="ARCHIVE", help="archive folder of trial files")
    p.add_argument("--json", action="store_true", help="print the fits as JSON")
    _fit_options(p)
    p.set_defaults(func=run_fit)

    p = sub.add_parser(
        "tables",
        help=HELP["tables"],
        description="Identify every trial under ARCHIVE, fit lambda per gain class and write Table 2 (effective "
        "mass per configuration), Table 3 (lambda with CIs) and Table 4 (flexible base, eq 8 prediction vs "
        "identified) as CSV and Markdown into --out, plus identification.csv with every trial.",
    )
    p.add_argument("archive", metavar="ARCHIVE", help="archive folder of trial files")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created)")
    _fit_options(p)
    p.set_defaults(func=run_tables)


def _fit_options(p) -> None:
    p.add_argument("--bootstrap", type=int, default=200, metavar="N",
                   help="bootstrap resamples for the confidence intervals (default 200)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="bootstrap seed (default 0)")


def _check_fit_options(args) -> None:

    if args.bootstrap < 0:
        raise InputError(f"--bootstrap must be >= 0, got {args.bootstrap}")
    check_seed(args.seed, key="--seed")


def _fmt(v, spec=".4g") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)


def _trials(paths) -> list:
    """``paths``, each checked against its finalized folder's manifest before it is read."""
    paths = list(paths)
    check_listed_digests(paths)
    return paths


def run_identify(args) -> int:
    records = identify_files(progress(_trials(args.paths), desc="identify"))
    if args.json:
        json.dump([r.to_dict() for r in records], sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    for r in records:
        head = (f"{r.path}: m* = {_fmt(r.m_eff)} kg, e = {_fmt(r.e)}, v_a = {_fmt(r.v_a)} -> {_fmt(r.v_a_post)} m/s, "
                f"v_b = {_fmt(r.v_b)} -> {_fmt(r.v_b_post)} m/s, contact {_fmt(r.contact_start, '.5f')}-"
                f"{_fmt(r.contact_end, '.5f')} s, impulse {_fmt(r.impulse)} N s (piezo) vs "
                f"{_fmt(r.impulse_momentum)} N s (m_b dv_b)")
        print(head + (f"  EXCLUDED: {r.reason}" if r.excluded else ""))
    return 0


def _fits(args):
    _check_fit_options(args)
    records = identify_files(progress(_trials(find_trials(args.archive)), desc="identify"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        fits = fit_gain_classes(records, n_bootstrap=args.bootstrap, random_state=args.seed, warn=False)
    return records, fits


def run_fit(args) -> int:
    records, fits = _fits(args)
    if not fits:
        raise InputError(f"{args.archive}: no usable fixed-base trials to fit lambda to "
                         f"({sum(r.excluded for r in records)} of {len(records)} trials excluded)")
    excluded = [r for r in records if r.excluded]
    if args.json:
        out = {"trials": len(records), "excluded": [{"path": r.path, "reason": r.reason} for r in excluded],
               "fits": {cls: f.summary() for cls, f in fits.items()}}
        json.dump(out, sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    print(f"{len(records)} trials, {len(excluded)} excluded")
    for r in excluded:
        print(f"  excluded {r.path}: {r.reason}")
    for cls, f in fits.items():
        lvl = f"{100 * f.ci:.0f} %"
        print(f"gain class {cls}: {f.n_trials_} trials, {f.n_configurations_} configurations, "
              f"rms log residual {f.rms_log_residual_:.3g}")
        for j, lam in enumerate(f.lambda_):
            lo, hi = f.lambda_ci_[0, j], f.lambda_ci_[1, j]
            print(f"  lambda_{j + 1} = {lam:.4g} kg m^2  {lvl} CI [{_fmt(float(lo))}, {_fmt(float(hi))}]  "
                  f"{'identifiable' if f.identifiable_[j] else 'NOT identifiable'}")
        print("  sensitivity d ln m*/d ln lambda (rows: configurations):")
        for q, row in zip(f.configurations_, f.sensitivity_, strict=True):
            qd = ", ".join(f"{x:.4g}" for x in (q * 180 / math.pi))
            # the model's angles: the PUMA 560's DH angles, another robot's URDF joint angles
            print(f"    q = [{qd}] deg (model): " + "  ".join(f"{x:.3g}" for x in row))
        print(f"  condition number {f.condition_number_:.4g}")
        for w in f.warnings_:
            print(f"  warning: {w}")
    return 0


def run_tables(args) -> int:
    _check_fit_options(args)
    check_output_dir(args.out, files=TABLE_FILES)
    paper = load_paper()
    records = identify_files(progress(_trials(find_trials(args.archive)), desc="identify"))
    # the tables put the paper's PUMA 560 values beside the trials': another robot has none
    others = sorted({r.robot for r in records} - {paper["robot"]})
    if others:
        raise InputError(f"{args.archive}: tables compares trials with the paper's {paper['robot']}, this archive "
                         f"holds {', '.join(others)} trials (campaign fit-lambda fits their lambda)")
    paths = write_tables(records, args.out, paper=paper, n_bootstrap=args.bootstrap, random_state=args.seed)
    for name, files in paths.items():
        print(f"{name}: " + ", ".join(str(p) for p in files.values()))
    return 0
