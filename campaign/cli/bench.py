"""``campaign bench``: work-precision and per-trial cost, stress suite.

``campaign bench work-precision [--quick | --smoke] [--out DIR]`` times every integration setting of
the rig (and a naive fixed-step RK4) on representative scenes against a converged
reference, prints the table and the verdict, and writes the table (markdown), the raw rows
(JSON) and the log-log plot (PNG) to DIR. ``campaign bench stress [--reduced]`` runs the
corners of the input space and the closed-form stress and prints the summary; it exits
with status 1 if a case failed or blew up. The recorded summaries are in the user guide's
*Benchmarks* page (``docs/benchmarks.rst``).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from .. import bench
from ..core.files import check_output_dir, write_atomic
from .commands import HELP


def register(sub) -> None:
    p = sub.add_parser(
        "bench",
        help=HELP["bench"],
        description="Benchmarks of the simulated VES-II. Timings are medians of repeated trials on "
        "this machine; they are not tests.",
    )
    bsub = p.add_subparsers(dest="bench_command", metavar="BENCH", required=True)
    wp = bsub.add_parser(
        "work-precision",
        help="median wall time per trial against the error for every integration setting",
        description="Sweep substeps_contact x substeps_free of the rig's RK4 (and a uniform 0.1 ms step and a "
        "naive fixed-step RK4) on representative scenes (fixed and flexible base, ideal and default, "
        "configurations 2 and 3); errors against a reference at 32x the default substeps in the identified m* "
        "and e, the true post-impact velocities and the recorded channels. Also times the default per-trial "
        "simulation and file writing beside the naive baseline.",
    )
    size = wp.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true",
                      help="two scenes per base, a coarser sweep and fewer repeats (a few minutes)")
    size.add_argument("--smoke", action="store_true",
                      help="one fixed-base scene, its default setting and one with twice the contact substeps, one "
                      "timed repeat, the cost of one trial: the whole command in seconds, to check that it runs "
                      "(its times and errors measure nothing)")
    wp.add_argument("--out", metavar="DIR", default=None,
                    help="write work_precision.md, work_precision.json and work_precision.png here")
    wp.add_argument("--repeats", type=int, default=None, metavar="N",
                    help="timed trials per setting (default 5, quick 3, smoke 1)")
    wp.add_argument("--no-cost", action="store_true", help="skip the per-trial cost table")
    wp.add_argument("--no-flexible", action="store_true", help="fixed-base scenes only")
    wp.set_defaults(func=run_work_precision)
    st = bsub.add_parser(
        "stress",
        help="corners of the input space: every case passes its invariants or is refused up front",
        description="Run the stress grid (poses at/near the stretched singularity and the joint limits, gains "
        "0-1000x High, contact stiffness 0.01-1000x, speeds 0.01-10 m/s, hammer mass 0.01-100x m*, servo "
        "100 Hz-10 kHz, soft and stiff beams, coarse integration overrides) and the closed-form stress (Ex-IIT "
        "near singular poses, eq 11 conditioning, lambda fit on ill-conditioned designs). Exit status 1 if any "
        "case failed or blew up.",
    )
    st.add_argument("--reduced", action="store_true",
                    help="the reduced set the test suite runs: one or two cases per axis (about 10 s)")
    st.add_argument("--no-closed-form", action="store_true", help="skip the closed-form stress")
    st.add_argument("--quiet", action="store_true", help="print only the tables")
    st.set_defaults(func=run_stress)


def _jsonable(x):
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if hasattr(x, "tolist"):
        return _jsonable(x.tolist())
    return x


#: the files ``bench work-precision --out DIR`` writes
WORK_PRECISION_FILES = ("work_precision.md", "work_precision.json", "work_precision.png")


def run_work_precision(args) -> int:
    if args.out:
        check_output_dir(args.out, files=WORK_PRECISION_FILES)
    log = (lambda s: print(s, file=sys.stderr))
    size = "smoke" if args.smoke else "quick" if args.quick else "full"
    res = bench.work_precision(size=size, repeats=args.repeats, flexible=not args.no_flexible, log=log)
    table = bench.format_wp_table(res)
    refs = bench.format_wp_references(res)
    verdict = "\n".join(bench.wp_verdict(res))
    parts = [table, "", refs, "", verdict]
    if res["skipped"]:
        parts += ["", "Skipped: " + "; ".join(f"{a} ({b})" for a, b in res["skipped"])]
    if not args.no_cost:
        cost = bench.trial_cost(size=size, log=log)
        parts += ["", bench.format_cost(cost)]
    parts += ["", bench.machine_line()]
    text = "\n".join(parts)
    print(text)
    if args.out:
        md, js, png = (Path(args.out) / name for name in WORK_PRECISION_FILES)
        bench.plot_work_precision(res, png)      # the figure first: if it fails, no table is left without it
        write_atomic(md, text + "\n")
        write_atomic(js, json.dumps(_jsonable(res), indent=1))
        print(f"\nwrote {md}, {js}, {png}")
    return 0


def run_stress(args) -> int:
    log = None if args.quiet else (lambda s: print(s, file=sys.stderr))
    results = bench.run_stress(bench.stress_cases(reduced=args.reduced), log=log)
    print(bench.format_stress(results))
    if not args.no_closed_form:
        print()
        print(bench.format_closed_form(bench.closed_form_stress(log=log)))
    s = bench.stress_summary(results)
    print(f"\n{s['run']} cases: {s['passed']} passed ({s['excluded']} excluded by identification), "
          f"{s['refused']} refused with a reason, {s['blow-up']} reported blow-ups, {s['failed']} failed")
    return 1 if s["failed"] or s["blow-up"] else 0
