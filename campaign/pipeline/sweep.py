"""The workflow's simulation job: every speed x repeat of sweep cells, one trial file each.

:func:`run_cells` simulates the trials of one or more sweep cells (base x configuration x
gain set) with the lean trial loop, one after another, and writes one file per trial with
:func:`campaign.archive.write_trial` (atomic), printing one progress line per trial; given
a job manifest, it lists there what it wrote with the digests taken as it wrote
(:mod:`campaign.archive.jobs`). :func:`run_trial` simulates one trial of a cell.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..archive import intact_trials, read_record, trial_path, write_job_manifest, write_trial, write_trial_entry
from ..core.errors import InputError, SimulationError, TrialFileError
from ..core.timing import Timer
from ..core.tolerance import worst
from ..model.paper import gain_counts
from ..plan.stroke import check_scene_stroke
from ..rig.batch import simulate_batch
from ..scene.checks import check_rig_params, check_seed, check_speeds, pendulum_reach
from ..scene.description import Scene, make_scene

__all__ = ["run_cells", "run_cell", "run_trial"]


def run_cells(cells: Iterable[Sequence[Any]], *, archive_dir: str | os.PathLike, speeds: Sequence[float],
              repeats: int, campaign_seed: int = 0, gain_overrides: Mapping | None = None,
              rig: str | os.PathLike | None = None, params: Mapping[str, Any] | None = None,
              timer: Timer | None = None,
              progress: Callable[[int, int, str], None] | None = None,
              job_manifest: str | os.PathLike | None = None, job: str = "simulate",
              repeat_indices: Sequence[int] | None = None, keep_others: str | None = None) -> list[Path]:
    """Simulate every speed x repeat of sweep cells and write one trial file per trial.

    Every scene is built and checked first, then the trials are integrated one after another
    (:func:`campaign.rig.batch.simulate_batch`: the numbers ``campaign trial`` gives each).

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
        Seed the trials' seeds derive from (with the cell), see :func:`campaign.scene.description.make_scene`.
    gain_overrides : mapping, optional
        Overrides of the paper's gain counts, ``{gain: {"P": ...}}`` (:func:`gain_counts`).
    rig : path-like, optional
        Rig parameter file (default ``config/rig.yaml``).
    params : mapping, optional
        Dotted-key rig parameter overrides.
    timer : Timer, optional
        Receives the seconds spent in ``simulate`` and ``write``.
    progress : callable, optional
        Called as ``progress(done, total, cell)`` as each trial finishes (``campaign sweep``
        draws its progress line from it).
    job_manifest : path-like, optional
        Write the job manifest of :mod:`campaign.archive.jobs` here, once every trial is
        written: each trial's path, file sha256, content digests and index row. A trial
        file already there that holds the same trial (checked from scratch first) is
        kept as it is, so a rerun that reproduces the campaign changes no file.
    job : str
        The job's name in its manifest.
    repeat_indices : sequence of int, optional
        Only these repeat indices (each ``< repeats``), e.g. ``[1]`` for one trial
        (:func:`run_trial`); default all.
    keep_others : str, optional
        The option that named ``archive_dir`` (``"--out"``): a file at a trial's path that is
        not that trial (another seed or rig, or no trial) is then refused before any
        simulation, not replaced (the workflow's jobs own their paths and replace it).

    Returns
    -------
    list of pathlib.Path
        The trial files written, in the order simulated.

    Raises
    ------
    ValueError
        A bad cell, speed, repeat count, campaign seed (an integer in [0, 2**63 - 1]) or rig
        parameter (before any simulation).
    campaign.core.errors.SimulationError
        One or more trials failed to integrate, each named with its cell and its message;
        every other trial of the batch is written (each is complete).
    """
    timer = timer if timer is not None else Timer()
    check_seed(campaign_seed, key="campaign_seed")
    # every speed within the pendulum's reach and distinct in its path, before any trial
    speeds = check_speeds(speeds, reach=pendulum_reach(check_rig_params(params, rig=rig)))
    plan = _plan_trials(cells, archive_dir=archive_dir, speeds=speeds, repeats=repeats, campaign_seed=campaign_seed,
                        gain_overrides=gain_overrides, rig=rig, params=params, repeat_indices=repeat_indices)
    if keep_others is not None:
        _check_others(plan, archive_dir=Path(archive_dir), option=keep_others)
    n = len(plan)
    finished = [0]
    t_start = time.perf_counter()

    def done(i, _result):
        finished[0] += 1
        if progress is not None:
            progress(finished[0], n, plan[i][0].cell)

    with timer("simulate"):
        results = simulate_batch([scene for scene, _ in plan], on_done=done)
    per_trial = 1e3 * (time.perf_counter() - t_start) / max(n, 1)
    if job_manifest is None:
        return _write_trials(plan, results, timer=timer, per_trial_ms=per_trial)
    with timer("write"):
        # files a previous run left: kept where they hold the same trial (checked from scratch, in a child)
        present = [path for _, path in plan if path.is_file()]
        intact = {p for p, ok in zip(present, intact_trials(present), strict=True) if ok}
    entries: list = []

    def write(trial, path):
        entries.append(write_trial_entry(trial, path, campaign_dir=archive_dir, keep_same=path in intact))
        return _what_was_done(entries[-1])

    written = _write_trials(plan, results, timer=timer, per_trial_ms=per_trial, write=write)
    with timer("write"):
        write_job_manifest(job_manifest, entries, job=job)
    return written


def _plan_trials(cells, *, archive_dir, speeds, repeats, campaign_seed, gain_overrides, rig,
                 params, repeat_indices=None) -> list[tuple[Scene, Path]]:
    """Every trial's scene and file path, cell by cell, speed by speed, repeat by repeat; each
    flexible-base scene's stroke checked (:func:`campaign.plan.stroke.check_scene_stroke`)
    before any trial is simulated."""
    cells = [(str(b), int(c), str(g)) for b, c, g in cells]
    indices = range(int(repeats)) if repeat_indices is None else [int(r) for r in repeat_indices]
    wrong = [r for r in indices if not 0 <= r < int(repeats)]
    if wrong:
        raise ValueError(f"repeat {wrong[0]} is not one of the {int(repeats)} repeat(s) 0..{int(repeats) - 1}")
    plan = []
    for base, config, gain in cells:
        counts = gain_counts(gain, gain_overrides)
        for speed in speeds:
            for repeat in indices:
                scene = make_scene(base=base, config=config, gain=gain, speed=float(speed), repeat=repeat,
                                   gains_counts=counts, rig=rig, params=dict(params or {}),
                                   campaign_seed=int(campaign_seed))
                check_scene_stroke(scene)
                plan.append((scene, trial_path(archive_dir, scene)))
    return plan


def _check_others(plan, *, archive_dir: Path, option: str) -> None:
    """Each file already at a planned trial's path holds that trial (the same scene: its
    cell, seed and rig), else InputError naming ``option``, the file and both seeds."""
    for scene, path in plan:
        if not path.exists():
            continue
        try:
            held = read_record(archive_dir, path)
        except TrialFileError:
            raise InputError(f"{option} {archive_dir}: {path} is there and is not a readable trial file; "
                             "a sweep replaces only a file of the same trial (remove it, or choose another folder)") \
                from None
        if held.scene_sha256 != scene.sha256:
            what = f"seed {held.seed}, this sweep's {scene.seed}" if held.seed != scene.seed else "another rig"
            raise InputError(f"{option} {archive_dir}: {path} holds another trial ({what}); a sweep does not "
                             "replace another trial: write to another folder or remove it")


def _write_trials(plan, results, *, timer: Timer, per_trial_ms: float,
                  write: Callable[[Any, Path], str] | None = None) -> list[Path]:
    """Write each simulated trial to its path with one progress line; SimulationError naming
    every trial that failed, after the others are written. ``write(trial, path)`` writes one
    and says what it did (default :func:`campaign.archive.write_trial`: "written")."""
    n = len(plan)
    written, failed = [], []
    for i, ((scene, path), trial) in enumerate(zip(plan, results, strict=True), 1):
        if isinstance(trial, SimulationError):
            failed.append(f"{scene.cell}: {trial}")
            print(f"[{i}/{n}] {scene.cell}: seed {scene.seed}, FAILED: {trial}", flush=True)
            continue
        t1 = time.perf_counter()
        with timer("write"):
            done = (write or _write_plain)(trial, path)
        t2 = time.perf_counter()
        truth = trial["truth"].data_vars
        duration = 1e3 * float(truth["contact_end"].values - truth["contact_start"].values)
        print(f"[{i}/{n}] {scene.cell}: seed {scene.seed}, contact {duration:.1f} ms, peak "
              f"{float(truth['peak_force'].values):.1f} N; simulated {per_trial_ms:.0f} ms (batch mean), {done} "
              f"{1e3 * (t2 - t1):.0f} ms -> {path}", flush=True)
        written.append(path)
    if failed:
        raise SimulationError(f"{len(failed)} of {n} trials failed (the other {n - len(failed)} are written): "
                              + "; ".join(failed))
    return written


def _what_was_done(entry) -> str:
    """A progress line's account of one trial file: kept (with the largest difference of each
    group when the digests differed), written, or replaced naming the worst difference."""
    if not entry.compared:
        return "kept (same trial)" if entry.kept else "written"
    if entry.kept:
        per_group = {g: worst(d for d in entry.compared if d.name.startswith(f"{g}/")) for g in ("measured", "truth")}
        flips = [f"{d.flips} in {d.name}" for d in entry.compared if d.flips]
        return "kept (same trial) [largest difference: " + ", ".join(
            f"{d.relative:.2g} of its scale in {d.name}" if d.largest else f"none in {g}"
            for g, d in per_group.items()) + (f"; one-step flips: {', '.join(flips)}" if flips else "") + "]"
    return f"written: the file there held another trial ({worst(entry.compared)})"


def _write_plain(trial, path: Path) -> str:
    write_trial(trial, path)
    return "written"


def run_cell(base: str, config: int, gain: str, out_dir: str | os.PathLike, **kwargs: Any) -> list[Path]:
    """Simulate one sweep cell: :func:`run_cells` with ``cells=[(base, config, gain)]``."""
    return run_cells([(base, config, gain)], archive_dir=out_dir, **kwargs)


def run_trial(base: str, config: int, gain: str, speed: float, repeat: int, *, archive_dir: str | os.PathLike,
              repeats: int, **kwargs: Any) -> Path:
    """Simulate one trial of a sweep cell, the same one (same seed, same numbers) its sweep's
    job writes: :func:`run_cells` with one speed and one repeat index. ``repeats`` is the
    sweep's (a repeat index must be below it); ``kwargs`` as :func:`run_cells`."""
    (path,) = run_cells([(base, config, gain)], archive_dir=archive_dir, speeds=[speed], repeats=repeats,
                        repeat_indices=[repeat], **kwargs)
    return path
