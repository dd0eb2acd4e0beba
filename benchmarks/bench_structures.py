"""CPU per flexible-base trial: the stiff mast against the space-class structure, and the
frozen arm's closed form against its ticks integrated one by one.

For each Table 4 cell at 2.5 m/s, ``campaign.rig.simulate_arrays`` (simulation only, no
archive write) is timed with ``time.process_time`` on the stiff mast, on the space-class
structure (its default: the frozen arm's ticks in closed form, ``campaign.rig.linear_phase``)
and on the space-class structure with ``flexible.linear_phases`` off (every emulator tick of
the frozen arm through Pinocchio); the three are interleaved so that all see the same
machine load, after one warm-up each. Prints the medians [ms] and the closed form's share of
the space-class record's emulator ticks.

Usage::

    python benchmarks/bench_structures.py               # 3 interleaved repeats
    python benchmarks/bench_structures.py --repeats 5
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import campaign.rig.integrate as integrate  # noqa: E402
import campaign.rig.trial_run as trial_run  # noqa: E402
from campaign.bench.common import blas_line, machine_line  # noqa: E402
from campaign.rig import linear_phase, simulate_arrays  # noqa: E402
from campaign.rig.trial import build, integration_args  # noqa: E402
from campaign.scene.description import make_scene  # noqa: E402

CELLS = ((1, "low"), (1, "high"), (2, "low"), (2, "high"))
#: the rigs compared: name -> rig parameters
VARIANTS = {"stiff mast": {"flexible.structure": "stiff_mast"},
            "space class": {"flexible.structure": "space_class"},
            "space class, per tick": {"flexible.structure": "space_class", "flexible.linear_phases": False}}


def linear_fraction(scene) -> float:
    """Share of a trial's emulator ticks after the touch that the frozen arm's closed form
    covers: the integrator's closed-form calls are counted by wrapping them for one run."""
    rig = build(scene)
    done = []
    run = linear_phase.run_frozen

    def counted(*args):
        m, taus = run(*args)
        done.append(m)
        return m, taus

    trial_run.run_frozen = counted
    try:
        integrate.integrate_trial(rig.plant, rig.pid, **integration_args(rig))
    finally:
        trial_run.run_frozen = run
    return sum(done) / max(1, len(rig.plant.history))


def cell_times(config: int, gain: str, *, speed: float, repeats: int) -> dict:
    """Median CPU [s] per variant of one cell, interleaved, and the closed form's share."""
    scenes = {name: make_scene(base="flexible", config=config, gain=gain, speed=speed, params=params)
              for name, params in VARIANTS.items()}
    times = {name: [] for name in scenes}
    for scene in scenes.values():
        simulate_arrays(scene)            # warm-up
    for _ in range(repeats):
        for name, scene in scenes.items():
            t0 = time.process_time()
            simulate_arrays(scene)
            times[name].append(time.process_time() - t0)
    out = {name: statistics.median(v) for name, v in times.items()}
    out["closed form"] = linear_fraction(scenes["space class"])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--speed", type=float, default=2.5)
    args = ap.parse_args(argv)
    print(blas_line())
    rows = {f"{c}-{g}": cell_times(c, g, speed=args.speed, repeats=args.repeats) for c, g in CELLS}
    names = list(VARIANTS)
    print(f"CPU medians over {args.repeats} interleaved trials [ms], {args.speed:g} m/s")
    print("| cell | " + " | ".join(names) + " | space class / stiff mast | per tick / stiff mast | closed form |")
    print("|---|" + "---|" * (len(names) + 3))
    for cell, v in rows.items():
        print(f"| {cell} | " + " | ".join(f"{1e3 * v[n]:.0f}" for n in names)
              + f" | {v['space class'] / v['stiff mast']:.2f} | {v['space class, per tick'] / v['stiff mast']:.2f}"
              f" | {100 * v['closed form']:.0f} % |")
    total = {n: sum(v[n] for v in rows.values()) for n in names}
    print("| all four | " + " | ".join(f"{1e3 * total[n]:.0f}" for n in names)
          + f" | {total['space class'] / total['stiff mast']:.2f} | "
          f"{total['space class, per tick'] / total['stiff mast']:.2f} | |")
    print(machine_line())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
