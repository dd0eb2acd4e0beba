"""The floor of a compiled fixed-base trial loop, against the Python one-trial path.

Lock-step batching (``campaign.rig.batch``) leaves ~90 % of a fixed-base trial's CPU in
Python around Pinocchio. This benchmark measures what a loop compiled against Pinocchio's
C++ library would still spend: the per-call cost of the dynamics a right-hand-side
evaluation needs (ABA in the world convention; the impact frame's placement and Jacobian
for the contact gap; RNEA for a stuck joint's holding torque) on the rig's own arm model,
timed in C++ (``compiled_floor/floor.cpp``, built here against the ``pin`` wheel's headers
and ``libpinocchio_default``) and from Python (``pin.aba`` etc., one state per call); and the
rig's evaluation counts per trial from one sweep job of the full campaign, simulated
through the one-trial path (build / integrate / record timed apart, CPU).

Eigen's headers are not in the ``pin`` wheel: the script downloads the ``cmeel-eigen``
wheel from PyPI (``pip download``) into ``.benchmarks/compiled_floor/`` and compiles there
with ``g++`` (about a minute). Nothing of it is part of the package.

Usage::

    python benchmarks/compiled_floor.py [--readme benchmarks/out/summary.md]
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import statistics
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pinocchio as pin

from campaign.bench.common import blas_line, machine_line, md_table, write_section
from campaign.model.paper import gain_counts
from campaign.model.robot import load_robot
from campaign.rig.integrate import integrate_trial
from campaign.rig.trial import build, integration_args, record_arrays
from campaign.scene.description import make_scene

HERE = Path(__file__).resolve().parent
WORK = HERE.parent / ".benchmarks" / "compiled_floor"
EIGEN = "cmeel-eigen==3.4.1"
SPEEDS = (1.0, 1.3, 1.6, 1.9, 2.2, 2.5)
DEFINES = ["-DNDEBUG", "-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION", "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
           "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30", "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
           "-DBOOST_FUSION_INVOKE_MAX_ARITY=12"]


def cmeel_prefix() -> Path:
    """The ``cmeel.prefix`` folder of the installed ``pin`` wheel (headers and libraries)."""
    for p in Path(pin.__file__).resolve().parents:
        if p.name == "cmeel.prefix":
            return p
    raise SystemExit("compiled_floor: pinocchio is not installed from the pin wheel (no cmeel.prefix)")


def build_floor() -> tuple[Path, float]:
    """Compile floor.cpp (once); returns the binary and the compile's wall time [s] (0 if cached)."""
    WORK.mkdir(parents=True, exist_ok=True)
    binary = WORK / "floor"
    if binary.exists() and binary.stat().st_mtime > (HERE / "compiled_floor" / "floor.cpp").stat().st_mtime:
        return binary, 0.0
    eigen = WORK / "eigen" / "cmeel.prefix" / "include" / "eigen3"
    if not eigen.is_dir():
        subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "-q", EIGEN, "-d", str(WORK)], check=True)
        wheel = next(WORK.glob("cmeel_eigen-*.whl"))
        zipfile.ZipFile(wheel).extractall(WORK / "eigen")
    prefix = cmeel_prefix()
    t0 = time.perf_counter()
    subprocess.run(["g++", "-O2", "-std=c++17", *DEFINES, f"-I{prefix / 'include'}", f"-I{eigen}",
                    str(HERE / "compiled_floor" / "floor.cpp"), f"-L{prefix / 'lib'}", "-lpinocchio_default", f"-Wl,-rpath,{prefix / 'lib'}", "-o", str(binary)], check=True)
    return binary, time.perf_counter() - t0


def compiled_costs(binary: Path, robot) -> dict[str, float]:
    """Per-call cost [us] of each dynamics call in C++ (median of 7 runs of 200k calls)."""
    model = robot.model
    if any(j.shortname() != "JointModelRZ" for j in model.joints[1:]):
        raise SystemExit("compiled_floor: floor.cpp builds revolute-z joints only")
    lines = [f"{model.njoints - 1} " + " ".join(f"{x:.17g}" for x in model.gravity.linear)]
    se3 = lambda M: " ".join(f"{x:.17g}" for x in (*M.rotation.ravel(), *M.translation))  # noqa: E731
    for j in range(1, model.njoints):
        I = model.inertias[j]
        lines.append(f"{model.parents[j]} {se3(model.jointPlacements[j])} {model.armature[j - 1]:.17g} "
                     f"{I.mass:.17g} " + " ".join(f"{x:.17g}" for x in (*I.lever, *I.inertia.ravel())))
    f = model.frames[robot.impact_frame_id]
    lines.append(f"{f.parentJoint} {se3(f.placement)}")
    spec = WORK / "model.txt"
    spec.write_text("\n".join(lines) + "\n")
    out = subprocess.run([str(binary), str(spec)], check=True, capture_output=True, text=True).stdout
    costs = {k: float(v) for k, v in (line.split() for line in out.splitlines())}
    if int(costs.pop("nv")) != model.nv:
        raise SystemExit("compiled_floor: the C++ model's nv differs from the rig's arm model")
    return costs


def python_costs(robot, n: int = 20000) -> dict[str, float]:
    """The same calls from Python, one state per call [us] (median of 7 runs)."""
    model, data = robot.model, robot.model.createData()
    fid = robot.impact_frame_id
    q, v, tau, a = (np.full(model.nv, x) for x in (0.3, 0.1, 1.0, 0.0))
    calls = {"aba": lambda: pin.aba(model, data, q, v, tau, pin.Convention.WORLD),
             "rnea": lambda: pin.rnea(model, data, q, v, a),
             "frame_jacobian": lambda: (pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED),
                                        data.oMf[fid])}
    out = {}
    for name, fn in calls.items():
        runs = []
        for _ in range(7):
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            runs.append((time.perf_counter() - t0) / n * 1e6)
        out[name] = statistics.median(runs)
    return out


def trial_costs(gain: str) -> dict[str, float]:
    """One sweep job of the full campaign (fixed base, 3 configurations x 6 speeds x 2
    repeats) through the one-trial path: CPU per trial by stage [ms] and evaluation counts."""
    scenes = [make_scene(base="fixed", config=c, gain=gain, speed=v, repeat=r, gains_counts=gain_counts(gain),
                         campaign_seed=1996) for c in (1, 2, 3) for v in SPEEDS for r in range(2)]
    b = i = rec = 0.0
    n_rhs, n_steps = [], []
    for s in scenes:
        c0 = time.process_time()
        rig = build(s)
        c1 = time.process_time()
        traj = integrate_trial(rig.plant, rig.pid, **integration_args(rig))
        c2 = time.process_time()
        record_arrays(rig, traj)
        c3 = time.process_time()
        b, i, rec = b + c1 - c0, i + c2 - c1, rec + c3 - c2
        n_rhs.append(traj.n_rhs)
        n_steps.append(traj.n_steps)
    n = len(scenes)
    return {"trials": n, "build": b / n * 1e3, "integrate": i / n * 1e3, "record": rec / n * 1e3,
            "rhs": float(np.mean(n_rhs)), "steps": float(np.mean(n_steps))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gain", default="high")
    ap.add_argument("--readme", help="write the summary under '## Compiled-loop floor' in this file")
    args = ap.parse_args(argv)
    print(blas_line())
    robot = load_robot("puma560")
    binary, compile_s = build_floor()
    cpp, py = compiled_costs(binary, robot), python_costs(robot)
    trial_costs(args.gain)            # warm-up: imports and caches
    tc = trial_costs(args.gain)
    per_eval_cpp = cpp["aba"] + cpp["frame_jacobian"]
    per_eval_py = py["aba"] + py["frame_jacobian"]
    floor_ms = tc["rhs"] * per_eval_cpp / 1e3
    glue_us = tc["integrate"] * 1e3 / tc["rhs"] - per_eval_py
    rows = [(name, f"{cpp[name]:.2f}", f"{py[name]:.2f}") for name in ("aba", "frame_jacobian", "rnea")]
    body = [
        __doc__.split("\n\n")[1].replace("\n", " "),
        "",
        md_table((f"call (rig's arm model, nv = {robot.model.nv})", "C++ [us]", "Python, one state [us]"), rows),
        "",
        md_table((f"fixed-base sweep job, {args.gain} gains, {tc['trials']} trials, one-trial path", "value"), [
            ("CPU per trial: build / integrate / record [ms]",
             f"{tc['build']:.1f} / {tc['integrate']:.1f} / {tc['record']:.1f}"),
            ("RK4 steps / right-hand-side evaluations per trial", f"{tc['steps']:.0f} / {tc['rhs']:.0f}"),
            ("integration CPU per evaluation [us]", f"{tc['integrate'] * 1e3 / tc['rhs']:.1f}"),
            ("of which Python glue around ABA + frame Jacobian [us]", f"{glue_us:.1f}"),
            ("compiled floor per trial: evaluations x (ABA + frame Jacobian) in C++ [ms]", f"**{floor_ms:.2f}**"),
        ]),
        "",
        f"g++ build of floor.cpp: {compile_s:.0f} s (0 = cached). " + machine_line(),
        "Rerun: `.venv/bin/python benchmarks/compiled_floor.py --readme benchmarks/out/summary.md`.",
    ]
    text = "\n".join(body)
    print(text)
    if args.readme:
        write_section(args.readme, "## Compiled-loop floor", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
