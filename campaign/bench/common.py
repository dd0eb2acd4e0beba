"""What every benchmark shares: the targets, the machine and BLAS lines, timing, and writing a summary section
(``benchmarks/out/``, which ``make bench`` makes)."""

from __future__ import annotations

import datetime
import gc
import math
import os
import platform
import time
from collections.abc import Callable, Iterable, Sequence
from importlib.metadata import version
from pathlib import Path
from typing import Any

from .. import __version__
from ..core.files import write_atomic

#: per-trial simulation time targets of the rig (fixed and flexible base) and the trial write [s]
TARGET_FIXED = 0.025
TARGET_FLEXIBLE = 0.150
TARGET_WRITE = 0.050
#: the naive baseline's time on the machine the rig's targets were set on (about 350 ms)
#: [s]; printed beside the rig's times, but not used to
#: scale them: our naive RK4 (:func:`naive_rk4`) does more per step than that
#: unpublished one (a FrictionState and the contact kinematics at every stage) and takes
#: 2-2.6x that here, while the write references below take 0.5-1.4x theirs
BASELINE_AT_TARGETS = 0.350
#: the reference costs stated for the machine the targets were set on [s]: one NetCDF4
#: group of a few channels written through xarray/h5netcdf ("about 35 ms whatever its
#: size") and the same arrays through plain h5py ("about 3 ms"). Fixed library work that
#: :func:`write_probe` repeats exactly, so ``probe / reference`` says how this machine, at
#: this minute, compares with that one; the per-trial and campaign times are also shown
#: scaled by the xarray figure (the Python-bound one, like the rig)
XARRAY_WRITE_AT_TARGETS = 0.035
H5PY_WRITE_AT_TARGETS = 0.003
#: accuracy target for m* and e at the default integration setting (relative)
TARGET_REL_ERR = 1e-3
#: the reference is the same scene at this multiple of the default substeps (in and out of contact)
REF_FACTOR = 32
#: relative error shown (and plotted) for a setting identical to the reference
ERR_FLOOR = 1e-16
#: the sizes of the work-precision and per-trial cost runs: ``full`` (the recorded run),
#: ``quick`` (fewer scenes, a coarser sweep, fewer repeats) and ``smoke`` (one fixed-base
#: scene, its default setting and one finer one, one timed repeat, the cost of one trial:
#: the whole command in seconds, which shows it runs; its times and errors measure nothing)
SIZES = ("full", "quick", "smoke")


def check_size(size: str) -> str:
    """``size`` if it is one of :data:`SIZES`; else a ``ValueError`` naming it."""
    if size not in SIZES:
        raise ValueError(f"size {size!r}: expected one of {', '.join(SIZES)}")
    return size


# ---------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------

def pin_to_one_cpu() -> str:
    """Pin the process to one CPU if the OS allows it; describe what was done."""
    try:
        cpus = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpus[0]})
        return f"pinned to CPU {cpus[0]}"
    except (AttributeError, OSError):
        return "not pinned (the OS does not support CPU affinity)"


def cpu_name() -> str:
    """The CPU's model name (``/proc/cpuinfo``), else what :mod:`platform` says."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def wall_and_cpu(fn: Callable[[], Any], repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU times [s] of ``repeats`` calls of ``fn`` after one warm-up call: on a
    machine shared with other jobs the CPU time is what one core spends on it."""
    fn()
    wall, cpu = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return wall, cpu


def run_command(cmd: Sequence[str], *, cwd: str | os.PathLike, env: dict[str, str]) -> tuple[float, float, str]:
    """Run a command; return its wall time, the CPU time of it and all its descendants [s]
    and its standard output. Raises with its output tail if it fails."""
    import resource
    import subprocess

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(list(cmd), cwd=cwd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), proc.stdout


def time_call(fn: Callable[[], Any], repeats: int) -> list[float]:
    """Wall times [s] of ``repeats`` calls of ``fn`` after one warm-up call."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return times

def machine_line() -> str:
    """One line naming the machine, its load and the library versions."""

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    libs = ", ".join(f"{name} {version(dist)}" for name, dist in
                     (("numpy", "numpy"), ("pin", "pin"), ("xarray", "xarray")))
    return (f"Machine: {platform.machine()}, {os.cpu_count()} CPUs shared with other jobs, load average "
            f"{load:.1f} at the end of the run; Python {platform.python_version()}, {libs}, campaign {__version__}; "
            f"{datetime.date.today().isoformat()}.")


#: the BLAS thread settings every benchmark pins to 1 before numpy loads (``make bench`` and
#: the top of each script): its timings are those of one core
BLAS_THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def blas_line() -> str:
    """One line saying how many BLAS threads this process runs (the benchmarks pin 1)."""
    return "BLAS threads: " + ", ".join(f"{v}={os.environ.get(v, 'unset')}" for v in BLAS_THREADS) + "."


def relative_error(a: float, b: float) -> float:
    """``|a - b| / |b|`` (absolute when b == 0; nan when either is not finite)."""
    a, b = float(a), float(b)
    if not (math.isfinite(a) and math.isfinite(b)):
        return float("nan")
    return abs(a - b) / abs(b) if b != 0 else abs(a - b)


def timed_call(fn: Callable[[], Any]) -> tuple[Any, float, float]:
    """(result, wall s, CPU s) of one call, garbage collection kept out of the timing."""
    gc.collect()
    enabled = gc.isenabled()
    gc.disable()
    try:
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        return out, time.perf_counter() - w0, time.process_time() - c0
    finally:
        if enabled:
            gc.enable()


def write_section(readme: str | os.PathLike, heading: str, body: str) -> Path:
    """Replace (or append) the section ``heading`` of ``readme`` (a markdown file), atomically."""
    readme = Path(readme)
    text = readme.read_text() if readme.is_file() else "# Benchmarks\n"
    section = f"{heading}\n\n{body.rstrip()}\n"
    lines = text.splitlines(keepends=True)
    start = next((i for i, line in enumerate(lines) if line.rstrip() == heading), None)
    if start is None:
        text = text.rstrip("\n") + "\n\n" + section
    else:
        end = next((j for j in range(start + 1, len(lines)) if lines[j].startswith("## ")), len(lines))
        tail = "".join(lines[end:])
        text = "".join(lines[:start]) + section + ("\n" + tail if tail else "")
    return write_atomic(readme, text)


def md_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """A markdown table of ``rows`` under ``header``."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out)


def short_error(x: float) -> str:
    """Error in short scientific notation ('0' for exact agreement, 'nan' when undefined)."""
    if x is None or not math.isfinite(x):
        return "nan"
    return "0" if x == 0 else f"{x:.1e}"
