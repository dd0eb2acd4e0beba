"""CPU per trial inside a simulation job: the lean trial loop against the loop it replaced.

A simulation job (``campaign.pipeline.sweep.run_cells``) simulates its trials with
``campaign.rig.batch.simulate_batch``: build every rig, integrate and record each trial. This
script times that call, per trial, for one sweep job of a campaign (``--jobs ci``: the
reduced campaign's sweep of one gain set, 6 fixed-base or 4 flexible-base trials; ``--jobs
full``: the full campaign's, 36 / 36), old and new side by side in the same run:

``old job``
    ``simulate_batch`` of the revision before the lean loop (``--old``, default
    :data:`OLD_REV`): the lock-step batch over the job's trials (NumPy over the batch axis,
    ``pinocchio.abaInParallel``) with the array loop for the steps that hold events;
``old one-trial``
    the same revision's one-trial path (``simulate_arrays`` per trial): the array loop alone;
``new job``
    ``simulate_batch`` now: the lean loop (``campaign.rig.trial_run``) one trial at a time,
    with its split into building the rig, integrating and recording the channels.

Every measurement runs in a fresh process (the old revision's ``campaign`` and ``config``
extracted with ``git archive``), BLAS pinned to one thread before numpy loads, after one
untimed run of the whole job; rounds interleave old and new so that both see the same machine load, and
the table gives medians [CPU ms per trial] (``time.process_time``).

Targets: a fixed-base trial <= 12 ms and a space-class one <= 60 ms of CPU on the 2-core
machine where the old job took 25 and 120 ms. On another machine the verdict scales:
``new / old job x 25 ms`` (resp. 120 ms), the new job's time on the machine where the old
job took 25 (120) ms. Exits with status 1 if a target is missed.

Usage::

    python benchmarks/bench_trial_loop.py                  # ci jobs, fixed and flexible, 3 rounds
    python benchmarks/bench_trial_loop.py --rounds 5 --jobs full --bases fixed
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tarfile  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
#: the last revision with the array loop and the lock-step batch (the "old" columns)
OLD_REV = "24f95fc11fad9d71d6c11ffc16956b67270f1b01"
#: base -> (old job's CPU per trial where the targets were set [ms], target [ms])
TARGETS = {"fixed": (25.0, 12.0), "flexible": (120.0, 60.0)}
#: the sweep jobs timed: campaign -> (speeds, repeats, configurations per base)
JOBS = {"ci": ((1.5, 2.5), 1, {"fixed": (1, 2, 3), "flexible": (1, 2)}),
        "full": ((1.0, 1.3, 1.6, 1.9, 2.2, 2.5), 2, {"fixed": (1, 2, 3), "flexible": (1, 2, 3)})}


# -- the measuring process -------------------------------------------------------------------
def _scenes(base: str, gain: str, jobs: str) -> list:
    """The scenes of one sweep job, as ``run_cells`` makes them (the flexible base on the
    space-class structure)."""
    from campaign.model.paper import gain_counts
    from campaign.scene.description import make_scene

    speeds, repeats, configs = JOBS[jobs]
    params = {"flexible.structure": "space_class"} if base == "flexible" else {}
    return [make_scene(base=base, config=c, gain=gain, speed=v, repeat=r, gains_counts=gain_counts(gain),
                       params=params, campaign_seed=1996)
            for c in configs[base] for v in speeds for r in range(repeats)]


def child(base: str, gain: str, jobs: str, role: str) -> dict:
    """CPU per trial [s] of this process's ``campaign`` (old or new) on one sweep job."""
    import gc

    import scipy.optimize  # noqa: F401  (every job locates events: keep its import out of the timing)

    from campaign.rig.batch import simulate_batch
    from campaign.rig.trial import build, integration_args, record_arrays, simulate_arrays

    scenes = _scenes(base, gain, jobs)
    # warm-up: the whole job once, untimed, so that the job and its split below both time
    # a warm process (valgrind counts the same instructions in a first and a second pass,
    # to 0.2 %; on a quiet machine the two agree to 0.1 ms a trial, under other jobs' load
    # single passes scatter by +-15 ms)
    simulate_batch(scenes)
    n = len(scenes)
    out = {}

    def timed(fn):
        gc.collect()
        c0 = time.process_time()
        fn()
        return (time.process_time() - c0) / n

    out["job"] = timed(lambda: simulate_batch(scenes))
    if role == "old":
        out["one"] = timed(lambda: [simulate_arrays(s) for s in scenes])
        return out
    from campaign.rig.integrate import integrate_trial

    split = {"build": 0.0, "integrate": 0.0, "record": 0.0}
    steps = rhs = 0
    gc.collect()
    for s in scenes:
        c0 = time.process_time()
        rig = build(s)
        c1 = time.process_time()
        traj = integrate_trial(rig.plant, rig.pid, **integration_args(rig))
        c2 = time.process_time()
        record_arrays(rig, traj)
        c3 = time.process_time()
        split["build"] += (c1 - c0) / n
        split["integrate"] += (c2 - c1) / n
        split["record"] += (c3 - c2) / n
        steps += traj.n_steps
        rhs += traj.n_rhs
    out.update(split, steps=steps / n, rhs=rhs / n)
    return out


# -- the driver ------------------------------------------------------------------------------
def _old_tree(rev: str, dest: Path) -> Path:
    """The old revision's ``campaign`` package and ``config`` folder, extracted under ``dest``."""
    data = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", rev, "campaign", "config"],
                          check=True, capture_output=True).stdout
    tar = dest / "old.tar"
    tar.write_bytes(data)
    with tarfile.open(tar) as tf:
        tf.extractall(dest / "old", filter="data")
    return dest / "old"


def _run(root: Path, base: str, gain: str, jobs: str, role: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root)}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", role, "--bases", base, "--gain", gain,
           "--jobs", jobs]
    res = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True, cwd=str(root))
    return json.loads(res.stdout.strip().splitlines()[-1])


def _row(base: str, gain: str, jobs: str, old: list, new: list) -> tuple[str, bool]:
    """A table row from the rounds' measurements, and whether the target is met."""
    def med(runs, key):
        return 1e3 * statistics.median(r[key] for r in runs)

    old_job, new_job = med(old, "job"), med(new, "job")
    old_ref, target = TARGETS[base]
    scaled = new_job / old_job * old_ref
    steps, rhs = new[0]["steps"], new[0]["rhs"]
    n = len(_scenes(base, gain, jobs))
    line = (f"| {base} {gain} ({n} trials) | {old_job:.1f} | {med(old, 'one'):.1f} | {new_job:.1f} | "
            f"{med(new, 'build'):.1f} / {med(new, 'integrate'):.1f} / {med(new, 'record'):.1f} | {steps:.0f} | "
            f"{rhs / steps:.2f} | {old_job / new_job:.2f}x | {scaled:.1f} <= {target:.0f} "
            f"({'met' if scaled <= target else 'MISSED'}) |")
    return line, scaled <= target


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--bases", nargs="+", default=["fixed", "flexible"], choices=sorted(TARGETS))
    ap.add_argument("--gain", default="high")
    ap.add_argument("--jobs", default="ci", choices=sorted(JOBS))
    ap.add_argument("--old", default=OLD_REV, help="revision of the old loop (default: %(default)s)")
    ap.add_argument("--child", choices=("old", "new"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.bases[0], args.gain, args.jobs, args.child)))
        return 0

    from campaign.bench.common import blas_line, machine_line

    print(blas_line())
    print(f"old: {args.old[:12]} (extracted with git archive); new: {REPO}; {args.rounds} interleaved rounds, "
          "each measurement in a fresh process after one untimed run of the job")
    head = ("| job | old job | old one-trial | new job | new: build / integrate / record | RK4 steps | "
            "evaluations per step | speed-up | new / old job x 25 (120) ms vs target |")
    lines, all_ok = [head, "|---" * (head.count("|") - 1) + "|"], True
    print("\n".join(lines), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        old_root = _old_tree(args.old, Path(tmp))
        for base in args.bases:
            old, new = [], []
            for r in range(args.rounds):
                order = (("old", old_root, old), ("new", REPO, new))
                for role, root, into in (order if r % 2 == 0 else order[::-1]):
                    into.append(_run(root, base, args.gain, args.jobs, role))
            line, ok = _row(base, args.gain, args.jobs, old, new)
            lines.append(line)
            all_ok &= ok
            print(line, flush=True)
    print()
    print("\n".join(lines))
    print("[CPU ms per trial, medians of", args.rounds, "rounds]")
    print(machine_line())
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
