"""``campaign design``: choose poses and impact directions that identify lambda (campaign.design.run)."""

from __future__ import annotations

import os
import sys

from ..core.errors import InputError
from ..core.files import check_output_file
from ..design.run import run_design, write_design
from ..model.paper import load_paper
from .args import parse_vector
from .commands import HELP


def register(sub) -> None:
    p = sub.add_parser(
        "design",
        help=HELP["design"],
        description="Choose K poses of the arm, each with a horizontal impact direction, from a candidate set, "
        "maximising the information about ln lambda (eq 11, 15) of each gain class under the identification's "
        "measurement error model var(ln m*) = a^2 + b^2 ((1 + m*/m_b)/v)^2, calibrated on a campaign's identified "
        "trials against their simulator truth. Candidates that give the same m* and sensitivities are offered "
        "once (unless --repeat-information): m* (eq 7) is even in n, so the model gives a pose struck along -n the "
        "m* it gives along n, and it is unchanged when the arm and n turn together about joint 1. Prints the chosen "
        "poses, their predicted sensitivities d ln m*/d ln lambda and the predicted 95 % interval of each lambda "
        "component, beside the same numbers for the paper's three configurations; writes JSON and Markdown.",
    )
    p.add_argument("--k", type=int, default=6, metavar="K", help="number of poses to choose (default 6)")
    p.add_argument("--criterion", choices=("D", "A", "E"), default="D",
                   help="D-optimal (det of the information, default), A (trace of its inverse) or E (its smallest "
                        "eigenvalue)")
    p.add_argument("--candidates", default="grid", metavar="grid|random|FILE",
                   help="candidate set: 'grid' (joint 1 -45/0/45, joint 2 90-225 and joint 3 -30-135 deg every "
                        "15 deg, azimuths of n every 30 deg; default), 'random' (--n-random poses uniform within the "
                        "joint limits, seeded) or a CSV with columns q1,q2,q3 (paper deg) and azimuth (deg from -x "
                        "about +z) or nx,ny,nz")
    p.add_argument("--repeat-information", action="store_true",
                   help="offer every candidate, also one that repeats another's measurement (a pose along n and "
                        "along -n): the design may then choose one measurement twice")
    p.add_argument("--n-random", type=int, default=2000, metavar="N", help="random candidates (default 2000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random candidates (default 0)")
    p.add_argument("--speeds", default="1.5,2.5", metavar="V1,V2,...",
                   help="hammer speeds each pose is struck at [m/s] (default 1.5,2.5)")
    p.add_argument("--repeats", type=int, default=1, metavar="R", help="trials per pose, speed and gain set (default 1)")
    p.add_argument("--calibration", action="append", default=None, metavar="CSV",
                   help="identification table(s) whose fixed-base trials calibrate the error model against their "
                        "truth (default: the committed reference archive's)")
    p.add_argument("--prior", action="append", default=[], metavar="CLASS=L1,L2,L3",
                   help="lambda [kg m^2] the design of a gain class is optimal at (default the paper's Table 3); "
                        "e.g. the lambda a first designed campaign fitted, for a second, sequential design")
    p.add_argument("--rig", default=None, metavar="PATH", help="rig parameter file (default config/rig.yaml)")
    p.add_argument("--json", dest="out_json", default=None, metavar="PATH", help="write the result as JSON")
    p.add_argument("--md", dest="out_md", default=None, metavar="PATH", help="write the result as Markdown")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def _speeds(text: str) -> list[float]:

    out = []
    for s in str(text).split(","):
        try:
            v = float(s)
        except ValueError:
            raise InputError(f"--speeds {text}: {s.strip()!r} is not a number") from None
        if not (v > 0 and v < float("inf")):
            raise InputError(f"--speeds {text}: {s.strip()} must be a speed > 0 m/s")
        out.append(v)
    return out


def run(args) -> int:
    outputs = {option: path for option, path in (("--json", args.out_json), ("--md", args.out_md)) if path is not None}
    for option, path in outputs.items():
        check_output_file(path, option=option)
    if len(outputs) == 2 and os.path.abspath(args.out_json) == os.path.abspath(args.out_md):
        raise InputError(f"--json and --md both name {args.out_json}; name two files")
    speeds = _speeds(args.speeds)
    if args.k < 1:
        raise InputError(f"--k {args.k}: must be >= 1")
    if args.repeats < 1:
        raise InputError(f"--repeats {args.repeats}: must be >= 1")
    if args.seed < 0:
        raise InputError(f"--seed {args.seed}: the seed of the random candidates must be an integer >= 0")
    if args.n_random < 1:
        raise InputError(f"--n-random {args.n_random}: must be >= 1")

    priors = dict(load_paper()["table3"])
    for text in args.prior:
        name, _, values = text.partition("=")
        if name not in priors:
            raise InputError(f"--prior {text}: unknown gain class {name!r}; known: {sorted(priors)}")
        lam = parse_vector(values, option="--prior", size=len(priors[name]), units="kg m^2")
        if any(x <= 0 for x in lam):
            raise InputError(f"--prior {text}: every lambda component must be > 0 kg m^2")
        priors[name] = lam
    result = run_design(n_poses=args.k, criterion=args.criterion, candidates=args.candidates,
                        n_random=args.n_random, seed=args.seed, speeds=speeds, repeats=args.repeats,
                        calibration=args.calibration, rig=args.rig, lambda_prior=priors,
                        repeat_information=args.repeat_information)
    md = write_design(result, out_json=args.out_json, out_md=args.out_md)
    if not args.quiet:
        print(md, end="", file=sys.stdout)
    return 0
