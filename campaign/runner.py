"""The small API the workflow's thin scripts call: sweep cells in, trial files and tables out.

The Snakemake workflow (``Snakefile``, ``workflow/``) only wires stages together; each of
its scripts reads ``snakemake.input``/``params`` and calls one function here:

* :func:`run_cells` simulates every speed x repeat of one or more sweep cells
  (base x configuration x gain set) and writes one trial file per trial with
  :func:`campaign.archive.write_trial` (atomic), printing one progress line per trial;
* :func:`identify_trials` identifies m* (eq 10) and e (eq 12) of trial files from their
  measured channels (:mod:`campaign.identify`) and writes one CSV row per trial;
* :func:`find_cell_trials` lists the trials of a cell in an existing archive, so a campaign
  can be re-analysed without simulating anything (the workflow's ``simulate: false``);
* :func:`job_log` sends a job's output to its log file and ends the log with one
  ``TIMING`` line (interpreter start-up + imports, simulation, identification, total),
  which ``benchmarks/bench_campaign.py`` sums over a campaign.

This module imports only the standard library at the top: the Snakefile imports it to
compute trial paths while it builds the DAG, and must stay fast.

Trial paths follow :attr:`campaign.scene.Scene.cell`:
``<archive>/<base>/config<N>/<gain>/v<speed m/s, 3 decimals>/r<repeat, 2 digits>.nc``;
:func:`run_cells` checks each scene's path against :func:`trial_relpath` before it
simulates, so the workflow's declared outputs and the files written cannot drift apart.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence, TextIO

from .cellpath import misfiled

__all__ = [
    "TRIAL_SUFFIX", "IDENTIFY_COLUMNS", "Timer", "cell_dir", "trial_relpath", "cell_trials", "find_cell_trials",
    "index_cells", "misfiled", "gain_counts", "run_cells", "run_cell", "identify_trials", "read_identification", "fit_lambda", "load_fits",
    "make_table", "job_log", "package_file", "write_atomic",
]

#: suffix of a trial file (campaign.archive.TRIAL_SUFFIX)
TRIAL_SUFFIX = ".nc"

#: columns of an identification CSV, in order: the fields of
#: :class:`campaign.identify.TrialIdentification` (a field it gains later is appended)
IDENTIFY_COLUMNS = (
    "base", "config", "gain", "speed", "repeat", "m_eff", "e", "excluded", "reason",
    "v_a", "v_a_post", "v_b", "v_b_post", "impulse", "impulse_momentum", "peak_force", "contact_start",
    "contact_end", "theta_contact", "n_joint_pre", "n_joint_contact", "n_joint_post", "hammer_mass",
    "q_cmd", "impact_direction", "base_mass", "base_inertia", "base_com", "base_mount", "robot", "path",
)
#: units of the numeric columns
IDENTIFY_UNITS = {
    "speed": "m/s", "m_eff": "kg", "e": "1", "v_a": "m/s", "v_a_post": "m/s", "v_b": "m/s", "v_b_post": "m/s",
    "impulse": "N s", "impulse_momentum": "N s", "peak_force": "N", "contact_start": "s", "contact_end": "s",
    "theta_contact": "rad", "hammer_mass": "kg", "q_cmd": "rad (DH)", "impact_direction": "1", "base_mass": "kg",
    "base_inertia": "kg m2 (row-major 3x3)", "base_com": "m", "base_mount": "m",
}
#: columns holding several numbers (space-separated in the CSV)
_VECTOR_COLUMNS = frozenset({"q_cmd", "impact_direction", "base_inertia", "base_com", "base_mount"})
_TEXT_COLUMNS = frozenset({"base", "gain", "reason", "path", "robot"})
_INT_COLUMNS = frozenset({"config", "repeat", "n_joint_pre", "n_joint_contact", "n_joint_post"})

_GAINS = ("zero", "low", "high")
_BASES = ("fixed", "flexible")


# ---------------------------------------------------------------------------------------
# paths (standard library only: used while Snakemake builds the DAG)
# ---------------------------------------------------------------------------------------
def _check_cell(base: str, config: int, gain: str) -> None:
    if base not in _BASES:
        raise ValueError(f"unknown base {base!r}; expected one of {_BASES}")
    if gain not in _GAINS:
        raise ValueError(f"unknown gain set {gain!r}; expected one of {_GAINS}")
    if isinstance(config, bool) or not isinstance(config, int) or config < 1:
        raise ValueError(f"configuration must be a paper configuration number >= 1, got {config!r}")


def cell_dir(base: str, config: int, gain: str) -> str:
    """Relative folder of a sweep cell in an archive: ``<base>/config<N>/<gain>``."""
    _check_cell(base, config, gain)
    return f"{base}/config{config}/{gain}"


def trial_relpath(base: str, config: int, gain: str, speed: float, repeat: int) -> str:
    """Relative path of one trial in an archive (``Scene.cell`` + ``.nc``).

    Examples
    --------
    >>> trial_relpath("fixed", 1, "zero", 2.5, 0)
    'fixed/config1/zero/v2.500/r00.nc'
    """
    speed = float(speed)
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"impact speed must be a finite number > 0 m/s, got {speed!r}")
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 0:
        raise ValueError(f"repeat must be an integer >= 0, got {repeat!r}")
    return f"{cell_dir(base, config, gain)}/v{speed:.3f}/r{repeat:02d}{TRIAL_SUFFIX}"


def cell_trials(archive_dir: str | os.PathLike, base: str, config: int, gain: str,
                speeds: Sequence[float], repeats: int) -> list[str]:
    """Paths of every trial of a cell: each speed x repeat ``0 .. repeats-1``, speed-major."""
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1, got {repeats!r}")
    return [str(Path(archive_dir) / trial_relpath(base, config, gain, s, r)) for s in speeds for r in range(repeats)]


def find_cell_trials(archive_dir: str | os.PathLike, base: str, config: int, gain: str) -> list[str]:
    """The trial files of a cell already in an archive folder, sorted (empty if none).

    Used when a campaign is re-analysed without simulating: the trials are whatever the
    archive holds for the cell, whichever speeds and repeats it was run with.
    """
    folder = Path(archive_dir) / cell_dir(base, config, gain)
    if not folder.is_dir():
        return []
    return sorted(str(p) for p in folder.glob(f"v*/r*{TRIAL_SUFFIX}") if p.is_file() and not p.name.startswith("."))


def index_cells(archive_dir: str | os.PathLike) -> dict[tuple[str, int, str], list[str]]:
    """The trials of a finalized archive by cell, from its own ``index.csv``.

    ``{(base, configuration, gain): [trial path, ...]}``, each list speed-major as
    :func:`cell_trials` orders it. Re-analysing an archive takes its cells from here, so
    the workflow asks for what the archive holds, whatever campaign configuration made it.

    Raises
    ------
    FileNotFoundError
        The folder has no ``index.csv`` (not finalized).
    ValueError
        A row whose path is not the one its base, configuration, gain, speed and repeat
        give (named), or an index without trials.
    """
    index = Path(archive_dir) / "index.csv"
    if not index.is_file():
        raise FileNotFoundError(f"{archive_dir}: no index.csv (finalize it first: campaign archive finalize {archive_dir})")
    cells: dict[tuple[str, int, str], list[tuple[float, int, str]]] = {}
    with open(index, newline="", encoding="utf-8") as fh:
        for n, row in enumerate(csv.DictReader(fh), start=2):
            try:
                base, config, gain = row["base"], int(row["config"]), row["gain"]
                speed, repeat = float(row["speed"]), int(row["repeat"])
                expected = trial_relpath(base, config, gain, speed, repeat)
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"{index}, line {n}: unreadable row ({exc})") from None
            if row["path"] != expected:
                raise ValueError(f"{index}, line {n}: path {row['path']} contradicts its row "
                                 f"(base, config, gain, speed, repeat give {expected})")
            cells.setdefault((base, config, gain), []).append((speed, repeat, str(Path(archive_dir) / expected)))
    if not cells:
        raise ValueError(f"{index}: lists no trial")
    return {cell: [p for _, _, p in sorted(rows)] for cell, rows in sorted(cells.items())}


def package_file(*parts: str) -> Path:
    """A file of the project's ``config/`` folder as the package reads it (``$CAMPAIGN_CONFIG_DIR``
    overrides it, as in :func:`campaign.paper.config_dir`), without importing numpy."""
    env = os.environ.get("CAMPAIGN_CONFIG_DIR")
    folder = Path(env) if env else Path(__file__).resolve().parents[1] / "config"
    return folder.joinpath(*parts)


def gain_counts(gain: str, overrides: Mapping[str, Mapping[str, float]] | None = None) -> tuple[float, float, float]:
    """(P, D, I) controller counts of a gain set: the paper's Table 1 row with ``overrides``.

    Parameters
    ----------
    gain : {"zero", "low", "high"}
    overrides : mapping, optional
        ``{gain: {"P": ..., "D": ..., "I": ...}}``; any key may be left out.
    """
    from .paper import load_paper

    table = load_paper()["gains"]
    if gain not in table:
        raise ValueError(f"unknown gain set {gain!r}; expected one of {sorted(table)}")
    row = {k: float(table[gain][k]) for k in ("P", "D", "I")}
    for key, value in dict((overrides or {}).get(gain) or {}).items():
        if key not in row:
            raise ValueError(f"gain_counts.{gain}.{key}: unknown gain term (expected P, D or I)")
        value = float(value)
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"gain_counts.{gain}.{key} = {value!r} must be a finite count >= 0")
        row[key] = value
    return row["P"], row["D"], row["I"]


# ---------------------------------------------------------------------------------------
# logging and timing
# ---------------------------------------------------------------------------------------
class Timer:
    """Wall and CPU seconds spent per stage of a job (``with timer("simulate"): ...``)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    @contextlib.contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.seconds[stage] = self.seconds.get(stage, 0.0) + time.perf_counter() - t0
            self.cpu[stage] = self.cpu.get(stage, 0.0) + time.process_time() - c0

    @contextlib.contextmanager
    def imports(self) -> Iterator[None]:
        """The stage ``imports`` (a job's heavy modules), with the cyclic garbage collector paused.

        Importing numpy, scipy, xarray, pinocchio and matplotlib creates hundreds of
        thousands of objects that all stay alive; the collector's passes over them find
        nothing to free and cost about 10 % of the import time (0.05-0.15 s a job). It is
        switched back on (if it was on) when the imports are done.
        """
        import gc

        enabled = gc.isenabled()
        gc.disable()
        try:
            with self("imports"):
                yield
        finally:
            if enabled:
                gc.enable()


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
def job_log(path: str | os.PathLike | None, *, job: str = "job", exit_process: bool = False) -> Iterator[Timer]:
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
    timer = Timer()
    startup = _process_age()
    startup_cpu = time.process_time()  # CPU of this process so far: interpreter, preamble, this module
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
        record = {"job": job, "startup": round(startup, 4), **{k: round(v, 4) for k, v in timer.seconds.items()},
                  "total": round(total, 4),
                  "cpu": {"startup": round(startup_cpu, 4), **{k: round(v, 4) for k, v in timer.cpu.items()},
                          "children": round(_children_cpu(), 4),
                          "total": round(time.process_time() + _children_cpu(), 4)}}
        print(f"TIMING {json.dumps(record, sort_keys=True)}")
        if stream is not None:
            sys.stdout, sys.stderr = old
            stream.close()
    if exit_process:  # reached only when the job succeeded (an exception re-raises above)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


# ---------------------------------------------------------------------------------------
# simulation
# ---------------------------------------------------------------------------------------
def run_cells(cells: Iterable[Sequence[Any]], *, archive_dir: str | os.PathLike, speeds: Sequence[float],
              repeats: int, campaign_seed: int = 0, gain_overrides: Mapping | None = None,
              rig: str | os.PathLike | None = None, params: Mapping[str, Any] | None = None,
              expected: Iterable[str] | None = None, timer: Timer | None = None, threads: int = 1,
              progress: Callable[[int, int, str], None] | None = None) -> list[Path]:
    """Simulate every speed x repeat of sweep cells and write one trial file per trial.

    The trials are integrated together, in lock-step, by the batched rig
    (:func:`campaign.rig.batch.simulate_batch`: the same numbers as one trial at a time).

    Parameters
    ----------
    cells : iterable of (base, config, gain)
        The sweep cells, e.g. ``[("fixed", 1, "zero")]``.
    archive_dir : path-like
        The campaign's archive folder; trial ``t`` goes to ``archive_dir/<t.cell>.nc``.
    speeds : sequence of float
        Hammer speeds along n [m/s].
    repeats : int
        Trials per speed (repeat indices ``0 .. repeats-1``; each has its own seed).
    campaign_seed : int
        Seed the trials' seeds derive from (with the cell), see :func:`campaign.scene.make_scene`.
    gain_overrides : mapping, optional
        Overrides of the paper's gain counts, ``{gain: {"P": ...}}`` (:func:`gain_counts`).
    rig : path-like, optional
        Rig parameter file (default ``config/rig.yaml``).
    params : mapping, optional
        Dotted-key rig parameter overrides.
    expected : iterable of str, optional
        The trial files the caller (the workflow) declared; a scene whose path is not one of
        them, or a declared file no scene writes, raises before anything is simulated.
    timer : Timer, optional
        Receives the seconds spent in ``simulate`` and ``write``.
    threads : int
        OpenMP threads of the batched Pinocchio calls (one: jobs already run side by side).
    progress : callable, optional
        Called as ``progress(done, total, cell)`` as each trial finishes (``campaign sweep``
        draws its progress line from it).

    Returns
    -------
    list of pathlib.Path
        The trial files written, in the order simulated.

    Raises
    ------
    ValueError
        A bad cell, speed, repeat count or rig parameter (before any simulation), or a
        mismatch with ``expected``.
    campaign.errors.SimulationError
        One or more trials failed to integrate, each named with its cell and its message;
        every other trial of the batch is written (each is complete).
    """
    timer = timer if timer is not None else Timer()
    with timer.imports():
        from .archive import trial_path, write_trial
        from .checks import check_rig_params, check_speeds, pendulum_reach
        from .errors import SimulationError
        from .rig.batch import simulate_batch   # plain arrays: the job never imports xarray
        from .scene import make_scene
    # every speed within the pendulum's reach and distinct in its path, before any trial
    speeds = check_speeds(speeds, reach=pendulum_reach(check_rig_params(params, rig=rig)))
    cells = [(str(b), int(c), str(g)) for b, c, g in cells]
    plan = []
    for base, config, gain in cells:
        counts = gain_counts(gain, gain_overrides)
        for speed in speeds:
            for repeat in range(int(repeats)):
                scene = make_scene(base=base, config=config, gain=gain, speed=float(speed), repeat=repeat,
                                   gains_counts=counts, rig=rig, params=dict(params or {}),
                                   campaign_seed=int(campaign_seed))
                path = trial_path(archive_dir, scene)
                rel = trial_relpath(base, config, gain, float(speed), repeat)
                if path != Path(archive_dir) / rel:
                    raise ValueError(f"scene path {path} differs from the workflow's trial path {rel}: "
                                     "campaign.scene.Scene.cell and campaign.runner.trial_relpath disagree")
                plan.append((scene, path))
    if expected is not None:
        declared = {os.path.normpath(p) for p in expected}
        planned = {os.path.normpath(str(p)) for _, p in plan}
        extra, missing = sorted(planned - declared), sorted(declared - planned)
        if extra or missing:
            raise ValueError("the trials to simulate differ from the declared outputs: "
                             + (f"not declared {extra[:3]} " if extra else "")
                             + (f"never written {missing[:3]}" if missing else ""))
    n = len(plan)
    finished = [0]
    t_start = time.perf_counter()

    def done(i, _result):
        finished[0] += 1
        if progress is not None:
            progress(finished[0], n, plan[i][0].cell)

    with timer("simulate"):
        results = simulate_batch([scene for scene, _ in plan], threads=threads, on_done=done)
    per_trial = 1e3 * (time.perf_counter() - t_start) / max(n, 1)
    written, failed = [], []
    for i, ((scene, path), trial) in enumerate(zip(plan, results), 1):
        if isinstance(trial, SimulationError):
            failed.append(f"{scene.cell}: {trial}")
            print(f"[{i}/{n}] {scene.cell}: seed {scene.seed}, FAILED: {trial}", flush=True)
            continue
        t1 = time.perf_counter()
        with timer("write"):
            write_trial(trial, path)
        t2 = time.perf_counter()
        truth = trial["truth"].data_vars
        duration = 1e3 * float(truth["contact_end"].values - truth["contact_start"].values)
        print(f"[{i}/{n}] {scene.cell}: seed {scene.seed}, contact {duration:.1f} ms, peak "
              f"{float(truth['peak_force'].values):.1f} N; simulated {per_trial:.0f} ms (batch mean), written "
              f"{1e3 * (t2 - t1):.0f} ms -> {path}", flush=True)
        written.append(path)
    if failed:
        raise SimulationError(f"{len(failed)} of {n} trials failed (the other {n - len(failed)} are written): "
                              + "; ".join(failed))
    return written


def run_cell(base: str, config: int, gain: str, out_dir: str | os.PathLike, **kwargs: Any) -> list[Path]:
    """Simulate one sweep cell: :func:`run_cells` with ``cells=[(base, config, gain)]``."""
    return run_cells([(base, config, gain)], archive_dir=out_dir, **kwargs)


# ---------------------------------------------------------------------------------------
# identification
# ---------------------------------------------------------------------------------------
def _csv_value(value: Any) -> Any:
    """One identification field as a CSV cell: booleans 0/1, NaN empty, vectors space-separated."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (tuple, list)):
        return " ".join(repr(float(x)) for x in value)
    if isinstance(value, float) and not math.isfinite(value):
        return "" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def identify_trials(paths: Sequence[str | os.PathLike], out_csv: str | os.PathLike, *,
                    options: Mapping[str, Any] | None = None, timer: Timer | None = None) -> list[dict[str, Any]]:
    """Identify m* (eq 10) and e (eq 12) of trial files and write one CSV row per trial.

    Identification reads only each trial's ``measured`` group (:mod:`campaign.identify`).
    An excluded trial keeps its row, with ``excluded = 1`` and the reason; it never enters
    a fit or a table.

    Parameters
    ----------
    paths : sequence of path-like
        Trial files.
    out_csv : path-like
        The CSV to write (columns :data:`IDENTIFY_COLUMNS`; empty cells are NaN), written
        to a temporary file and renamed.
    options : mapping, optional
        Fields of :class:`campaign.identify.IdentifyOptions`.
    timer : Timer, optional
        Receives the seconds spent in ``identify``.

    Returns
    -------
    list of dict
        The rows written.

    Raises
    ------
    ValueError
        An unknown identification option (named).
    campaign.errors.TrialFileError
        A file is not a trial or lacks a channel (named).
    """
    import dataclasses

    timer = timer if timer is not None else Timer()
    with timer.imports():
        from .errors import InputError, TrialFileError
        from .checks import check_identify_options
        from .identify import identify_trial, load_trial
        from .robot import load_robot
    opts = check_identify_options(options)
    robots: dict[str, Any] = {}
    rows = []
    columns: list[str] | None = None
    n = len(paths)
    for i, path in enumerate(paths, 1):
        t0 = time.perf_counter()
        with timer("identify"):
            measured, attrs = load_trial(path, arrays=True)   # plain arrays: no xarray in the job
            name = str(attrs.get("robot") or measured.attrs.get("robot") or "")
            if not name:
                raise TrialFileError(f"{path}: no 'robot' attribute in the trial")
            wrong = misfiled(path, attrs)   # a trial of another cell would bias this cell's m*
            if wrong:
                raise TrialFileError(wrong)
            if name not in robots:
                robots[name] = load_robot(name)
            try:
                res = identify_trial(measured, robot=robots[name], meta={**attrs, "path": str(path)},
                                     options=opts, where=str(path))
            except InputError as exc:
                raise TrialFileError(str(exc)) from None
        if columns is None:
            names = [f.name for f in dataclasses.fields(res)]
            columns = list(IDENTIFY_COLUMNS) + [n for n in names if n not in IDENTIFY_COLUMNS]
        row = {k: _csv_value(getattr(res, k)) for k in columns}
        row["path"] = str(path)
        rows.append(row)
        state = f"excluded: {res.reason}" if res.excluded else f"m* = {res.m_eff:.3f} kg, e = {res.e:.3f}"
        print(f"[{i}/{n}] {path}: {state} ({1e3 * (time.perf_counter() - t0):.0f} ms)", flush=True)
    out = Path(out_csv)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            writer = csv.DictWriter(fh, fieldnames=columns or list(IDENTIFY_COLUMNS), lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return rows


def _parse_extra(value: str) -> Any:
    """A column this module does not know: a number, several numbers, or text."""
    try:
        return float(value) if value != "" else float("nan")
    except ValueError:
        pass
    try:
        return tuple(float(x) for x in value.split())
    except ValueError:
        return value


def read_identification(paths: Iterable[str | os.PathLike]) -> list[dict[str, Any]]:
    """Read identification CSVs (:func:`identify_trials`) back as records.

    Returns
    -------
    list of dict
        One record per trial, as :meth:`campaign.identify.TrialIdentification.to_dict`
        gives them (what :mod:`campaign.tables` takes), except that a number that was not
        computable is NaN: numbers as float, counts and cell indices as int, ``excluded`` as
        bool, vectors (``q_cmd``, ``impact_direction``, ``base_inertia``) as tuples of float.

    Raises
    ------
    ValueError
        A file is not an identification table (a required column is missing), named.
    """
    rows = []
    for path in paths:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            missing = [c for c in IDENTIFY_COLUMNS if c not in (reader.fieldnames or ())]
            if missing:
                raise ValueError(f"{path}: not an identification table (no column {', '.join(missing)})")
            for line, row in enumerate(reader, 2):
                out: dict[str, Any] = {}
                try:
                    for key, value in row.items():
                        if key in _TEXT_COLUMNS:
                            out[key] = value
                        elif key in _VECTOR_COLUMNS:
                            out[key] = tuple(float(x) for x in value.split())
                        elif key in _INT_COLUMNS:
                            out[key] = int(value)
                        elif key == "excluded":
                            out[key] = bool(int(value))
                        elif key in IDENTIFY_COLUMNS:
                            out[key] = float(value) if value != "" else float("nan")
                        else:  # a field identification gained after this reader: keep its meaning
                            out[key] = _parse_extra(value)
                except ValueError as exc:
                    raise ValueError(f"{path}, line {line}: bad value ({exc})") from None
                rows.append(out)
    return rows


# ---------------------------------------------------------------------------------------
# Virtual Rotor Inertia and the tables
# ---------------------------------------------------------------------------------------
def write_atomic(path: str | os.PathLike, data: str | bytes) -> Path:
    """Write ``data`` to a temporary file beside ``path`` and rename it into place."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        if isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data, encoding="utf-8")
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out


def fit_lambda(ident_tables: Iterable[str | os.PathLike], out_json: str | os.PathLike, *,
               gain_class: str, gains: Sequence[str],
               base: str = "fixed", options: Mapping[str, Any] | None = None, seed: int = 0,
               timer: Timer | None = None) -> dict[str, Any]:
    """Fit lambda (eq 11, 15) to the identified effective masses of one gain class.

    The fit is :class:`campaign.fit.LambdaFit` over the class's usable trials of ``base``
    (every configuration, speed and repeat), with the trials' robot and impact direction,
    as :func:`campaign.tables.fit_gain_classes` does for all classes at once.

    Parameters
    ----------
    ident_tables : iterable of path-like
        Identification CSVs (:func:`identify_trials`); rows of other bases or gains, and
        excluded trials, are left out.
    out_json : path-like
        :meth:`campaign.fit.LambdaFit.summary` with the gain class, the gains pooled and
        the trials used and excluded (written atomically); all that Tables 3-4 read back
        (:func:`load_fits`).
    gain_class : str
        Name of the class (``paper.yaml`` ``gain_classes``: ``zero_low``, ``high``).
    gains : sequence of str
        The gain sets pooled in the class.
    base : str
        Base whose trials are fitted (the paper: fixed).
    options : mapping, optional
        :class:`campaign.fit.LambdaFit` settings (``structure``, ``n_bootstrap``, ``ci``,
        ``min_sensitivity``, ``max_relative_ci``).
    seed : int
        Seed of the bootstrap (the workflow passes ``campaign_seed``).
    timer : Timer, optional
        Receives the seconds spent in ``imports`` and ``fit``.

    Returns
    -------
    dict
        What was written to ``out_json``.

    Raises
    ------
    ValueError
        No usable trial, trials of several robots, or an unknown fit
        option (named).
    """
    import warnings

    timer = timer if timer is not None else Timer()
    with timer.imports():
        import numpy as np

        from .fit import IdentifiabilityWarning, LambdaFit
        from .robot import load_robot

    allowed = {"structure", "n_bootstrap", "ci", "min_sensitivity", "max_relative_ci"}
    unknown = sorted(set(options or {}) - allowed)
    if unknown:
        raise ValueError(f"fit: unknown option(s) {unknown}; known: {sorted(allowed)}")
    rows = [r for r in read_identification(ident_tables) if r["base"] == base and r["gain"] in gains]
    used = [r for r in rows if not r["excluded"] and math.isfinite(r["m_eff"]) and r["m_eff"] > 0]
    if not used:
        raise ValueError(f"fit {gain_class}: no usable {base}-base trial with gains {list(gains)} "
                         f"({len(rows)} found, all excluded)")
    robots = sorted({r["robot"] for r in used})
    if len(robots) != 1:
        raise ValueError(f"fit {gain_class}: the trials mix robots {robots}")
    # each trial is fitted along its own impact direction (a designed campaign strikes
    # poses from several horizontal directions)
    directions = np.array([r["impact_direction"] for r in used], float)
    with timer("fit"), warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)  # the findings are in the summary
        est = LambdaFit(load_robot(robots[0]), direction=directions[0], random_state=int(seed),
                        **dict(options or {}))
        est.fit(np.array([r["q_cmd"] for r in used]), np.array([r["m_eff"] for r in used]), directions=directions)
    result = {
        "gain_class": gain_class, "gains": list(gains), "base": base, "robot": robots[0], **est.summary(),
        "n_excluded": len(rows) - len(used), "configs": sorted({int(r["config"]) for r in used}),
        "units": {"lambda": "kg m^2", "lambda_ci": "kg m^2"},
    }
    write_atomic(out_json, json.dumps(result, indent=2, sort_keys=True) + "\n")
    lam = ", ".join(f"{x:.4g}" for x in np.ravel(est.lambda_))
    print(f"fit {gain_class} ({', '.join(gains)}): lambda = [{lam}] kg m^2 from {len(used)} trials "
          f"({len(rows) - len(used)} excluded); condition number {est.condition_number_:.3g}")
    for warning in est.warnings_:
        print(f"warning: {warning}")
    return result


def load_fits(results: Mapping[str, str | os.PathLike]) -> dict[str, Any]:
    """The fitted :class:`campaign.fit.LambdaFit` of each gain class, read back from
    :func:`fit_lambda`'s JSON (:meth:`campaign.fit.LambdaFit.from_summary`)."""
    from .errors import InputError
    from .fit import LambdaFit

    out = {}
    for gain_class, path in results.items():
        with open(path, encoding="utf-8") as fh:
            try:
                out[gain_class] = LambdaFit.from_summary(json.load(fh))
            except (ValueError, InputError) as exc:
                raise InputError(f"{path}: {exc}") from None
    return out


def make_table(name: str, out_csv: str | os.PathLike, out_md: str | os.PathLike, *,
               ident_tables: Iterable[str | os.PathLike] = (), fits: Mapping[str, str | os.PathLike] | None = None,
               source: str | os.PathLike | None = None, out_html: str | os.PathLike | None = None,
               structure: str | None = None, timer: Timer | None = None):
    """Write Table 2, 3, 4 or Table 4 under both structures (:mod:`campaign.tables`) as CSV,
    Markdown and HTML, each atomically.

    Parameters
    ----------
    name : {"table2", "table3", "table4", "table4_structures", "plan_rig_check"}
    out_csv, out_md : path-like
    out_html : path-like, optional
        The Markdown as a standalone HTML page (:mod:`campaign.htmlpage`), which
        Snakemake's report shows inline.
    ident_tables : iterable of path-like
        Identification CSVs: fixed-base ones for Table 2, flexible-base ones for Table 4.
    fits : mapping, optional
        ``{gain class: JSON of fit_lambda}`` for Tables 3 and 4, in the paper's order.
    source : path-like, optional
        For ``table4_structures``: the CSV ``benchmarks/space_structure.py`` writes; for
        ``plan_rig_check``: the CSV ``benchmarks/plan_rig_check.py`` writes.
    structure : str, optional
        For ``table4``: the structure its flexible-base trials emulate (a note names it).
    timer : Timer, optional

    Returns
    -------
    campaign.tables.Table
    """
    timer = timer if timer is not None else Timer()
    with timer.imports():
        from . import tables
    with timer("table"):
        records = read_identification(ident_tables)
        loaded = load_fits(fits or {})
        if name == "table2":
            table = tables.table2(records)
        elif name == "table3":
            table = tables.table3(loaded)
        elif name == "table4":
            table = tables.table4(records, loaded, structure=structure)
        elif name == "table4_structures":
            table = tables.structures_table(source)
        elif name == "plan_rig_check":
            table = tables.rig_check_table(source)
        else:
            raise ValueError(f"unknown table {name!r}; expected table2, table3, table4, table4_structures or "
                             "plan_rig_check")
        write_atomic(out_csv, table.to_csv())
        write_atomic(out_md, table.to_markdown())
        if out_html is not None:
            from .htmlpage import markdown_page

            write_atomic(out_html, markdown_page(table.to_markdown(), title=table.title))
    print(table.to_markdown())
    return table
