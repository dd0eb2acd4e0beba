"""Numerical-stability stress suite of the simulated VES-II and the closed forms.

A grid over the corners of the input space (``campaign.bench.stress_cases``): poses at and
near the stretched singularity and at the joint limits; gains 0 to 1000x High; contact
stiffness 0.01x to 1000x; impact speeds 0.01 to 10 m/s; hammer mass 0.01x to 100x m*; servo
rates 100 Hz to 10 kHz; very soft and very stiff beams and the VES loop's own limits; coarse
integration overrides; and crossings of those corners. Every case goes through the trial
pipeline (scene -> rig -> simulate -> invariants -> file) and ends as one of

- passed: the trial holds every invariant of ``campaign.bench.check_invariants`` (finite
  everywhere; the contact recorded and followed by data; the hammer's momentum balance; no
  energy gain in passive scenes; identified m* and e finite and physical, or the trial
  excluded by identification with its reason), and its file was written;
- refused: an ``InputError`` before any simulation, with a message naming the cause;
- reported blow-up: a ``SimulationError`` after the work started (no file written);
- failed: anything else (an invariant broken, another exception, a file left behind).

The target is 0 failed (and a blow-up should be a refusal up front). The closed-form
part evaluates the Ex-IIT towards the stretched singularity, eq 11's conditioning, and the
lambda fit on ill-conditioned designs.

Usage::

    .venv/bin/python benchmarks/stress.py                       # full grid (a few minutes)
    .venv/bin/python benchmarks/stress.py --reduced             # the test suite's subset
    .venv/bin/python benchmarks/stress.py --readme benchmarks/README.md

The same run is ``campaign bench stress [--reduced]``. Exit status 1 if a case failed or
blew up.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from campaign import bench
from campaign.bench.stress import stress_summary

HEADING = "## Stress suite"

INTRO = """\
Corners of the input space through the trial pipeline (scene -> rig -> simulate ->
invariants -> file), from `benchmarks/stress.py` (`campaign.bench.stress_cases`). Outcomes:
**passed** (every invariant of `campaign.bench.check_invariants` holds and the file was
written; "excluded" = identification refused to give m* with a stated reason, which is a
deliberate outcome), **refused** (`InputError` before any simulation, message shown),
**reported blow-up** (`SimulationError` after work started; no file), **failed** (an
invariant broken, another exception, or a file left behind). Invariants: every float finite;
the contact recorded and followed by at least 3 joint-encoder samples; the never-tensile
contact slowed the hammer; the hammer's momentum change equals the contact impulse within
the bound of the pendulum's tangential momentum balance (gravity impulse and path curvature
during the contact); in passive scenes (Zero gains; the ideal coupling without gravity) the
energy `E - tau_gc . (q - q0)` never rises after the touch by more than 1e-6 of the
hammer's kinetic energy and the true restitution is <= 1; identified m* finite and >= 0.9x
the Ex-IIT m* (lambda = 0), e in [0, 1.05]. Joint limits are reported, not enforced (the rig
has no end stops)."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reduced", action="store_true", help="the reduced set (tests/test_stress.py)")
    ap.add_argument("--no-flexible", action="store_true", help="fixed-base cases only")
    ap.add_argument("--no-closed-form", action="store_true", help="skip the closed-form stress")
    ap.add_argument("--only", default=None, help="run only cases whose axis or label contains this text")
    ap.add_argument("--readme", type=Path, help=f"write the section '{HEADING}' of this file")
    args = ap.parse_args(argv)

    log = (lambda s: print(s, file=sys.stderr))
    cases = bench.stress_cases(reduced=args.reduced, flexible=not args.no_flexible)
    if args.only:
        cases = [c for c in cases if args.only in c.axis or args.only in c.label]
    results = bench.run_stress(cases, log=log)
    s = stress_summary(results)
    total = sum(r.seconds for r in results)
    parts = [INTRO, bench.format_stress(results),
             f"{s['run']} cases in {total:.0f} s: **{s['passed']} passed** ({s['excluded']} excluded by "
             f"identification), **{s['refused']} refused** with a reason, **{s['blow-up']} reported blow-ups**, "
             f"**{s['failed']} failed**."]
    if not args.no_closed_form:
        parts += ["### Closed-form stress (Ex-IIT, eq 11, lambda fit)",
                  bench.format_closed_form(bench.closed_form_stress(log=log))]
    parts.append(bench.machine_line() + " Rerun: `.venv/bin/python benchmarks/stress.py --readme "
                 "benchmarks/README.md`.")
    body = "\n\n".join(parts)
    print(body)
    if args.readme:
        bench.write_section(args.readme, HEADING, body)
        print(f"\nwrote {HEADING!r} in {args.readme}", file=sys.stderr)
    return 1 if s["failed"] or s["blow-up"] else 0


if __name__ == "__main__":
    sys.exit(main())
