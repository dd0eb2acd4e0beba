"""A workflow job's log: everything it prints, ended by one ``TIMING`` line.

A job that makes several products (``identify_<base>``, ``fixed_base``, ...) writes one log
per product, each ended by the product's own ``TIMING`` line (``part_of`` the job), beside
the job's log, which holds its start-up and imports. ``benchmarks/bench_campaign.py`` sums
the ``TIMING`` lines over a campaign.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import time
import traceback
from collections.abc import Iterator
from typing import TextIO

from ..core.timing import Timer

__all__ = ["job_log"]
def _process_age() -> float:
    """Seconds since this process started (interpreter start-up + imports so far).

    On Linux from ``/proc`` (the process's start in clock ticks since boot against the
    uptime: 10 ms resolution, and no 11 ms of importing psutil in every job); elsewhere
    from psutil.
    """
    try:
        with open("/proc/self/stat", encoding="ascii") as fh:
            start_ticks = int(fh.read().rsplit(")", 1)[1].split()[19])  # field 22, starttime
        with open("/proc/uptime", encoding="ascii") as fh:
            uptime = float(fh.read().split()[0])
        return max(0.0, uptime - start_ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError, AttributeError):
        pass
    try:
        import psutil  # a Snakemake dependency

        return max(0.0, time.time() - psutil.Process().create_time())
    except Exception:  # noqa: BLE001 - timing is informative only
        return float("nan")



def _children_cpu() -> float:
    """CPU seconds of this process's finished child processes (e.g. forked file checks)."""
    try:
        import resource

        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        return usage.ru_utime + usage.ru_stime
    except (ImportError, OSError):  # not on this platform
        return 0.0



@contextlib.contextmanager
def job_log(path: str | os.PathLike | None, *, job: str = "job", exit_process: bool = False,
            part_of: str | None = None) -> Iterator[Timer]:
    """Send everything a job prints to its log file; end the log with a ``TIMING`` line.

    Parameters
    ----------
    path : path-like or None
        The job's log file (``snakemake.log[0]``); None keeps stdout/stderr.
    job : str
        Name printed in the log's first and last lines.
    exit_process : bool
        End the process (exit status 0) as soon as the job has succeeded and its log is
        closed, skipping the interpreter's teardown: freeing the objects of numpy, xarray,
        pinocchio and matplotlib one by one costs 0.1-0.3 s of CPU per job, as much as some
        jobs' work, for memory the operating system takes back at once. Only for a process
        that exists to run this one job (the workflow's scripts): nothing after the ``with``
        block runs, and ``atexit`` handlers do not either, so every output must be written
        and closed inside the block (the campaign's writers close their files and rename
        them into place there). A failing job still raises as usual.
    part_of : str, optional
        This log is one product's of the job named here, opened inside that job's own
        ``job_log``: what the block prints goes to this log, then back to the job's; its
        ``TIMING`` line holds no start-up and says ``part_of`` (its CPU is part of the job's).

    Yields
    ------
    Timer
        Accumulates seconds per stage (``simulate``, ``write``, ``identify``, ...).

    Notes
    -----
    The last line is ``TIMING {json}`` with the wall seconds of ``startup`` (process start
    to the first line of the job: interpreter start-up and Snakemake's script preamble),
    of each stage timed with the timer (``imports`` of the stage's modules, ``simulate``,
    ``write``, ``identify``, ...) and the ``total``, and the same in CPU seconds under
    ``cpu`` (its ``total`` includes the CPU of child processes the job waited for, listed
    as ``children``). A failing job writes its traceback to the log and re-raises.
    """
    if part_of is not None and exit_process:
        raise ValueError("a product's log (part_of) cannot end the process")
    timer = Timer()
    startup = _process_age() if part_of is None else 0.0
    # CPU of this process so far: interpreter, preamble, this module (a part: from its start)
    startup_cpu = time.process_time() if part_of is None else 0.0
    c0 = time.process_time()
    children0 = _children_cpu() if part_of is not None else 0.0
    t0 = time.perf_counter()
    stream: TextIO | None = open(path, "w", encoding="utf-8", buffering=1) if path is not None else None
    old = sys.stdout, sys.stderr
    if stream is not None:
        sys.stdout = sys.stderr = stream
    try:
        print(f"{job}: started (start-up {startup:.2f} s)")
        yield timer
    except BaseException:
        traceback.print_exc()
        raise
    finally:
        total = time.perf_counter() - t0 + (startup if math.isfinite(startup) else 0.0)
        children = _children_cpu() - children0
        record = {"job": job, "startup": round(startup, 4), **{k: round(v, 4) for k, v in timer.seconds.items()},
                  "total": round(total, 4),
                  "cpu": {"startup": round(startup_cpu, 4), **{k: round(v, 4) for k, v in timer.cpu.items()},
                          "children": round(children, 4),
                          "total": round(startup_cpu + time.process_time() - c0 + children, 4)}}
        if part_of is not None:
            record["part_of"] = part_of
        print(f"TIMING {json.dumps(record, sort_keys=True)}")
        if stream is not None:
            sys.stdout, sys.stderr = old
            stream.close()
    if exit_process:  # reached only when the job succeeded (an exception re-raises above)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)

