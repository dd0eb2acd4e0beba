"""CPU per trial of the batched rig against the one-trial path, amortised over a sweep job.

One sweep job of the full campaign (``config/config.yaml``, ``job_unit: sweep``): one base
and one gain set, configurations 1-3 x 6 speeds x 2 repeats = 36 trials. Each round
simulates the job both ways in the same process, one after the other (build, integrate and
record every trial: what the workflow's simulation job does before writing), and times
each with ``time.process_time`` (CPU of this process). The table gives the medians over
the rounds [ms per trial], the batched path's split into build / integrate / record, the
share of RK4 steps the batch took (the rest are its trials' own event loops), and the
ratio. ``--threads`` also times the batched integration of a 3x larger job (108 trials)
with 1 and 2 OpenMP threads per batched Pinocchio call.

Usage::

    python benchmarks/bench_batched.py                 # fixed and flexible, 3 rounds
    python benchmarks/bench_batched.py --bases fixed --rounds 5
    python benchmarks/bench_batched.py --threads       # adds the 1-vs-2-thread comparison
    python benchmarks/bench_batched.py --profile       # adds where the batched integration's CPU goes
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import statistics
import time

from campaign.bench.common import blas_line
from campaign.model.paper import gain_counts
from campaign.rig import batch
from campaign.rig.simulate import (
    build,
    integration_args,
    record_arrays,
    simulate_arrays,
)
from campaign.scene.description import make_scene

SPEEDS = (1.0, 1.3, 1.6, 1.9, 2.2, 2.5)


def sweep(base: str, gain: str, repeats: int = 2) -> list:
    """The scenes of one sweep job of the full campaign."""
    return [make_scene(base=base, config=c, gain=gain, speed=v, repeat=r, gains_counts=gain_counts(gain),
                       campaign_seed=1996)
            for c in (1, 2, 3) for v in SPEEDS for r in range(repeats)]


def one_trial(scenes) -> float:
    c0 = time.process_time()
    for s in scenes:
        simulate_arrays(s)
    return time.process_time() - c0


def batched(scenes, threads: int = 1) -> dict:
    """CPU [s] of the batched job by stage, and the share of steps the batch took."""
    init = batch._Batch.__init__
    made: list = []

    def counting(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)

    c0 = time.process_time()
    rigs = [build(s) for s in scenes]
    c1 = time.process_time()
    batch._Batch.__init__ = counting
    try:
        trajs = batch.integrate_batch([(r.plant, r.pid, integration_args(r)) for r in rigs], threads=threads)
    finally:
        batch._Batch.__init__ = init
    c2 = time.process_time()
    taken = sum(b.accepted for b in made)
    for r, t in zip(rigs, trajs, strict=True):
        record_arrays(r, t)
    c3 = time.process_time()
    # steps the batch took; the rest (event steps) were the trials' own loops'
    total = sum(t.n_steps for t in trajs)
    return {"build": c1 - c0, "integrate": c2 - c1, "record": c3 - c2, "total": c3 - c0,
            "share": taken / total if total else 0.0}


def profile(scenes) -> dict:
    """Where the batched integration's CPU goes [s]: Pinocchio's batched calls
    (``abaInParallel``, ``rneaInParallel``), the rest of the batch's steps (NumPy, the
    per-trial contact kinematics and reduced-model ABA of partly stuck arms), and the
    trials' own loops (event steps, hand-overs)."""
    import pinocchio as pin

    spent = {"batched": 0.0, "batch steps": 0.0}

    def timed(fn):
        def call(*args):
            c = time.process_time()
            fn(*args)
            spent["batched"] += time.process_time() - c
        return call

    class Timed:
        abaInParallel = staticmethod(timed(pin.abaInParallel))
        rneaInParallel = staticmethod(timed(pin.rneaInParallel))

        def __getattr__(self, name):
            return getattr(pin, name)

    step = batch._Batch.step

    def timed_step(self):
        c = time.process_time()
        out = step(self)
        spent["batch steps"] += time.process_time() - c
        return out

    rigs = [build(s) for s in scenes]
    batch.pin, batch._Batch.step = Timed(), timed_step
    try:
        c0 = time.process_time()
        batch.integrate_batch([(r.plant, r.pid, integration_args(r)) for r in rigs])
        total = time.process_time() - c0
    finally:
        batch.pin, batch._Batch.step = pin, step
    return {"abaInParallel + rneaInParallel": spent["batched"],
            "rest of the batch's steps": spent["batch steps"] - spent["batched"],
            "trials' own loops": total - spent["batch steps"], "total": total}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--bases", nargs="+", default=["fixed", "flexible"])
    ap.add_argument("--gain", default="high")
    ap.add_argument("--threads", action="store_true", help="also time 1 vs 2 threads on a 108-trial job")
    ap.add_argument("--profile", action="store_true", help="also split the batched integration's CPU by part")
    args = ap.parse_args(argv)
    print(blas_line())
    print(f"{'job (36 trials)':<22}{'one-trial':>10}{'batched':>9}{'build':>7}{'integ.':>8}{'record':>8}"
          f"{'steps in batch':>16}{'ratio':>7}   [CPU ms per trial, median of {args.rounds}]")
    for base in args.bases:
        scenes = sweep(base, args.gain)
        n = len(scenes)
        simulate_arrays(scenes[0])   # warm-up: imports and caches
        ones, bats = [], []
        for _ in range(args.rounds):
            ones.append(one_trial(scenes))
            bats.append(batched(scenes))
        one = statistics.median(ones) / n * 1e3
        med = {k: statistics.median(b[k] for b in bats) for k in bats[0]}
        tot = med["total"] / n * 1e3
        print(f"{base + ', ' + args.gain:<22}{one:>10.1f}{tot:>9.1f}{med['build'] / n * 1e3:>7.1f}"
              f"{med['integrate'] / n * 1e3:>8.1f}{med['record'] / n * 1e3:>8.1f}{100 * med['share']:>15.0f}%"
              f"{one / tot:>7.2f}x")
    if args.profile:
        for base in args.bases:
            n = len(sweep(base, args.gain))
            runs = [profile(sweep(base, args.gain)) for _ in range(args.rounds)]
            parts = "; ".join(f"{k} {statistics.median(r[k] for r in runs) / n * 1e3:.1f}" for k in runs[0])
            print(f"{base}, batched integration [CPU ms per trial]: {parts}")
    if args.threads:
        scenes = sweep("fixed", args.gain, repeats=6)
        for threads in (1, 2):
            runs = []
            for _ in range(args.rounds):
                rigs = [build(s) for s in scenes]
                jobs = [(r.plant, r.pid, integration_args(r)) for r in rigs]
                w0, c0 = time.perf_counter(), time.process_time()
                batch.integrate_batch(jobs, threads=threads)
                runs.append((time.perf_counter() - w0, time.process_time() - c0))
            wall = statistics.median(r[0] for r in runs)
            cpu = statistics.median(r[1] for r in runs)
            print(f"fixed, {len(scenes)} trials, {threads} thread(s): integrate {wall:.2f} s wall, {cpu:.2f} s CPU")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
