"""Work-precision of the simulated VES-II, and its per-trial cost.

For representative scenes (fixed and flexible base, ideal and default scenes,
configurations 2 and 3, Zero/Low/High gains) every integration setting of the rig's
event-located RK4 (``substeps_contact`` from 1/8x to 8x the scene's default, ``substeps_free``
1, 2, 4), the same RK4 forced to a uniform 0.1 ms step, and a straightforward fixed-step RK4
at 0.1 ms (``campaign.bench.naive_rk4``: no event location, no analytic swing, fixed 0.5 s
horizon, Python-side Pinocchio calls) are run in one process, interleaved round-robin, and
compared with a converged reference (the same scene at 32x the default substeps, checked
against 16x) in

(a) the identified m* and e (``campaign.identify`` on the measured channels),
(b) the true post-impact velocities v'_a, v'_b,
(c) the recorded channels: max |x - x_ref| over the samples / peak-to-peak of x_ref, worst
    channel of the measured group (noise is seeded, so it cancels; a one-count flip of a
    quantised channel does not) and of the truth group.

The per-trial cost section times the default setting over the campaign's trials (median
simulation time per trial, fixed and flexible base) and ``campaign.archive.write_trial``
separately, with the naive baseline (0.5 s of fixed-base trial) printed beside them.

Usage::

    .venv/bin/python benchmarks/work_precision.py                 # print
    .venv/bin/python benchmarks/work_precision.py --quick         # 2 scenes per base, fewer settings
    .venv/bin/python benchmarks/work_precision.py --readme benchmarks/README.md --png benchmarks/work_precision.png

The same run is ``campaign bench work-precision [--quick] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from campaign import bench
from campaign.bench.work_precision import (
    assign_fronts,
    format_wp_references,
    wp_verdict,
)

WP_HEADING = "## Work-precision"
COST_HEADING = "## Per-trial cost"

WP_INTRO = """\
Median wall time per trial of every integration setting of the rig against its error, on
representative scenes, from `benchmarks/work_precision.py` (one run; the settings of a scene
interleaved round-robin; simulation only, identification and file writing excluded). Settings
are `substeps_contact/substeps_free`: RK4 steps per 1 ms servo tick in and out of contact
(`campaign/rig/integrate.py`; the rig's default for the contact is 32 steps per contact
duration estimate, at least `integration.substeps_contact`). `rk4 uniform 0.1 ms` is the rig's
integrator at 10/10; `naive rk4 0.1 ms` is a straightforward fixed-step RK4 (no event
location, no analytic swing, 0.5 s fixed horizon; `campaign.bench.naive_rk4`). Errors are
relative to a reference at 32x the default substeps (its distance to 16x is in the second
table): (a) identified m*, e; (b) true v'_a, v'_b; (c) recorded channels, max error over the
samples relative to each channel's peak-to-peak excursion, measured group (seeded noise
cancels; a one-count flip of a quantised encoder does not) and truth group. `0` = identical
to the reference. `front` = on the Pareto front of (median time, worst of m*, e, v'_a, v'_b)
by wall time / CPU time / RHS evaluations."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer scenes, settings and repeats")
    ap.add_argument("--repeats", type=int, default=None, help="timed trials per setting (default 5)")
    ap.add_argument("--no-flexible", action="store_true", help="fixed-base scenes only")
    ap.add_argument("--no-cost", action="store_true", help="skip the per-trial cost section")
    ap.add_argument("--readme", type=Path, help=f"write '{WP_HEADING}' and '{COST_HEADING}' into this file")
    ap.add_argument("--png", type=Path, default=None, help="write the log-log plot here")
    ap.add_argument("--json", type=Path, default=None, help="write the raw rows here (after every scene)")
    ap.add_argument("--only", default=None, help="run only scenes whose label contains this text")
    ap.add_argument("--from-json", type=Path, nargs="+", default=None, metavar="JSON",
                    help="do not run the sweep: render the rows saved by --json (later files replace the scenes "
                    "of earlier ones)")
    ap.add_argument("--cost-only", action="store_true", help="only the per-trial cost section")
    ap.add_argument("--note", default="", help="a sentence added under the verdict (e.g. where the rows come from)")
    args = ap.parse_args(argv)

    log = (lambda s: print(s, file=sys.stderr))
    def checkpoint(partial):
        if args.json:
            import json

            from campaign.cli.bench import _jsonable
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(_jsonable(partial), indent=1))

    if args.cost_only:
        res = None
    elif args.from_json:
        res = load_results(args.from_json)
    else:
        res = bench.work_precision(quick=args.quick, repeats=args.repeats, flexible=not args.no_flexible, log=log,
                                   only=args.only, checkpoint=checkpoint)
        checkpoint(res)
    wp_body = render(res, args) if res is not None else None
    cost_body = None
    if not args.no_cost and (args.cost_only or not args.from_json):
        cost = bench.trial_cost(quick=args.quick, log=log)
        cost_body = "\n\n".join([
            "Median wall time per trial at the default integration setting over the campaign's trials "
            "(configurations 1-3 fixed / 1-2 flexible, their gain sets, 1.0 and 2.5 m/s; "
            f"{cost['repeats']} timed runs each after a warm-up), the trial file written by "
            "`campaign.archive.write_trial` timed separately, and the naive baseline in the same run. "
            "Targets: simulation <= 25 ms (fixed) / <= 150 ms (flexible), writing <= 50 ms.",
            bench.format_cost(cost), bench.machine_line(),
        ])
        print("\n" + cost_body)
    if args.readme:
        if wp_body:
            bench.write_section(args.readme, WP_HEADING, wp_body)
        if cost_body:
            bench.write_section(args.readme, COST_HEADING, cost_body)
        print(f"\nwrote the sections in {args.readme}", file=sys.stderr)
    return 0


def load_results(paths) -> dict:
    """Rows saved by --json; a later file replaces the scenes of earlier ones. Fronts are
    recomputed."""
    import json

    def num(x):
        if isinstance(x, str) and x in ("inf", "-inf", "nan"):
            return float(x)
        if isinstance(x, dict):
            return {k: num(v) for k, v in x.items()}
        if isinstance(x, list):
            return [num(v) for v in x]
        return x

    res = {"rows": [], "scenes": [], "skipped": [], "repeats": 0}
    for path in paths:
        part = num(json.loads(Path(path).read_text()))
        labels = {sc["label"] for sc in part["scenes"]}
        res["rows"] = [r for r in res["rows"] if r["scene"] not in labels] + part["rows"]
        res["scenes"] = [sc for sc in res["scenes"] if sc["label"] not in labels] + part["scenes"]
        res["skipped"] = [sk for sk in res["skipped"] if sk[0] not in labels] + [tuple(x) for x in part["skipped"]]
        res["repeats"] = part["repeats"]
    order = [sc.label for sc in bench.wp_scenes()]
    res["scenes"].sort(key=lambda sc: order.index(sc["label"]) if sc["label"] in order else 99)
    res["rows"].sort(key=lambda r: order.index(r["scene"]) if r["scene"] in order else 99)
    for sc in res["scenes"]:
        assign_fronts([r for r in res["rows"] if r["scene"] == sc["label"]])
    return res


def render(res, args) -> str:
    png = bench.plot_work_precision(res, args.png) if args.png else None
    verdict = "\n".join(wp_verdict(res))
    skipped = ("\n\nNot run: " + "; ".join(f"{a} ({b})" for a, b in res["skipped"])) if res["skipped"] else ""
    plot = ""
    if png:
        rel = png.name if args.readme and png.resolve().parent == args.readme.resolve().parent else png
        plot = f"\n\n![work-precision]({rel})"
    wp_body = "\n\n".join([
        WP_INTRO, bench.format_wp_table(res), format_wp_references(res),
        "Verdict per scene (default setting):\n\n" + verdict + skipped + (f"\n\n{args.note}" if args.note else "") + plot,
        bench.machine_line() + f" Repeats per setting: {res['repeats']} (flexible: 3; naive: half). Rerun: "
        "`.venv/bin/python benchmarks/work_precision.py --readme benchmarks/README.md --png "
        "benchmarks/work_precision.png`.",
    ])
    print(wp_body)
    return wp_body


if __name__ == "__main__":
    sys.exit(main())
