"""Benchmarks of the simulated VES-II: work-precision, per-trial cost, stress (issue 8).

Library code behind ``benchmarks/work_precision.py``, ``benchmarks/stress.py`` and
``campaign bench``; nothing here is used by the campaign itself.

Work-precision (:func:`work_precision`)
    For representative scenes, every integration setting the rig supports
    (``substeps_contact`` x ``substeps_free`` of its event-located RK4, see
    :mod:`campaign.rig.integrate`), a uniform 0.1 ms step of the same integrator, and a
    straightforward fixed-step RK4 (:func:`naive_rk4`, no event location, no analytic
    swing, fixed horizon) are timed (median wall time per trial, settings interleaved
    round-robin so a load change on the shared machine hits all of them alike) and compared
    with a converged reference (the same scene at 32x the default substeps in and out of
    contact) in (a) the identified m* and e, (b) the true post-impact velocities, (c) the
    recorded channels (max error over the samples relative to the channel's peak-to-peak
    excursion, measured and truth groups separately).

Per-trial cost (:func:`trial_cost`)
    Median simulation time per trial at the default setting and, separately, the time to
    write its file (:func:`campaign.archive.write_trial`), beside the naive baseline in the
    same run.

Stress (:func:`stress_cases`, :func:`run_stress`)
    Corners of the input space. Every case either passes the invariants of
    :func:`check_invariants` or is refused before simulating (``InputError``) with a
    message naming the cause. A ``SimulationError`` after work started is a reported
    blow-up (no file written) and counts against the suite, as does anything else.

Closed-form stress (:func:`closed_form_stress`)
    Ex-IIT (eq 7, 11) towards the stretched singularity: finite or ``inf``, never NaN or
    garbage; the conditioning of eq 11; the lambda fit on ill-conditioned designs.
"""

from __future__ import annotations

import dataclasses
import datetime
import gc
import math
import os
import platform
import statistics
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError, SimulationError

__all__ = [
    "naive_rk4", "naive_trial", "WPScene", "Setting", "wp_scenes", "wp_settings", "work_precision",
    "pareto_front", "format_wp_table", "plot_work_precision", "trial_cost", "format_cost",
    "StressCase", "StressResult", "stress_cases", "run_case", "run_stress", "check_invariants",
    "format_stress", "closed_form_stress", "format_closed_form", "write_section", "machine_line",
    "truth_m_impulse", "write_probe",
]

#: per-trial simulation time targets of the rig issues (3 and 4) [s]
TARGET_FIXED = 0.025
TARGET_FLEXIBLE = 0.150
TARGET_WRITE = 0.050
#: the naive baseline's time on the machine the rig issue's targets were set on ("about
#: 350 ms", issue 3) [s]; printed beside the rig's times as the issue asks, but not used to
#: scale them: our naive RK4 (:func:`naive_rk4`) does more per step than the issue's
#: unpublished one (a FrictionState and the contact kinematics at every stage) and takes
#: 2-2.6x that here, while the issue's write references below take 0.5-1.4x theirs
BASELINE_AT_TARGETS = 0.350
#: issue 3's own reference costs on the machine its targets were set on [s]: one NetCDF4
#: group of a few channels written through xarray/h5netcdf ("about 35 ms whatever its
#: size") and the same arrays through plain h5py ("about 3 ms"). Fixed library work that
#: :func:`write_probe` repeats exactly, so ``probe / reference`` says how this machine, at
#: this minute, compares with that one; the per-trial and campaign times are also shown
#: scaled by the xarray figure (the Python-bound one, like the rig)
XARRAY_WRITE_AT_TARGETS = 0.035
H5PY_WRITE_AT_TARGETS = 0.003
#: accuracy target of issue 8 for m* and e at the default setting (relative)
TARGET_REL_ERR = 1e-3
#: the reference is the same scene at this multiple of the default substeps (in and out of contact)
REF_FACTOR = 32
#: relative error shown (and plotted) for a setting identical to the reference
ERR_FLOOR = 1e-16


# ---------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------
def machine_line() -> str:
    """One line naming the machine, its load and the library versions."""
    from importlib.metadata import version

    from . import __version__
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    libs = ", ".join(f"{name} {version(dist)}" for name, dist in
                     (("numpy", "numpy"), ("pin", "pin"), ("xarray", "xarray")))
    return (f"Machine: {platform.machine()}, {os.cpu_count()} CPUs shared with other jobs, load average "
            f"{load:.1f} at the end of the run; Python {platform.python_version()}, {libs}, campaign {__version__}; "
            f"{datetime.date.today().isoformat()}.")


def _rel(a: float, b: float) -> float:
    """|a - b| / |b| (absolute when b == 0; nan when either is not finite)."""
    a, b = float(a), float(b)
    if not (math.isfinite(a) and math.isfinite(b)):
        return float("nan")
    return abs(a - b) / abs(b) if b != 0 else abs(a - b)


def _timed(fn: Callable[[], Any]) -> tuple[Any, float, float]:
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
    tmp = readme.with_name(f".{readme.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, readme)
    return readme


def _md(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out)


def _e(x: float) -> str:
    """Error in short scientific notation ('0' for exact agreement, 'nan' when undefined)."""
    if x is None or not math.isfinite(x):
        return "nan"
    return "0" if x == 0 else f"{x:.1e}"


# ---------------------------------------------------------------------------------------
# the naive baseline: a straightforward fixed-step RK4
# ---------------------------------------------------------------------------------------
def naive_rk4(scene, *, step: float = 1e-4, duration: float | None = None):
    """A straightforward fixed-step RK4 of a fixed-base trial, the baseline of issues 3 and 8.

    What "straightforward" means here (everything the rig's integrator avoids):

    - one step size ``step`` (0.1 ms) from ``t = 0`` to ``duration`` (default: the trial's
      pre-contact window + ``trial.min_post_contact``, 0.5 s for the default scene): the
      swing before the touch is integrated, not taken from its analytic solution, and the
      trial does not stop when the arm has settled;
    - Python-side Pinocchio calls through the same right-hand side as the rig
      (:meth:`FixedBasePlant.rhs`: ``pin.aba`` plus the contact kinematics at every stage);
    - no event location: the contact force is evaluated wherever the penetration is
      positive; the contact edges, post-impact velocities and the hammer catch are taken
      at the first step end past them;
    - Coulomb friction with the sign of each joint's velocity at the step start (no stick
      phase; a joint at rest chatters around zero velocity instead of sticking);
    - the servo updates at the step ends that fall on its ticks.

    Returns
    -------
    (rig, Trajectory)
        The assembled rig (:func:`campaign.rig.build`) and a
        :class:`campaign.rig.integrate.Trajectory` that :func:`campaign.rig.simulate.record`
        turns into the trial's channels (integration starts at ``t_contact = 0``).
    """
    from .rig.integrate import Trajectory
    from .rig.plant import FrictionState
    from .rig.simulate import build

    if scene.base != "fixed":
        raise InputError("the naive RK4 baseline is defined for fixed-base scenes only")
    rig = build(scene)
    plant, pid = rig.plant, rig.pid
    nv = plant.nv
    iv, ith, ithd, iP = plant.i_v, plant.i_th, plant.i_thd, plant.i_P
    arm_q = getattr(plant, "arm_q", slice(0, nv))
    T = rig.servo_period
    speed = float(scene.speed)
    min_post = float(getattr(rig, "min_post", scene.p("trial.min_post_contact")))
    if duration is None:
        duration = rig.t_contact + min_post
    n_steps = int(round(duration / step))
    per_tick = T / step
    catch_delay = float(scene.p("pendulum.catch_delay"))
    sticky = np.asarray(plant.sticky, dtype=bool)
    r = plant.pend.radius

    x = np.zeros(plant.size)
    x[:nv] = plant.q0
    th, thd = plant.pend.swing(np.array([-rig.t_contact]), speed)
    x[ith], x[ithd] = float(th[0]), float(thd[0])
    x0 = x.copy()
    all_free = np.ones(nv, dtype=int)
    tau = plant.servo(pid.update(x[arm_q]))
    tau_static = tau.copy()
    servo_t, servo_tau = [0.0], [tau.copy()]
    rhs = plant.rhs
    caught = False
    n_rhs = 0
    ts = np.empty(n_steps + 1)
    xs = np.empty((n_steps + 1, plant.size))
    xds = np.empty((n_steps + 1, plant.size))
    ts[0], xs[0] = 0.0, x
    contact_on = False
    contacts: list[list] = []
    post: dict[str, float] = {}
    pre_vb = speed
    t_catch = math.inf
    next_tick = 1
    for i in range(n_steps):
        t = i * step
        # Coulomb friction by the sign of each joint's velocity (none at rest), no stick phase
        fs = FrictionState(all_free, plant.coulomb(np.where(sticky, np.sign(x[iv]), 1.0).astype(int)), iv.start)

        def f(xx, tt):
            return rhs(xx, tau, fs, speed, caught, tt)

        k1 = f(x, t)
        k2 = f(x + 0.5 * step * k1, t + 0.5 * step)
        k3 = f(x + 0.5 * step * k2, t + 0.5 * step)
        k4 = f(x + step * k3, t + step)
        n_rhs += 4
        xds[i] = k1
        x = x + (step / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        t = (i + 1) * step
        if not np.all(np.isfinite(x)):
            raise SimulationError(f"the naive RK4 blew up at t = {t:.6g} s")
        # contact bookkeeping at the step end (no event location)
        delta, ddelta, Jn = plant.gap(x)
        if delta > 0 and not contact_on:
            contact_on = True
            contacts.append([t, None, speed])
        elif delta <= 0 and contact_on:
            contact_on = False
            contacts[-1][1] = t
            if not post:
                post = {"v_a": float(Jn @ x[iv]), "v_b": r * math.cos(x[ith]) * x[ithd], "P": float(x[iP])}
                t_catch = t + catch_delay
        if not contacts:
            pre_vb = r * math.cos(x[ith]) * x[ithd]
        if post and not caught and (t >= t_catch or (x[ithd] >= 0 > xs[i][ithd])):
            caught = True
            x[ithd] = 0.0
        ts[i + 1], xs[i + 1] = t, x
        # servo tick at this step end?
        if (i + 1) >= next_tick * per_tick - 1e-9:
            tau = plant.servo(pid.update(x[arm_q]))
            servo_t.append(t)
            servo_tau.append(tau.copy())
            next_tick += 1
    xds[n_steps] = rhs(x, tau, FrictionState(all_free, plant.coulomb(np.where(sticky, np.sign(x[iv]), 1.0).astype(int)),
                                             iv.start), speed, caught, ts[n_steps])
    n_rhs += 1
    if not contacts or contacts[0][1] is None:
        raise SimulationError("naive RK4: the contact had not ended by the end of the trial")
    values = dict(
        t=ts, x=xs, xd=xds, servo_t=np.asarray(servo_t), servo_tau=np.asarray(servo_tau), t_contact=0.0,
        contacts=[tuple(c) for c in contacts], v_a_pre=0.0, v_b_pre=pre_vb, v_a_post=post["v_a"],
        v_b_post=post["v_b"], impulse=post["P"], t_end=float(ts[-1]), t_static=None, settled=False,
        n_steps=n_steps, n_rhs=n_rhs, n_events=0, tau_static=tau_static, x0=x0,
    )
    fields = {f.name for f in dataclasses.fields(Trajectory)}
    missing = fields - set(values)
    if missing:  # the rig's Trajectory grew: fill what a fixed base does not need
        values.update({k: None for k in missing})
    return rig, Trajectory(**{k: v for k, v in values.items() if k in fields})


def naive_trial(scene, *, step: float = 1e-4, duration: float | None = None):
    """The naive baseline's trial as a DataTree (same sensors and layout as :func:`simulate`)."""
    from .rig.simulate import record

    rig, traj = naive_rk4(scene, step=step, duration=duration)
    tree = record(rig, traj)
    tree.attrs["integration_steps"] = int(traj.n_steps)
    tree.attrs["integration_rhs_evaluations"] = int(traj.n_rhs)
    return tree


# ---------------------------------------------------------------------------------------
# work-precision
# ---------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class WPScene:
    """A representative scene of the work-precision benchmark."""

    label: str
    kwargs: dict

    def make(self):
        from .scene import make_scene
        return make_scene(**self.kwargs)


@dataclasses.dataclass(frozen=True)
class Setting:
    """One integration setting: the rig's RK4 with these substeps, or the naive baseline."""

    label: str
    substeps_contact: int | None = None
    substeps_free: int | None = None
    naive: bool = False
    default: bool = False

    def run(self, scene):
        from .rig import simulate
        if self.naive:
            return naive_trial(scene)
        if self.default:
            return simulate(scene)
        return simulate(scene, integration={"substeps_contact": self.substeps_contact,
                                            "substeps_free": self.substeps_free})


def wp_scenes(*, quick: bool = False, flexible: bool = True) -> list[WPScene]:
    """Representative scenes: configurations 2 (nearly stretched) and 3 (folded), ideal and
    default, Zero and High gains, fixed base and (when the rig accepts it) flexible base."""
    out = [
        WPScene("fixed ideal c2", dict(base="fixed", config=2, scene="ideal", speed=1.5)),
        WPScene("fixed default c2 high", dict(base="fixed", config=2, gain="high", speed=1.5)),
    ]
    if not quick:
        out += [
            WPScene("fixed ideal c3", dict(base="fixed", config=3, scene="ideal", speed=1.5)),
            WPScene("fixed default c2 zero", dict(base="fixed", config=2, gain="zero", speed=1.5)),
            WPScene("fixed default c3 zero", dict(base="fixed", config=3, gain="zero", speed=1.5)),
            WPScene("fixed default c3 high", dict(base="fixed", config=3, gain="high", speed=1.5)),
        ]
    if flexible:
        out += [
            WPScene("flexible loop c2 high", dict(base="flexible", config=2, gain="high", speed=1.5)),
            WPScene("flexible ideal-coupling c2 high",
                    dict(base="flexible", config=2, gain="high", speed=1.5, params={"ves.mode": "ideal"})),
        ]
        if not quick:
            out += [
                WPScene("flexible loop c3 low", dict(base="flexible", config=3, gain="low", speed=1.5)),
                WPScene("flexible ideal scene c2",
                        dict(base="flexible", config=2, scene="ideal", speed=1.5, params={"ves.mode": "ideal"})),
            ]
    return out


def rig_available(scene) -> tuple[bool, str]:
    """Can the rig build this scene? (False, reason) while a base is not integrated yet."""
    from .rig import build
    try:
        build(scene)
    except (InputError, NotImplementedError, ImportError, AttributeError) as exc:
        return False, f"{type(exc).__name__}: {exc}"
    return True, ""


def wp_settings(default_contact: int, default_free: int, *, quick: bool = False,
                naive: bool = True, frees: Sequence[int] = (1, 2, 4)) -> list[Setting]:
    """The sweep around a scene's default (``default_contact``, ``default_free`` substeps per
    servo tick): contact substeps from 1/8x to 8x the default, free substeps ``frees`` x the
    default, a uniform 0.1 ms step (10 substeps per 1 ms tick everywhere) and the naive RK4."""
    mults = (0.25, 1, 4) if quick else (0.125, 0.25, 0.5, 1, 2, 4, 8)
    frees = tuple(frees)[:2] if quick else tuple(frees)
    contact = sorted({max(1, int(round(default_contact * m))) for m in mults})
    out = []
    for c in contact:
        for f in frees:
            f_abs = max(1, default_free * f)
            is_def = c == default_contact and f_abs == default_free
            out.append(Setting(f"rk4 {c}/{f_abs}", c, f_abs, default=is_def))
    if not any(s.default for s in out):   # pragma: no cover - the grid always holds it
        out.append(Setting(f"rk4 {default_contact}/{default_free}", default_contact, default_free, default=True))
    out.append(Setting("rk4 uniform 0.1 ms", 10, 10))
    if naive:
        out.append(Setting("naive rk4 0.1 ms", naive=True))
    return out


def _channel_error(ds, ref) -> tuple[float, str]:
    """Max over the time-dependent float channels of max|x - x_ref| / peak-to-peak(x_ref)
    (per component, over the reference's whole record) on their common samples;
    returns (error, worst channel)."""
    worst, name = 0.0, ""
    for var in ref.data_vars:
        b = ref[var]
        tdim = next((d for d in b.dims if d.startswith("t_")), None)
        if var not in ds or b.dtype.kind != "f" or tdim is None:
            continue
        a = ds[var].transpose(tdim, ...)
        b = b.transpose(tdim, ...)
        n = min(a.sizes[tdim], b.sizes[tdim])
        if n == 0:
            continue
        bfull = np.asarray(b.values, float).reshape(b.sizes[tdim], -1)
        av = np.asarray(a.values, float).reshape(a.sizes[tdim], -1)[:n]
        if not np.all(np.isfinite(av)):
            return math.inf, var
        scale = np.ptp(bfull, axis=0)
        scale = np.where(scale > 0, scale, np.max(np.abs(bfull), axis=0))
        scale = np.where(scale > 0, scale, 1.0)
        err = float(np.max(np.abs(av - bfull[:n]) / scale))
        if err > worst:
            worst, name = err, var
    return worst, name


def trial_errors(tree, ref, ident, ident_ref) -> dict[str, Any]:
    """Errors of a trial against the reference trial of the same scene."""
    tr, rr = tree["truth"], ref["truth"]
    out = {
        "m_eff": _rel(ident.m_eff, ident_ref.m_eff),
        "e": _rel(ident.e, ident_ref.e),
        "v_a_post": _rel(float(tr.v_a_post), float(rr.v_a_post)),
        "v_b_post": _rel(float(tr.v_b_post), float(rr.v_b_post)),
    }
    out["measured"], out["measured_worst"] = _channel_error(tree["measured"].to_dataset(), ref["measured"].to_dataset())
    out["truth"], out["truth_worst"] = _channel_error(tr.to_dataset(), rr.to_dataset())
    out["ident"] = max(out["m_eff"], out["e"])
    out["velocity"] = max(out["v_a_post"], out["v_b_post"])
    out["combined"] = max(out["ident"], out["velocity"])
    return out


def _identify(tree):
    from .identify import identify_trial
    return identify_trial(tree["measured"].to_dataset(), meta=dict(tree.attrs))


def pareto_front(points: Sequence[tuple[float, float]], *, time_tol: float = 0.0) -> list[bool]:
    """Which (cost, error) points are on the Pareto front: no other point is at least as cheap
    and as accurate and strictly better in one of them. With ``time_tol`` > 0 a point only
    counts as cheaper when it is cheaper by more than that fraction (the timing noise of the
    run): costs within it are ties, and a tie is broken by the error alone."""
    on = []
    for i, (t, e) in enumerate(points):
        dominated = False
        for j, (t2, e2) in enumerate(points):
            if j == i or not (math.isfinite(t2) and math.isfinite(e2)):
                continue
            if time_tol > 0:
                cheaper = t2 < t * (1.0 - time_tol)
                tie = not cheaper and t2 <= t * (1.0 + time_tol)
                if (cheaper and e2 <= e) or (tie and e2 < e and t2 <= t):
                    dominated = True
                    break
            elif t2 <= t and e2 <= e and (t2 < t or e2 < e):
                dominated = True
                break
        on.append(not dominated and math.isfinite(e) and math.isfinite(t))
    return on


def timing_noise(rows: Sequence[dict]) -> float:
    """Median over a scene's settings of the relative half-range (max - min) / (2 median) of
    their timed repeats: the run's timing resolution on this shared machine."""
    spans = [(r["wall_max"] - r["wall_min"]) / (2.0 * r["wall"]) for r in rows
             if "error" not in r and r.get("wall", 0) > 0 and "wall_min" in r]
    return float(statistics.median(spans)) if spans else 0.0


def assign_fronts(rows: Sequence[dict]) -> float:
    """Mark ``front`` (median wall time, ties within the timing noise), ``front_cpu`` and
    ``front_rhs`` (strict) on the rows of one scene; returns the timing noise used."""
    tol = timing_noise(rows)
    for key, cost, t in (("front", "wall", tol), ("front_cpu", "cpu", 0.0), ("front_rhs", "rhs", 0.0)):
        pts = [(float(r.get(cost, math.nan)), max(r.get("combined", math.nan), ERR_FLOOR)) for r in rows]
        for r, f in zip(rows, pareto_front(pts, time_tol=t)):
            r[key] = f
    for r in rows:
        r["noise"] = tol
    return tol


def work_precision(*, quick: bool = False, repeats: int | None = None, flexible: bool = True,
                   log: Callable[[str], None] = print, only: str | None = None,
                   checkpoint: Callable[[dict], None] | None = None) -> dict[str, Any]:
    """Run the work-precision sweep; returns ``{"rows": [...], "scenes": [...], "skipped": [...]}``.

    Each row: scene, setting, substeps, steps, RHS evaluations, median/min/max wall and median
    CPU time per trial [s], and the errors of :func:`trial_errors`; ``front`` marks the Pareto
    front of (median wall time, max(rel. error of m*, e, v'_a, v'_b)) within its scene.
    """
    from .rig import build, simulate

    repeats = repeats or (3 if quick else 5)
    rows, skipped, scenes = [], [], []
    for spec in wp_scenes(quick=quick, flexible=flexible):
        if only and only not in spec.label:
            continue
        try:
            scene = spec.make()
        except InputError as exc:
            skipped.append((spec.label, f"scene refused: {exc}"))
            continue
        ok, why = rig_available(scene)
        if not ok:
            skipped.append((spec.label, why))
            log(f"[wp] {spec.label}: skipped ({why})")
            continue
        rig = build(scene)
        dc, df = int(rig.substeps_contact), int(rig.substeps_free)
        flex = scene.base != "fixed"
        settings = wp_settings(dc, df, quick=quick, naive=not flex, frees=(1, 2, 4, 8) if flex else (1, 2, 4))
        n_rep = max(2, repeats - 2) if flex else repeats
        log(f"[wp] {spec.label}: default {dc}/{df}; reference {REF_FACTOR * dc}/{REF_FACTOR * df}; "
            f"{len(settings)} settings x {repeats} repeats")
        try:
            ref, ref_wall, _ = _timed(lambda: simulate(scene, integration={
                "substeps_contact": REF_FACTOR * dc, "substeps_free": REF_FACTOR * df}))
            half = simulate(scene, integration={"substeps_contact": REF_FACTOR // 2 * dc,
                                                "substeps_free": REF_FACTOR // 2 * df})
        except Exception as exc:  # noqa: BLE001
            skipped.append((spec.label, f"reference failed: {type(exc).__name__}: {exc}"))
            log(f"[wp] {spec.label}: skipped, the reference failed ({type(exc).__name__}: {exc})")
            continue
        ident_ref = _identify(ref)
        ref_check = trial_errors(half, ref, _identify(half), ident_ref)
        scenes.append(dict(label=spec.label, default=(dc, df), ref=(REF_FACTOR * dc, REF_FACTOR * df),
                           ref_wall=ref_wall, ref_half_error=ref_check, m_eff=ident_ref.m_eff, e=ident_ref.e,
                           excluded=ident_ref.excluded, reason=ident_ref.reason))
        trees: dict[str, Any] = {}
        walls: dict[str, list] = {s.label: [] for s in settings}
        cpus: dict[str, list] = {s.label: [] for s in settings}
        failures: dict[str, str] = {}
        for s in settings:          # warm-up round (first calls of a code path cost more)
            try:
                with np.errstate(all="ignore"):
                    trees[s.label] = s.run(scene)
            except Exception as exc:  # noqa: BLE001 - a setting that fails is a row, not the end of the run
                failures[s.label] = f"{type(exc).__name__}: {exc}"
        for _ in range(n_rep):
            for s in settings:
                if s.label in failures or (s.naive and len(walls[s.label]) >= max(1, repeats // 2)):
                    continue        # the naive run is ~0.5 s: half the repeats suffice
                _, w, c = _timed(lambda: s.run(scene))
                walls[s.label].append(w)
                cpus[s.label].append(c)
        for s in settings:
            row = dict(scene=spec.label, setting=s.label, default=s.default, naive=s.naive,
                       substeps=("-" if s.naive else f"{s.substeps_contact or dc}/{s.substeps_free or df}"))
            if s.label in failures:
                row.update(error=failures[s.label], wall=math.nan, cpu=math.nan, combined=math.nan)
                rows.append(row)
                continue
            tree = trees[s.label]
            errs = trial_errors(tree, ref, _identify(tree), ident_ref)
            row.update(errs)
            row.update(wall=statistics.median(walls[s.label]), wall_min=min(walls[s.label]),
                       wall_max=max(walls[s.label]), cpu=statistics.median(cpus[s.label]),
                       n=len(walls[s.label]), steps=int(tree.attrs.get("integration_steps", -1)),
                       rhs=int(tree.attrs.get("integration_rhs_evaluations", -1)))
            rows.append(row)
        mine = [r for r in rows if r["scene"] == spec.label]
        if checkpoint:
            checkpoint({"rows": rows, "scenes": scenes, "skipped": skipped, "repeats": repeats})
        assign_fronts(mine)
        d = next(r for r in mine if r["default"])
        if "error" in d:
            log(f"[wp] {spec.label}: the default setting failed: {d['error']}")
        else:
            log(f"[wp] {spec.label}: default {d['wall'] * 1e3:.0f} ms, m* {_e(d['m_eff'])}, e {_e(d['e'])}, "
                f"v' {_e(d['velocity'])}, front {'yes' if d['front'] else 'NO'}")
    return {"rows": rows, "scenes": scenes, "skipped": skipped, "repeats": repeats}


def wp_verdict(result: dict) -> list[str]:
    """Per scene: is the default on the front, within 1e-3 in m* and e, within the time target?"""
    lines = []
    for sc in result["scenes"]:
        mine = [r for r in result["rows"] if r["scene"] == sc["label"]]
        d = next(r for r in mine if r["default"])
        target = TARGET_FLEXIBLE if sc["label"].startswith("flexible") else TARGET_FIXED
        if "error" in d:
            ok = [r for r in mine if "error" not in r and r["ident"] <= TARGET_REL_ERR]
            best = min(ok, key=lambda r: r["wall"]) if ok else None
            lines.append(f"- {sc['label']}: the default setting {d['setting']} FAILS ({d['error'][:120]}); "
                         + (f"the fastest setting within 1e-3 is {best['setting']} ({best['wall'] * 1e3:.0f} ms)."
                            if best else "no setting reaches 1e-3."))
            continue
        acc = d["ident"] <= TARGET_REL_ERR
        fast = d["wall"] <= target
        tol = d.get("noise", 0.0)
        dominators = [r for r in mine if r is not d and math.isfinite(r.get("combined", math.nan))
                      and ((r["wall"] < d["wall"] * (1 - tol) and r["combined"] <= d["combined"])
                           or (r["wall"] <= d["wall"] and r["combined"] < d["combined"]))]
        dom = ", ".join(f"{r['setting']} ({r['wall'] * 1e3:.0f} ms, {_e(r['combined'])})" for r in dominators)
        front_ok = sorted((r for r in mine if r.get("front") and "error" not in r and r is not d
                           and r["ident"] <= TARGET_REL_ERR), key=lambda r: r["wall"])
        alt = ""
        if not d["front"] and front_ok:
            b = front_ok[0]
            alt = (f" Fastest front setting within 1e-3: {b['setting']} ({b['wall'] * 1e3:.0f} ms, "
                   f"{b['rhs']} RHS evaluations vs {d['rhs']}; m* {_e(b['m_eff'])}, e {_e(b['e'])}, "
                   f"v' {_e(b['velocity'])}).")
        lines.append(
            f"- {sc['label']}: default {d['setting']} {d['wall'] * 1e3:.0f} ms/trial "
            f"(target {target * 1e3:.0f} ms: {'met' if fast else 'missed'}); error m* {_e(d['m_eff'])}, "
            f"e {_e(d['e'])} (<= 1e-3: {'yes' if acc else 'NO'}), v' {_e(d['velocity'])}; "
            f"Pareto front (median wall time, ties within the timing noise {tol:.0%}): "
            f"{'yes' if d['front'] else 'NO, dominated by ' + dom}; "
            f"by CPU time: {'yes' if d['front_cpu'] else 'no'}; by RHS evaluations: "
            f"{'yes' if d['front_rhs'] else 'no'}." + alt)
    return lines


def format_wp_table(result: dict) -> str:
    header = ["scene", "setting", "substeps c/f", "steps", "RHS evals", "median wall [ms]", "min-max [ms]",
              "median CPU [ms]", "m*", "e", "v'_a", "v'_b", "measured (worst)", "truth (worst)",
              "front: wall/CPU/RHS"]
    rows = []
    for r in result["rows"]:
        name = f"**{r['setting']} (default)**" if r["default"] else r["setting"]
        if "error" in r:
            rows.append([r["scene"], name, r["substeps"], "-", "-", "-", "-", "-", "-", "-", "-", "-",
                         r["error"][:60], "-", "-"])
            continue
        rows.append([
            r["scene"], name, r["substeps"], r["steps"], r["rhs"], f"{r['wall'] * 1e3:.0f}",
            f"{r['wall_min'] * 1e3:.0f}-{r['wall_max'] * 1e3:.0f}", f"{r['cpu'] * 1e3:.0f}",
            _e(r["m_eff"]), _e(r["e"]), _e(r["v_a_post"]), _e(r["v_b_post"]),
            f"{_e(r['measured'])} ({r['measured_worst']})", f"{_e(r['truth'])} ({r['truth_worst']})",
            "/".join("yes" if r[k] else "no" for k in ("front", "front_cpu", "front_rhs")),
        ])
    return _md(header, rows)


def format_wp_references(result: dict) -> str:
    rows = []
    for sc in result["scenes"]:
        h = sc["ref_half_error"]
        rows.append([sc["label"], f"{sc['default'][0]}/{sc['default'][1]}", f"{sc['ref'][0]}/{sc['ref'][1]}",
                     f"{sc['ref_wall'] * 1e3:.0f}", f"{sc['m_eff']:.4g}", f"{sc['e']:.4f}",
                     _e(h["ident"]), _e(h["velocity"]), _e(h["truth"])])
    return _md(["scene", "default c/f", "reference c/f", "reference wall [ms]", "m* ref [kg]", "e ref",
                "half-ref vs ref: m*, e", "v'", "truth channels"], rows)


def plot_work_precision(result: dict, path: str | os.PathLike) -> Path:
    """Log-log error vs median wall time per trial, one panel per scene; default and naive marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [sc["label"] for sc in result["scenes"]]
    n = max(1, len(labels))
    cols = min(3, n)
    nrows = math.ceil(n / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(5.2 * cols, 4.0 * nrows), squeeze=False)
    series = (("ident", "m*, e (identified)", "o"), ("velocity", "v'_a, v'_b (truth)", "s"),
              ("measured", "measured channels", "^"))
    for ax, label in zip(axes.flat, labels):
        mine = [r for r in result["rows"] if r["scene"] == label and math.isfinite(r.get("wall", math.nan))]
        for key, name, marker in series:
            t = np.array([r["wall"] * 1e3 for r in mine])
            e = np.array([max(r[key], ERR_FLOOR) for r in mine])
            ax.scatter(t, e, marker=marker, s=22, alpha=0.75, label=name)
        front = sorted((r["wall"] * 1e3, max(r["combined"], ERR_FLOOR)) for r in mine if r["front"])
        if front:
            ax.plot(*zip(*front), "k--", lw=0.8, label="Pareto front (m*, e, v')")
        for r in mine:
            if r["default"]:
                ax.scatter([r["wall"] * 1e3], [max(r["combined"], ERR_FLOOR)], s=160, facecolors="none",
                           edgecolors="red", linewidths=2, label=f"default {r['setting']}", zorder=5)
            if r["naive"]:
                ax.scatter([r["wall"] * 1e3], [max(r["combined"], ERR_FLOOR)], s=160, marker="x", color="k",
                           label="naive RK4 0.1 ms", zorder=5)
            if r["setting"] == "rk4 uniform 0.1 ms":
                ax.scatter([r["wall"] * 1e3], [max(r["combined"], ERR_FLOOR)], s=120, marker="+", color="k",
                           label="rig RK4, uniform 0.1 ms", zorder=5)
        target = TARGET_FLEXIBLE if label.startswith("flexible") else TARGET_FIXED
        ax.axhline(TARGET_REL_ERR, color="grey", lw=0.7, ls=":")
        ax.axvline(target * 1e3, color="grey", lw=0.7, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("median wall time per trial [ms]")
        ax.set_ylabel("relative error vs reference")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    from matplotlib.lines import Line2D
    from matplotlib.ticker import LogLocator, NullFormatter
    for ax in axes.flat:
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_minor_locator(LogLocator(subs="all", numticks=12))
        ax.yaxis.set_minor_formatter(NullFormatter())
    proxies = [
        Line2D([], [], ls="", marker="o", color="C0", label="m*, e (identified)"),
        Line2D([], [], ls="", marker="s", color="C1", label="v'_a, v'_b (truth)"),
        Line2D([], [], ls="", marker="^", color="C2", label="measured channels"),
        Line2D([], [], ls="--", color="k", lw=0.8, label="Pareto front (worst of m*, e, v')"),
        Line2D([], [], ls="", marker="o", ms=12, mfc="none", mec="red", mew=2, label="default setting"),
        Line2D([], [], ls="", marker="+", ms=10, color="k", label="rig RK4, uniform 0.1 ms"),
        Line2D([], [], ls="", marker="x", ms=10, color="k", label="naive fixed-step RK4, 0.1 ms"),
    ]
    fig.legend(handles=proxies, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle("Work-precision of the simulated VES-II (dotted: 1e-3 error target, per-trial time target; "
                 f"errors of 0 drawn at {ERR_FLOOR:g})", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.96))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ---------------------------------------------------------------------------------------
# per-trial cost
# ---------------------------------------------------------------------------------------
def cost_scenes(*, quick: bool = False) -> list[tuple[str, dict]]:
    """(group, make_scene kwargs): the campaign's trials at the paper's speeds."""
    speeds = (1.0, 2.5) if not quick else (1.75,)
    configs = (1, 2, 3) if not quick else (1, 2)
    out = []
    for base in ("fixed", "flexible"):
        gains = ("zero", "low", "high") if base == "fixed" else ("low", "high")
        cfgs = configs if base == "fixed" else tuple(c for c in configs if c in (1, 2))
        for c in cfgs:
            for g in gains:
                for v in speeds:
                    out.append((base, dict(base=base, config=c, gain=g, speed=v)))
    return out


def write_probe(*, repeats: int = 7, samples: int = 500) -> dict[str, float]:
    """Issue 3's two write references, timed here: median wall time [s] of writing one
    NetCDF4 group of a few channels through xarray's h5netcdf engine (``"xarray"``) and of
    the same arrays through plain h5py (``"h5py"``), each into a fresh file.

    The group holds what a trial's group holds, at a trial's size: a time coordinate and
    three float channels (``samples`` long; one of them 3 wide) with ``units``. Compare
    with :data:`XARRAY_WRITE_AT_TARGETS` and :data:`H5PY_WRITE_AT_TARGETS`.
    """
    import h5py
    import xarray as xr

    t = np.arange(samples) * 1e-3
    rng = np.random.default_rng(0)
    data = {"f_piezo": ("t", rng.normal(size=samples)), "ft_force": (("t", "axis"), rng.normal(size=(samples, 3))),
            "theta_pend": ("t", rng.normal(size=samples))}
    ds = xr.Dataset({k: (d, v, {"units": "1"}) for k, (d, v) in data.items()},
                    coords={"t": ("t", t, {"units": "s"}), "axis": list("xyz")})

    def xarray_write(path):
        ds.to_netcdf(path, engine="h5netcdf", group="measured")

    def h5py_write(path):
        with h5py.File(path, "w") as f:
            g = f.create_group("measured")
            g.create_dataset("t", data=t)
            for k, (_, v) in data.items():
                g.create_dataset(k, data=v)

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, write in (("xarray", xarray_write), ("h5py", h5py_write)):
            write(Path(tmp) / f"warm-{name}.nc")
            times = []
            for i in range(repeats):
                t0 = time.perf_counter()
                write(Path(tmp) / f"{name}-{i}.nc")
                times.append(time.perf_counter() - t0)
            out[name] = statistics.median(times)
    return out


def trial_cost(*, quick: bool = False, repeats: int | None = None, baseline_repeats: int | None = None,
               log: Callable[[str], None] = print) -> dict[str, Any]:
    """Median simulation time per trial (default setting), file writing time separately, and
    the naive baseline (0.5 s of fixed-base trial, fixed-step RK4 at 0.1 ms) in the same run."""
    from . import archive
    from .rig import simulate
    from .scene import make_scene

    repeats = repeats or (2 if quick else 3)
    baseline_repeats = baseline_repeats or (2 if quick else 5)
    sims: dict[str, list] = {}
    per: dict[tuple, list] = {}
    writes: dict[str, list] = {}
    idents: list[float] = []
    skipped = []
    # issue 3's xarray write reference is timed after every scene, so each trial's time can
    # be scaled by the machine's speed of the same minute: it drifts by 1.5x within a run
    naive_scene = make_scene(base="fixed", config=1, gain="zero", speed=1.5)
    naive_rk4(naive_scene)   # warm-up
    write_probe(repeats=1)   # warm-up (h5py, h5netcdf imports)
    scaled: dict[str, list] = {}
    writes_scaled: dict[str, list] = {}
    probes: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        for group, kw in cost_scenes(quick=quick):
            scene = make_scene(**kw)
            ok, why = rig_available(scene)
            if not ok:
                skipped.append((group, why))
                continue
            tree = simulate(scene)   # warm-up
            walls = []
            for _ in range(repeats):
                tree, w, c = _timed(lambda: simulate(scene))
                walls.append(w)
                sims.setdefault(group, []).append(w)
                per.setdefault((group, kw["gain"]), []).append(w)
            probe = write_probe(repeats=3)
            probes.append(probe)
            factor = probe["xarray"] / XARRAY_WRITE_AT_TARGETS   # this machine now vs the targets' one
            scaled.setdefault(group, []).extend(w / factor for w in walls)
            _, w_id, _ = _timed(lambda: _identify(tree))
            idents.append(w_id)
            path = Path(tmp) / f"{group}-{kw['config']}-{kw['gain']}-{kw['speed']}.nc"
            for _ in range(repeats):
                _, w, _ = _timed(lambda: archive.write_trial(tree, path))
                writes.setdefault(group, []).append(w)
                writes_scaled.setdefault(group, []).append(w / factor)
        log(f"[cost] simulated {sum(len(v) for v in sims.values())} trials")
        scene = naive_scene
        naive = [_timed(lambda: naive_rk4(scene, duration=0.5))[1] for _ in range(baseline_repeats)]
        naive_full = [_timed(lambda: naive_trial(scene, duration=0.5))[1] for _ in range(max(1, baseline_repeats // 2))]
        ours = [_timed(lambda: simulate(scene))[1] for _ in range(baseline_repeats)]
        uniform = [_timed(lambda: simulate(scene, integration={"substeps_contact": 10, "substeps_free": 10}))[1]
                   for _ in range(max(1, baseline_repeats // 2))]
    log("[cost] baseline done")
    med = {k: statistics.median(v) for k, v in sims.items()}
    return dict(
        sim=med, sim_n={k: len(v) for k, v in sims.items()},
        sim_scaled={k: statistics.median(v) for k, v in scaled.items()},
        probe_xarray=_spread([p["xarray"] for p in probes]), probe_h5py=_spread([p["h5py"] for p in probes]),
        sim_range={k: (min(v), max(v)) for k, v in sims.items()},
        per_gain={k: statistics.median(v) for k, v in per.items()},
        write={k: statistics.median(v) for k, v in writes.items()},
        write_scaled={k: statistics.median(v) for k, v in writes_scaled.items()},
        identify=statistics.median(idents) if idents else math.nan,
        baseline=dict(naive_integration=statistics.median(naive), naive_trial=statistics.median(naive_full),
                      ours_same_scene=statistics.median(ours), uniform_0p1ms=statistics.median(uniform)),
        skipped=skipped, repeats=repeats,
    )


def _spread(values: Sequence[float]) -> tuple[float, float, float]:
    """(median, min, max); NaNs when there is nothing (no scene ran)."""
    if not values:
        return (math.nan,) * 3
    return statistics.median(values), min(values), max(values)


def _verdict(measured: float, scaled: float, target: float) -> str:
    """Met here, met only once scaled to the machine the targets were set on (by issue 3's
    xarray write reference), or missed."""
    if measured <= target:
        return "met"
    if scaled <= target:
        return "missed here; met scaled by the write reference"
    return "missed"


def format_cost(c: dict[str, Any]) -> str:
    rows = []
    for group, target in (("fixed", TARGET_FIXED), ("flexible", TARGET_FLEXIBLE)):
        if group not in c["sim"]:
            why = next((w for g, w in c["skipped"] if g == group), "not run")
            rows.append([group, "-", "-", "-", f"{target * 1e3:.0f}", "not available: " + why[:70]])
            continue
        lo, hi = c["sim_range"][group]
        gains = ", ".join(f"{g} {c['per_gain'][(group, g)] * 1e3:.0f}" for g in ("zero", "low", "high")
                          if (group, g) in c["per_gain"])
        scaled = c["sim_scaled"][group]
        verdict = _verdict(c["sim"][group], scaled, target)
        rows.append([group, c["sim_n"][group], f"**{c['sim'][group] * 1e3:.0f}**", f"{lo * 1e3:.0f}-{hi * 1e3:.0f}",
                     f"{scaled * 1e3:.0f}", f"{target * 1e3:.0f}", f"{verdict}; by gain: {gains}"])
    table1 = _md(["base", "trials timed", "median simulation [ms]", "min-max [ms]",
                  "scaled by the write reference [ms]", "target [ms]", "verdict"], rows)
    wrows = [[g, f"**{v * 1e3:.1f}**", f"{c['write_scaled'][g] * 1e3:.1f}", f"{TARGET_WRITE * 1e3:.0f}",
              _verdict(v, c["write_scaled"][g], TARGET_WRITE)] for g, v in c["write"].items()]
    table2 = _md(["base", "median write_trial [ms]", "scaled by the write reference [ms]",
                  "target [ms]", "verdict"], wrows)
    b = c["baseline"]
    table3 = _md(["same run, configuration 1, Zero gains, 1.5 m/s", "median wall [ms]"], [
        ["naive fixed-step RK4 at 0.1 ms, Python-side Pinocchio, 0.5 s of trial (integration only)",
         f"**{b['naive_integration'] * 1e3:.0f}**"],
        ["the same naive run + the rig's sensors and channels", f"{b['naive_trial'] * 1e3:.0f}"],
        ["the rig's RK4 forced to a uniform 0.1 ms step (10/10 substeps)", f"{b['uniform_0p1ms'] * 1e3:.0f}"],
        ["**the rig at its default setting** (simulation incl. channels)", f"**{b['ours_same_scene'] * 1e3:.0f}**"],
    ])
    px, ph = c["probe_xarray"], c["probe_h5py"]
    rx = px[0] / XARRAY_WRITE_AT_TARGETS
    scale_note = (
        f"Machine speed: issue 3 states two write costs measured where its targets were set, one NetCDF4 "
        f"group of a few channels through xarray/h5netcdf (about {XARRAY_WRITE_AT_TARGETS * 1e3:.0f} ms) and the "
        f"same arrays through plain h5py (about {H5PY_WRITE_AT_TARGETS * 1e3:.0f} ms). Timed after every scene of "
        f"this run (`campaign.bench.write_probe`) they took {px[0] * 1e3:.1f} ms ({px[1] * 1e3:.1f}-"
        f"{px[2] * 1e3:.1f}) and {ph[0] * 1e3:.1f} ms ({ph[1] * 1e3:.1f}-{ph[2] * 1e3:.1f}): this machine ran at "
        f"{rx:.2f}x and {ph[0] / H5PY_WRITE_AT_TARGETS:.2f}x those times"
        + ("; within 25 % of that machine, so the raw times are what the targets mean. " if 0.8 <= rx <= 1.25 else ". ")
        + "The scaled column divides each trial's time by its scene's xarray ratio (the Python-bound "
        "reference, like the rig). The naive RK4 below is not used for scaling: ours took "
        f"{b['naive_integration'] / BASELINE_AT_TARGETS:.1f}x the issue's {BASELINE_AT_TARGETS * 1e3:.0f} ms here "
        "because it does more per step than the issue's unpublished one (a friction state and the contact "
        "kinematics at every stage); the machine-independent figure is the rig's ratio to it in the same run.")
    return "\n\n".join([table1, scale_note, table2, table3,
                        f"Identification of one trial (not part of the simulation time): median "
                        f"{c['identify'] * 1e3:.1f} ms."])


def truth_m_impulse(measured, truth, robot) -> float:
    """Eq 11's impulsive-limit m* of a trial from its truth: the true contact impulse over
    the true tip velocity change through the Jacobian at the contact start,
    ``P / n.J(q_s) (qd(t_e) - qd(t_s))`` -- what identification with
    ``m_eff_estimator="impulse"`` is scored against (synthetic or rig trials; tests and
    ``benchmarks/identification_accuracy.py``).

    ``n.J(q_s) qd(t_s)`` is the true ``v_a_pre``, and ``n.J(q_s) qd(t_e)`` the true
    ``v_a_post`` less ``n.(J(q_e) - J(q_s)) qd(t_e)``; only that correction (< 1 % of the
    velocity change) takes ``q`` and ``qd`` interpolated from the truth samples, so their
    spacing (1 ms) hardly enters. On the impulsive synthetic trials (``decay="none"``, fixed
    base) it is eq 11 with the trial's lambda.
    """
    import pinocchio as pin

    from .exiit import impact_jacobian, unit_direction

    t = np.asarray(truth["t_truth"].values, float)
    q, v = np.asarray(truth["q"].values, float), np.asarray(truth["v"].values, float)
    t_s, t_e = float(truth["contact_start"]), float(truth["contact_end"])
    n = unit_direction(np.asarray(measured["impact_direction"].values, float))

    def at(x, tq):
        return np.array([np.interp(tq, t, x[:, k]) for k in range(x.shape[1])])

    def jn(qq):
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, qq)
        return n @ impact_jacobian(robot.model, data, qq, robot.impact_frame_id)[:3]

    qd_e = at(v, t_e)
    dv = float(truth["v_a_post"]) - float(truth["v_a_pre"]) - float((jn(at(q, t_e)) - jn(at(q, t_s))) @ qd_e)
    return float(truth["impulse"]) / dv


# ---------------------------------------------------------------------------------------
# stress suite
# ---------------------------------------------------------------------------------------
#: invariant tolerances (see check_invariants)
ENERGY_RTOL = 1e-6        # energy rise allowed after the touch, relative to the hammer's kinetic energy
POST_SAMPLES = 3          # joint-encoder samples needed after the contact end (identification's minimum)
GROWTH_TOL = 1.2          # flexible base: the last quarter's peak base motion / the first quarter's
MEFF_LOWER = 0.9          # identified m* >= this x Ex-IIT m* (lambda = 0): joint resistance only adds
E_UPPER = 1.05            # identified e <= this (noise margin above the physical bound 1)
LIMIT_TOL = math.radians(0.05)

PAPER_HIGH = (500000.0, 4000.0, 1500.0)


@dataclasses.dataclass(frozen=True)
class StressCase:
    """One corner of the input space: ``make_scene`` keywords (+ integration overrides)."""

    axis: str
    label: str
    kwargs: dict
    integration: dict | None = None
    #: ``hammer_x_meff``: set ``pendulum.head_mass`` so that m_b = this x Ex-IIT m* of the pose
    hammer_x_meff: float | None = None

    def make(self):
        from .scene import make_scene
        kw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in self.kwargs.items()}
        if self.hammer_x_meff is not None:
            m0 = _m0(kw)
            params = kw.setdefault("params", {})
            rod = params.get("pendulum.rod_mass", _rig_value("pendulum.rod_mass"))
            params["pendulum.head_mass"] = self.hammer_x_meff * m0 - rod / 3.0
        return make_scene(**kw)


def _rig_value(key: str):
    from .scene import load_rig
    return load_rig()[0][key]


def _m0(kw: dict) -> float:
    """Ex-IIT m* (eq 11, lambda = 0, fixed base) of the pose of ``make_scene`` keywords."""
    from . import exiit
    from .paper import load_paper
    from .robot import load_robot
    paper = load_paper()
    q = kw.get("q_paper_deg") or paper["configurations"][int(kw.get("config", 1))]
    q = np.radians(np.asarray(q, float) + np.asarray(paper["offset_deg"], float))
    return float(exiit.effective_mass(load_robot(), q))


@dataclasses.dataclass
class StressResult:
    case: StressCase
    status: str          # passed | refused | blow-up | failed
    reason: str
    seconds: float
    info: dict


def _x(gains, k):
    return tuple(float(g) * k for g in gains)


def stress_cases(*, reduced: bool = False, flexible: bool = True) -> list[StressCase]:
    """The corners of the input space (issue 8): poses at and near the stretched singularity
    and at the joint limits; gains 0 to 1000x High; contact stiffness 0.01x to 1000x; speeds
    0.01 to 10 m/s; hammer mass 0.01x to 100x m*; servo 100 Hz to 10 kHz; soft and stiff
    beams; coarse integration overrides; and some crossings of those corners."""
    C = StressCase
    k0 = float(_rig_value("contact.stiffness"))
    ei0 = float(_rig_value("flexible.beam_EI"))
    z = dict(config=1, gain="zero", speed=1.5)
    h = dict(config=1, gain="high", speed=1.5)

    def pose(q, gain="zero", speed=1.5):
        return dict(config=0, q_paper_deg=tuple(float(x) for x in q), gain=gain, speed=speed)

    qs = tuple(round(x, 9) for x in singular_pose())

    full = [
        # -- poses ------------------------------------------------------------------------
        *[C("pose", f"paper configuration {c}, {g}", dict(config=c, gain=g, speed=1.5))
          for c in (1, 2, 3) for g in ("zero", "high")],
        *[C("pose", f"stretched (0, 172, {q3}), {g}", pose((0.0, 172.0, q3), g))
          for q3 in (10.0, 2.0, 0.5, 0.1, 0.0) for g in ("zero", "high")],
        C("pose", "stretched (0, 172, 0.5), High, 2.5 m/s", pose((0.0, 172.0, 0.5), "high", 2.5)),
        C("pose", "stretched (0, 180, 0) horizontal, zero", pose((0.0, 180.0, 0.0))),
        C("pose", "exact singularity (q1*, q2*, q3*): n leaves the range, zero", pose(qs)),
        C("pose", "exact singularity (q1*, q2*, q3*), High", pose(qs, "high")),
        C("pose", "singularity + 0.1 deg on q3, zero", pose((qs[0], qs[1], qs[2] + 0.1))),
        C("pose", "q1 at +160 deg limit", pose((160.0, 150.0, 90.0))),
        C("pose", "q1 at -160 deg limit", pose((-160.0, 150.0, 90.0))),
        C("pose", "q2 at +225 deg limit", pose((0.0, 225.0, 90.0))),
        C("pose", "q2 at -45 deg limit", pose((0.0, -45.0, 90.0))),
        C("pose", "q3 at -135 deg limit", pose((0.0, 150.0, -135.0))),
        C("pose", "q3 0.01 deg beyond +135 limit", pose((0.0, 135.0, 135.01))),
        # -- gains --------------------------------------------------------------------------
        C("gains", "Low", dict(config=1, gain="low", speed=1.5)),
        *[C("gains", f"{k:g}x High", dict(h, gains_counts=_x(PAPER_HIGH, k))) for k in (0.1, 3, 10, 100, 1000)],
        C("gains", "1000x High, configuration 2", dict(config=2, gain="high", speed=1.5,
                                                        gains_counts=_x(PAPER_HIGH, 1000))),
        C("gains", "P only 10x High", dict(h, gains_counts=(PAPER_HIGH[0] * 10, 0.0, 0.0))),
        C("gains", "D only 100x High", dict(h, gains_counts=(0.0, PAPER_HIGH[1] * 100, 0.0))),
        # -- contact stiffness --------------------------------------------------------------
        *[C("contact", f"stiffness {m:g}x, {g}", dict(config=1, gain=g, speed=1.5,
                                                       params={"contact.stiffness": k0 * m}))
          for m in (0.01, 0.1, 10, 100, 1000) for g in ("zero", "high")],
        C("contact", "stiffness 1000x, linear, 2.5 m/s", dict(config=1, gain="zero", speed=2.5, params={
            "contact.stiffness": k0 * 1000, "contact.exponent": 1.0})),
        C("contact", "restitution 0.05", dict(z, params={"contact.restitution": 0.05})),
        C("contact", "restitution 1.0 (elastic)", dict(z, params={"contact.restitution": 1.0})),
        # -- speeds -------------------------------------------------------------------------
        *[C("speed", f"{v:g} m/s, {g}", dict(config=1, gain=g, speed=v))
          for v in (0.01, 0.1, 0.5, 2.5, 3.0, 5.0, 10.0) for g in ("zero", "high")],
        # -- hammer mass --------------------------------------------------------------------
        *[C("hammer", f"m_b = {m:g}x m*, configuration {c}", dict(config=c, gain="zero", speed=1.5),
            hammer_x_meff=m) for m in (0.01, 0.1, 1.0, 10.0, 100.0) for c in (1, 2)],
        C("hammer", "m_b = 100x m*, 2.5 m/s, High", dict(config=1, gain="high", speed=2.5), hammer_x_meff=100.0),
        # -- servo rate ---------------------------------------------------------------------
        *[C("servo", f"{r:g} Hz, {g}", dict(config=1, gain=g, speed=1.5, params={"controller.servo_rate": r}))
          for r in (100.0, 300.0, 3000.0, 10000.0) for g in ("low", "high")],
        C("servo", "100 Hz, zero", dict(z, params={"controller.servo_rate": 100.0})),
        C("servo", "10 kHz, 10x High", dict(h, gains_counts=_x(PAPER_HIGH, 10),
                                            params={"controller.servo_rate": 10000.0})),
        # -- crossings --------------------------------------------------------------------------
        C("cross", "stiffness 0.01x at 0.01 m/s", dict(config=1, gain="zero", speed=0.01,
                                                        params={"contact.stiffness": k0 * 0.01})),
        C("cross", "stiffness 1000x, High, 2.5 m/s", dict(config=1, gain="high", speed=2.5,
                                                           params={"contact.stiffness": k0 * 1000})),
        C("cross", "m_b = 0.01x m* at 0.01 m/s", dict(config=1, gain="zero", speed=0.01), hammer_x_meff=0.01),
        C("cross", "stretched (0, 172, 0.1), 1000x stiffness", pose((0.0, 172.0, 0.1)) | {
            "params": {"contact.stiffness": k0 * 1000}}),
        C("cross", "ideal scene, stiffness 1000x", dict(config=1, scene="ideal", speed=1.5, params={
            "contact.stiffness": 4.0e9})),
        C("cross", "ideal scene, configuration 2, 2.5 m/s", dict(config=2, scene="ideal", speed=2.5)),
        C("cross", "zero gravity, Zero gains (passive)", dict(z, params={"gravity": 0.0})),
        C("cross", "no friction, no gravity, Zero gains", dict(z, params={
            "gravity": 0.0, "arm.coulomb_scale": 0.0, "arm.viscous_scale": 0.0})),
        # -- integration overrides ----------------------------------------------------------
        *[C("integration", f"ideal contact, substeps_contact={s}", dict(config=1, scene="ideal", speed=1.5),
            integration={"substeps_contact": s}) for s in (1, 2, 4, 8)],
        C("integration", "default contact, substeps_free=1, substeps_contact=1, 2.5 m/s, 100x stiffness",
          dict(config=1, gain="zero", speed=2.5, params={"contact.stiffness": k0 * 100}),
          integration={"substeps_contact": 1}),
    ]
    if flexible:
        fl = dict(base="flexible", config=2, gain="high", speed=1.5)
        full += [
            C("beam", "flexible loop, configuration 2, High", dict(fl)),
            C("beam", "flexible ideal coupling, configuration 2, High", dict(fl, params={"ves.mode": "ideal"})),
            *[C("beam", f"EI {m:g}x, {mode}", dict(fl, params={"flexible.beam_EI": ei0 * m, "ves.mode": mode}))
              for m in (1e-4, 1e-2, 1e2, 1e4) for mode in ("loop", "ideal")],
            C("beam", "beam length 2 m (stiff), loop", dict(fl, params={"flexible.beam_length": 2.0})),
            C("beam", "beam length 200 m (soft), loop", dict(fl, params={"flexible.beam_length": 200.0})),
            C("beam", "damping ratio 0, ideal coupling", dict(fl, params={"flexible.damping_ratio": 0.0,
                                                                           "ves.mode": "ideal"})),
            C("beam", "VES rate 100 Hz", dict(fl, params={"ves.rate": 100.0})),
            C("beam", "VES bandwidth 100 Hz", dict(fl, params={"ves.bandwidth": 100.0})),
            C("beam", "VES bandwidth 300 Hz", dict(fl, params={"ves.bandwidth": 300.0})),
            C("beam", "VES latency 1 s", dict(fl, params={"ves.latency": 1.0})),
            C("beam", "VES latency 0", dict(fl, params={"ves.latency": 0.0})),
            C("beam", "flexible ideal scene, zero gravity (passive)", dict(
                base="flexible", config=2, scene="ideal", speed=1.5, params={"ves.mode": "ideal"})),
            C("beam", "flexible, stretched (0, 172, 0.5), High", dict(
                base="flexible", config=0, q_paper_deg=(0.0, 172.0, 0.5), gain="high", speed=1.5)),
        ]
    if not reduced:
        return full
    keep = {
        "stretched (0, 172, 0.0), zero", "stretched (0, 172, 0.5), high", "q3 at -135 deg limit",
        "q3 0.01 deg beyond +135 limit", "paper configuration 3, high",
        "10x High", "1000x High", "stiffness 0.01x, zero", "stiffness 1000x, high", "0.01 m/s, zero",
        "10 m/s, zero", "m_b = 0.01x m*, configuration 1", "m_b = 100x m*, configuration 2", "100 Hz, high",
        "3000 Hz, high", "ideal contact, substeps_contact=1", "ideal scene, configuration 2, 2.5 m/s",
        "no friction, no gravity, Zero gains", "EI 100x, ideal", "EI 10000x, loop", "VES bandwidth 300 Hz",
        "flexible ideal coupling, configuration 2, High", "exact singularity (q1*, q2*, q3*): n leaves the range, zero",
    }
    return [c for c in full if c.label in keep]


def _passive(scene, tree) -> bool:
    """No active element feeds energy: Zero gains (constant gravity compensation at most) and,
    on a flexible base, the ideal coupling without gravity (the VES loop is an active device)."""
    if any(scene.gains_counts):
        return False
    if scene.base == "flexible":
        return scene.p("ves.mode") == "ideal" and float(scene.p("gravity")) == 0.0
    return True


def _momentum_bound(scene, tr, c0: float, c1: float, P: float, m_b: float, vb1: float) -> float:
    """Largest |P - m_b (v_b - v'_b)| the pendulum's tangential momentum balance allows.

    About the pivot ``I_p theta'' = -mgl sin(theta) - F r cos(theta)``, so along the path
    ``m_b r dtheta' = -(mgl / r) sin(theta) dt - F cos(theta) dt``, while the stored hammer
    velocity is the component along n, ``v_b = r theta' cos(theta)``. Over a contact in which
    the pendulum swings at most ``theta_m`` from the bottom the two sides of
    ``P = m_b (v_b - v'_b)`` differ by at most the gravity impulse
    ``(mgl / r) sin(theta_m) (t1 - t0)`` plus ``(P + m_b |v'_b|) (1 - cos theta_m) / cos theta_m``.
    ``theta_m`` is taken from the truth samples in the contact (10 % margin)."""
    t = tr.t_truth.values
    th = np.abs(np.asarray(tr.theta.values, float))
    inside = (t >= c0) & (t <= c1)
    theta_m = 1.1 * float(max(np.max(th[inside]) if inside.any() else 0.0, abs(float(tr.theta.interp(
        t_truth=c1))) if c1 <= t[-1] else 0.0))
    theta_m = min(theta_m, 1.5)
    g = float(scene.p("gravity"))
    mgl_r = (float(scene.p("pendulum.head_mass")) + 0.5 * float(scene.p("pendulum.rod_mass"))) * g
    return (mgl_r * math.sin(theta_m) * (c1 - c0)
            + (abs(P) + m_b * abs(vb1)) * (1.0 - math.cos(theta_m)) / math.cos(theta_m) + 1e-6 * abs(P))


def check_invariants(scene, tree, ident) -> tuple[list[str], dict]:
    """Invariants of a finished trial; returns (violations, info).

    - every float in ``/measured`` and ``/truth`` is finite;
    - the trial's outputs are recorded: one contact, inside the record, followed by at least
      ``POST_RECORD`` of recording (what identification's post-contact windows need);
    - the never-tensile contact slowed the hammer (``v'_b < v_b``);
    - momentum: the hammer's momentum change equals the contact impulse within the bound of
      its tangential momentum balance (:func:`_momentum_bound`: gravity impulse and path
      curvature during the contact; about 1e-4 of the impulse for the default scenes);
    - passive scenes (:func:`_passive`): the energy ``E - tau_gc . (q - q0)`` (mechanical
      energy plus the potential of the constant gravity-compensation torque) never rises
      after the touch by more than ``ENERGY_RTOL`` x the hammer's kinetic energy, and the
      true restitution ``(v'_a - v'_b) / (v_b - v_a)`` is at most 1;
    - identification: either excluded with a reason, or m* finite and >= ``MEFF_LOWER`` x
      Ex-IIT m* (lambda = 0, fixed base), e finite in [0, ``E_UPPER``].
    """
    viol: list[str] = []
    info: dict[str, Any] = {}
    for g in ("measured", "truth"):
        ds = tree[g].to_dataset()
        for name, var in ds.variables.items():
            if var.dtype.kind == "f" and not np.all(np.isfinite(var.values)):
                viol.append(f"/{g}/{name} has non-finite values")
    if viol:
        return viol, info
    tr, me = tree["truth"], tree["measured"]
    c0, c1 = float(tr.contact_start), float(tr.contact_end)
    va, va1, vb, vb1 = (float(tr[k]) for k in ("v_a_pre", "v_a_post", "v_b_pre", "v_b_post"))
    m_b = float(me.hammer_mass_eff)
    P = float(tr.impulse)
    t_end = float(tr.t_truth[-1])
    info.update(contact_ms=(c1 - c0) * 1e3, peak_N=float(tr.peak_force), n_contacts=int(tr.attrs.get("n_contacts", 1)),
                record_after_s=t_end - c1)
    need = POST_SAMPLES / float(scene.p("sensors.joint_encoder_rate"))
    if not (c0 < c1 and t_end - c1 >= need):
        viol.append(f"contact [{c0:.4g}, {c1:.4g}] s is followed by {max(t_end - c1, 0.0):.3g} s of recording, less "
                    f"than {POST_SAMPLES} joint-encoder samples ({need:.3g} s): the trial's outputs are not recorded")
    if not vb1 < vb:
        viol.append(f"the contact did not slow the hammer (v_b {vb:.4g} -> {vb1:.4g} m/s)")
    e_true = (va1 - vb1) / (vb - va) if vb != va else math.nan
    m_true = m_b * (vb - vb1) / (va1 - va) if va1 != va else math.inf
    info.update(e_true=e_true, m_true=m_true)
    gap = abs(P - m_b * (vb - vb1))
    bound = _momentum_bound(scene, tr, c0, c1, P, m_b, vb1)
    info.update(momentum=gap / abs(P) if P else math.inf, momentum_bound=bound / abs(P) if P else math.inf)
    if not gap <= bound:
        viol.append(f"hammer momentum change {m_b * (vb - vb1):.6g} N s vs contact impulse {P:.6g} N s: "
                    f"{gap:.3g} N s apart, the pendulum's momentum balance allows {bound:.3g}")
    if _passive(scene, tree):
        t = tr.t_truth.values
        E = np.asarray(tr.energy.values, float)
        q = np.asarray(tr.q.values, float)
        q0 = np.asarray(me.q_cmd.values, float)
        tau = np.asarray(me.tau_cmd.values, float)
        tau_gc = tau[0] if tau.ndim == 2 and tau.shape[0] else np.zeros(q0.size)
        if tau.ndim == 2 and not np.array_equal(tau, np.broadcast_to(tau_gc, tau.shape)):
            viol.append("Zero-gain servo torque is not constant")
        Ep = E - (q - q0[None, :]) @ tau_gc
        Ea = Ep[t >= c0]
        ke = 0.5 * m_b * vb * vb
        rise = float(np.max(Ea - np.minimum.accumulate(Ea))) if Ea.size else 0.0
        info["energy_rise"] = rise / ke
        if rise > ENERGY_RTOL * ke:
            viol.append(f"energy rises by {rise:.3g} J after the touch in a passive scene "
                        f"({rise / ke:.2g} of the hammer's kinetic energy; tolerance {ENERGY_RTOL:g})")
        if not e_true <= 1.0 + 1e-9:
            viol.append(f"true restitution {e_true:.6g} > 1 in a passive scene")
    # flexible base: the structure is damped (and the emulation loop must be stable), so its
    # motion after the impact must not grow
    if "base_position" in tr.variables:
        t = tr.t_truth.values
        after = t > c1
        amp = np.max(np.abs(np.concatenate([np.asarray(tr.base_position.values, float),
                                            np.asarray(tr.base_rotation.values, float) * 0.5], axis=1)[after]),
                     axis=1) if after.any() else np.zeros(0)
        if amp.size >= 8:
            k = amp.size // 4
            first, last = float(np.max(amp[:k])), float(np.max(amp[-k:]))
            info["base_growth"] = last / first if first > 0 else math.inf
            if last > GROWTH_TOL * first:
                viol.append(f"base motion grows after the impact (peak {first:.3g} in the first quarter of the "
                            f"record, {last:.3g} in the last): unstable emulation loop or integration")
    # joint limits (the rig has no end stops): reported, not an invariant (see the README)
    from .robot import load_robot
    robot = load_robot(scene.p("robot"))
    q = np.asarray(tr.q.values, float)
    na = q.shape[1]
    over = np.maximum(q - robot.q_upper[None, :na], robot.q_lower[None, :na] - q)
    info["beyond_limit_deg"] = max(0.0, math.degrees(float(np.max(over))))
    # identification
    info.update(excluded=bool(ident.excluded), reason=ident.reason, m_eff=ident.m_eff, e=ident.e)
    if not ident.excluded:
        if not (math.isfinite(ident.m_eff) and ident.m_eff > 0 and math.isfinite(ident.e)):
            viol.append(f"identified m* = {ident.m_eff!r}, e = {ident.e!r}: not finite and positive, and the "
                        "trial is not excluded")
        else:
            if not (0.0 <= ident.e <= E_UPPER):
                viol.append(f"identified e = {ident.e:.4g} outside [0, {E_UPPER}]")
            if scene.base == "fixed":
                m0 = _m0({"q_paper_deg": scene.q_paper_deg})
                info["m0"] = m0
                # (at a pose where n leaves the range, m0 = inf: any finite m* > 0 is a lower value
                # only by the identification's resolution, so the bound does not apply)
                if math.isfinite(m0) and not ident.m_eff >= MEFF_LOWER * m0:
                    viol.append(f"identified m* = {ident.m_eff:.4g} kg below {MEFF_LOWER} x the Ex-IIT "
                                f"m* (lambda = 0) {m0:.4g} kg")
            info["ident_vs_truth"] = _rel(ident.m_eff, m_true)
    return viol, info


def run_case(case: StressCase, folder: str | os.PathLike, *, write: bool = True) -> StressResult:
    """Run one stress case through the trial pipeline (scene -> simulate -> invariants ->
    file) and classify it."""
    from . import archive
    from .rig import build, simulate

    folder = Path(folder)
    path = folder / (f"{abs(hash(case.label)) & 0xFFFFFFFF:08x}.nc")
    t0 = time.perf_counter()

    def done(status, reason, info=None):
        if status != "passed" and path.exists():
            status, reason = "failed", f"{reason}; and a file was left behind"
        return StressResult(case, status, reason, time.perf_counter() - t0, info or {})

    try:
        scene = case.make()
    except InputError as exc:
        return done("refused", f"scene: {exc}")
    except Exception as exc:  # noqa: BLE001
        return done("failed", f"{type(exc).__name__} while making the scene: {exc}")
    try:
        try:
            build(scene, integration=case.integration)
        except TypeError:       # a rig whose build() does not take (and check) integration overrides
            build(scene)
    except InputError as exc:
        return done("refused", str(exc))
    except ValueError as exc:   # refused before simulating, but not as the rig's InputError
        return done("refused", f"[{type(exc).__name__}, not InputError] {exc}")
    except Exception as exc:  # noqa: BLE001
        return done("failed", f"{type(exc).__name__} while building the rig: {exc}")
    try:
        with np.errstate(all="ignore"):
            tree = simulate(scene, integration=case.integration)
    except InputError as exc:
        return done("failed", f"InputError after the rig was built (work started): {exc}")
    except SimulationError as exc:
        return done("blow-up", str(exc))
    except Exception as exc:  # noqa: BLE001 - anything else is a failure of the suite
        return done("failed", f"{type(exc).__name__} during simulation: {exc}")
    try:
        ident = _identify(tree)
    except Exception as exc:  # noqa: BLE001
        return done("failed", f"identification raised {type(exc).__name__}: {exc}")
    viol, info = check_invariants(scene, tree, ident)
    info["sim_s"] = time.perf_counter() - t0
    if viol:
        return done("failed", "; ".join(viol), info)
    if write:
        try:
            archive.write_trial(tree, path)
        except Exception as exc:  # noqa: BLE001
            return done("failed", f"write_trial raised {type(exc).__name__}: {exc}", info)
        if not path.is_file():
            return done("failed", "write_trial left no file", info)
        path.unlink()
    note = f"identification excluded the trial: {ident.reason}" if ident.excluded else ""
    return done("passed", note, info)


def run_stress(cases: Sequence[StressCase], *, write: bool = True,
               log: Callable[[str], None] | None = print) -> list[StressResult]:
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            res = run_case(case, tmp, write=write)
            out.append(res)
            if log:
                log(f"[stress] {res.status:8s} {res.seconds:6.2f} s  {case.axis}: {case.label}"
                    + (f" -- {res.reason[:160]}" if res.reason else ""))
        left = list(Path(tmp).iterdir())
        if left:  # pragma: no cover - run_case removes what it wrote
            raise AssertionError(f"stress cases left files behind: {left}")
    return out


def stress_summary(results: Sequence[StressResult]) -> dict[str, int]:
    s = {"run": len(results)}
    for k in ("passed", "refused", "blow-up", "failed"):
        s[k] = sum(r.status == k for r in results)
    s["excluded"] = sum(r.status == "passed" and bool(r.info.get("excluded")) for r in results)
    return s


def format_stress(results: Sequence[StressResult]) -> str:
    s = stress_summary(results)
    summary = _md(["cases run", "passed", "(of which identification excluded)", "refused with reason",
                   "reported blow-up (no file)", "failed"],
                  [[s["run"], s["passed"], s["excluded"], s["refused"], s["blow-up"], s["failed"]]])
    axes: dict[str, dict[str, int]] = {}
    for r in results:
        d = axes.setdefault(r.case.axis, {"run": 0, "passed": 0, "refused": 0, "blow-up": 0, "failed": 0})
        d["run"] += 1
        d[r.status] += 1
    per_axis = _md(["axis", "run", "passed", "refused", "blow-up", "failed"],
                   [[a, d["run"], d["passed"], d["refused"], d["blow-up"], d["failed"]] for a, d in axes.items()])
    rows = []
    for r in results:
        i = r.info
        meas = ""
        if "m_true" in i:
            meas = (f"contact {i['contact_ms']:.3g} ms, peak {i['peak_N']:.3g} N, m*_true {i['m_true']:.3g} kg, "
                    f"e_true {i['e_true']:.3f}")
            if not i.get("excluded") and math.isfinite(i.get("m_eff", math.nan)):
                meas += f"; m*_id {i['m_eff']:.3g} kg, e_id {i['e']:.3f}"
            if i.get("beyond_limit_deg", 0) > 0:
                meas += f"; beyond joint limit by {i['beyond_limit_deg']:.2f} deg"
        reason = r.reason.replace("|", "/").replace("\n", " ")
        rows.append([r.case.axis, r.case.label, f"**{r.status}**" if r.status in ("failed", "blow-up") else r.status,
                     f"{r.seconds:.2f}", reason[:220], meas])
    cases = _md(["axis", "case", "outcome", "time [s]", "reason / note", "measured"], rows)
    return "\n\n".join([summary, per_axis, cases])


# ---------------------------------------------------------------------------------------
# closed-form stress: Ex-IIT near singular configurations, eq 11 conditioning, lambda fit
# ---------------------------------------------------------------------------------------
def _q_dh(q_paper_deg) -> np.ndarray:
    from .paper import load_paper
    return np.radians(np.asarray(q_paper_deg, float) + np.asarray(load_paper()["offset_deg"], float))


def _eq11_diagnostics(robot, q, lam=None, n=(-1.0, 0.0, 0.0)) -> dict[str, float]:
    """Conditioning of eq 11 at one pose: cond(H + lambda), cond(G*_33), and the relative
    condition number of m* = 1 / (n^T G n) with respect to G, ``||G||_2 / (n^T G n)``."""
    from . import exiit
    data = robot.model.createData()
    G = exiit.exiit_fixed(robot, q, lam, data=data)[:3, :3]
    H = exiit.inertia(robot.model, data, q) + exiit.lambda_matrix(lam, robot.nv)
    nn = exiit.unit_direction(n)
    s = float(nn @ G @ nn)
    sv = np.linalg.svd(G, compute_uv=False)
    return dict(cond_H=float(np.linalg.cond(H)), cond_G=float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf,
                kappa_m=float(sv[0] / s) if s > 0 else math.inf, nGn=s)


def singular_pose(robot=None) -> tuple[float, float, float]:
    """Paper angles (q1*, q2*, q3*) [deg] of the stretched singularity where n = -x leaves the
    range of G*: the elbow straight (smallest singular value of the tip Jacobian), then q1,
    q2 such that ``n^T G* n = 0`` (wrist centre in the x-z plane, arm horizontal)."""
    from scipy.optimize import minimize, minimize_scalar

    from . import exiit
    from .robot import load_robot
    robot = robot or load_robot()
    data = robot.model.createData()

    def smin(q3):
        J = exiit.impact_jacobian(robot.model, data, _q_dh((0.0, 172.0, q3)), robot.impact_frame_id)[:3]
        return float(np.linalg.svd(J, compute_uv=False)[-1])

    q3 = float(minimize_scalar(smin, bounds=(-20.0, 20.0), method="bounded", options={"xatol": 1e-12}).x)

    def ratio(x):
        G = exiit.exiit_fixed(robot, _q_dh((x[0], x[1], q3)), data=data)[:3, :3]
        return float(G[0, 0] / np.trace(G))

    r = minimize(ratio, [-10.0, 180.0], method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-22,
                                                                      "maxiter": 4000})
    return float(r.x[0]), float(r.x[1]), q3


def closed_form_stress(*, log: Callable[[str], None] | None = print) -> dict[str, Any]:
    """Ex-IIT (eq 7, 8, 11) towards the stretched singularity (paper q3 -> 0) and along
    random poses: every m* must be finite and positive or exactly ``inf``; scalar and batch
    evaluations agree; plus eq 11's conditioning and the lambda sensitivity of the paper's
    design, and the lambda fit on ill-conditioned designs (when ``campaign.fit`` exists)."""
    from . import exiit
    from .paper import load_paper
    from .robot import load_robot
    from .robot.floating import BaseBody, attach_to_floating_base

    robot = load_robot()
    paper = load_paper()
    lam_hi = np.asarray(paper["table3"]["high"], float)
    frobot = attach_to_floating_base(robot, BaseBody(mass=150.0, inertia=np.diag([50.0, 50.0, 5.0])))
    rows, problems = [], []

    def check(label, m, kind):
        if isinstance(m, float) and (math.isnan(m) or m <= 0 or (math.isfinite(m) and m > 1e9)):
            problems.append(f"{label} ({kind}): m* = {m!r}")

    # the stretched singularity where n = -x leaves the range of G*: elbow straight (paper
    # q3*), arm horizontal (q2*), and the shoulder turned so the wrist centre lies in the
    # x-z plane (q1*; with the 0.15 m shoulder offset, joint 1 otherwise moves the tip along x)
    qs = singular_pose(robot)
    info_rows = []
    deltas = (1.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-8, 1e-10, 0.0)
    families = [("paper q3 = q3* + d", 2), ("paper q1 = q1* + d", 0),
                ("configuration 2 family: (0, 172, q3* + d)", None)]
    for fam, axis in families:
        poses = []
        for dlt in deltas:
            qp = np.array(qs, float) if axis is not None else np.array([0.0, 172.0, qs[2]])
            qp[2 if axis is None else axis] += dlt
            poses.append(qp)
        Q = np.array([_q_dh(qp) for qp in poses])
        for lam_name, lam in (("0", None), ("High", lam_hi)):
            batch = exiit.effective_mass_batch(robot, Q, lam=lam)
            prev = 0.0
            for dlt, q, mb in zip(deltas, Q, batch):
                ms = exiit.effective_mass(robot, q, lam=lam)
                mf = exiit.effective_mass(frobot, q, lam=lam)
                d = _eq11_diagnostics(robot, q, lam)
                label = f"{fam}, d = {dlt:g} deg, lambda {lam_name}"
                for kind, m in (("scalar", ms), ("batch", float(mb)), ("flexible eq 8", mf)):
                    if not (m == math.inf or (math.isfinite(m) and m > 0)):
                        problems.append(f"{label} ({kind}): m* = {m!r} is neither finite > 0 nor inf")
                # a finite value must be meaningful: its rounding error bound eps * kappa * cond(H)
                acc = np.finfo(float).eps * d["kappa_m"] * d["cond_H"] if math.isfinite(ms) else 0.0
                if math.isfinite(ms) and acc > 1e-2:
                    problems.append(f"{label}: finite m* = {ms:.4g} kg with a rounding error bound of {acc:.2g}")
                agree = (math.isinf(ms) and math.isinf(mb)) or (math.isfinite(ms) and math.isfinite(mb)
                                                                  and abs(ms - mb) <= 1e-6 * ms)
                if not agree:
                    problems.append(f"{label}: scalar {ms!r} vs batch {float(mb)!r}")
                if axis is not None and ms < prev:
                    problems.append(f"{label}: m* = {ms:.6g} falls while approaching the singularity")
                prev = ms
                rows.append(dict(family=fam, q3=dlt, lam=lam_name, m_scalar=ms, m_batch=float(mb), m_flex=mf,
                                 acc=acc, **d))
    del info_rows
    # random poses inside the limits, including poses pushed onto the singular set
    rng = np.random.default_rng(8)
    Q = rng.uniform(robot.q_lower, robot.q_upper, size=(2000, robot.nv))
    Q[:500, 2] = -np.pi / 2 + rng.normal(0, 1e-9, 500)     # elbow straight (paper q3 = 0) within 1e-9 rad
    batch = exiit.effective_mass_batch(robot, Q)
    n_inf = int(np.sum(np.isinf(batch)))
    bad = int(np.sum(~(np.isinf(batch) | ((batch > 0) & (batch < 1e9)))))
    if bad:
        problems.append(f"random poses: {bad} of {len(Q)} batch values neither finite positive (< 1e9 kg) nor inf")
    mism = 0
    for q, mb in zip(Q[::10], batch[::10]):
        ms = exiit.effective_mass(robot, q)
        if not ((math.isinf(ms) and math.isinf(mb)) or abs(ms - mb) <= 1e-9 * ms):
            mism += 1
    if mism:
        problems.append(f"random poses: {mism} scalar/batch disagreements")
    rnd = dict(n=len(Q), n_inf=n_inf, bad=bad, mismatches=mism, max_finite=float(np.max(batch[np.isfinite(batch)])))

    # eq 11 as a lambda estimator: sensitivity of ln m* to ln lambda on the paper's design
    sens = _lambda_sensitivity(robot, [_q_dh(paper["configurations"][c]) for c in (1, 2, 3)], lam_hi)
    fit = _fit_stress(robot, paper, log=log)
    if log:
        log(f"[closed-form] {len(rows)} singular-family evaluations, {len(Q)} random poses; "
            f"{len(problems)} problems; sensitivity cond {sens['cond']:.3g}")
    return dict(rows=rows, random=rnd, problems=problems, sensitivity=sens, fit=fit)


def _lambda_sensitivity(robot, Qs, lam, h: float = 1e-6) -> dict[str, Any]:
    """S_ij = d ln m*_i / d ln lambda_j (central differences) and cond(S)."""
    from . import exiit
    S = np.zeros((len(Qs), len(lam)))
    for i, q in enumerate(Qs):
        for j in range(len(lam)):
            up, dn = lam.copy(), lam.copy()
            up[j] *= 1 + h
            dn[j] *= 1 - h
            S[i, j] = (math.log(exiit.effective_mass(robot, q, lam=up)) -
                       math.log(exiit.effective_mass(robot, q, lam=dn))) / (2 * h)
    sv = np.linalg.svd(S, compute_uv=False)
    return dict(S=S, cond=float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf, lam=lam)


def _fit_stress(robot, paper, *, log=None) -> dict[str, Any]:
    """The lambda fit (``campaign.fit``) on a well-posed and on ill-conditioned designs:
    it must report its condition number and not return wild values."""
    try:
        from . import fit as fitmod
    except ImportError as exc:
        return dict(available=False, note=f"campaign.fit is not available yet ({exc})")
    return _run_fit_stress(fitmod, robot, paper, log=log)


def _run_fit_stress(fitmod, robot, paper, *, log=None) -> dict[str, Any]:
    """LambdaFit on synthetic m* (eq 11 at the paper's High lambda, lognormal noise): the
    paper's design, and designs that are ill-conditioned by construction. A fit passes when
    every value is finite and inside its bounds, the condition number is reported, and any
    component more than 2x off the truth (or whose CI misses it) is flagged not identifiable."""
    import warnings as _w

    from . import exiit
    lam_true = np.asarray(paper["table3"]["high"], float)
    qs = singular_pose(robot)
    c = {k: np.array(v, float) for k, v in paper["configurations"].items()}
    designs = [
        ("paper configurations 1-3, 2 % noise", [c[1], c[2], c[3]], 0.02),
        ("paper configurations 1-3, 20 % noise", [c[1], c[2], c[3]], 0.20),
        ("configuration 2 alone (1 pose, 3 parameters)", [c[2]], 0.02),
        ("three poses within 0.01 deg of configuration 2", [c[2], c[2] + [0, 0, 0.01], c[2] + [0, 0.01, 0]], 0.02),
        ("three poses near the stretched singularity", [np.array(qs) + [0, 0, 0.5], np.array(qs) + [0, 0, 1.0],
                                                         np.array(qs) + [1.0, 0, 0.5]], 0.02),
        ("configurations 1 and 3 (folded / intermediate only)", [c[1], c[3]], 0.02),
    ]
    rng = np.random.default_rng(15)
    out = []
    for label, poses, noise in designs:
        Q = np.repeat(np.array([_q_dh(p) for p in poses]), 5, axis=0)
        m = np.array([exiit.effective_mass(robot, q, lam=lam_true) for q in Q])
        m = m * np.exp(rng.normal(0.0, noise, m.size))
        est = fitmod.LambdaFit(robot, n_bootstrap=100, random_state=1, warn=True)
        with _w.catch_warnings(record=True) as caught:
            _w.simplefilter("always")
            t0 = time.perf_counter()
            try:
                est.fit(Q, m)
                err = ""
            except Exception as exc:  # noqa: BLE001
                err = f"{type(exc).__name__}: {exc}"
            sec = time.perf_counter() - t0
        row = dict(design=label, noise=noise, seconds=sec, warnings=len(caught))
        if err:
            row.update(ok=isinstance(err, str) and err.startswith("InputError"), error=err)
            out.append(row)
            continue
        lam = np.asarray(est.lambda_, float)
        ci = np.asarray(est.lambda_ci_, float)
        ident = np.asarray(getattr(est, "identifiable_", np.ones(lam.size, bool)), bool)
        cond = float(getattr(est, "condition_number_", math.nan))
        problems = []
        if not np.all(np.isfinite(lam)) or np.any(lam < 0) or np.any(lam > est.lambda_max * (1 + 1e-9)):
            problems.append("lambda not finite / outside its bounds")
        if math.isnan(cond):
            problems.append("no condition number")
        for j in range(lam.size):
            wild = not (0.5 * lam_true[j] <= lam[j] <= 2.0 * lam_true[j])
            missed = np.all(np.isfinite(ci[:, j])) and not (ci[0, j] <= lam_true[j] <= ci[1, j])
            if (wild or missed) and ident[j]:
                problems.append(f"lambda_{j + 1} = {lam[j]:.3g} (true {lam_true[j]:.3g}, CI [{ci[0, j]:.3g}, "
                                f"{ci[1, j]:.3g}]) reported identifiable")
        row.update(ok=not problems, problems=problems, lam=lam, ci=ci, identifiable=ident, cond=cond)
        out.append(row)
        if log:
            log(f"[fit] {label}: cond {cond:.3g}, lambda {np.round(lam, 3).tolist()}, identifiable "
                f"{ident.tolist()}, {len(caught)} warnings, {'ok' if not problems else problems}")
    return dict(available=True, rows=out, lam_true=lam_true,
                note=f"{sum(r['ok'] for r in out)} of {len(out)} designs behave (see the table)")


def format_closed_form(c: dict[str, Any]) -> str:
    rows = []
    for r in c["rows"]:
        if r["lam"] != "0" and r["q3"] not in (40.0, 1e-2, 0.0):
            continue
        def m(x):
            return "inf" if math.isinf(x) else f"{x:.4g}"
        rows.append([r["family"], f"{r['q3']:g}", r["lam"], m(r["m_scalar"]), m(r["m_batch"]), m(r["m_flex"]),
                     f"{r['cond_H']:.3g}", "inf" if math.isinf(r["cond_G"]) else f"{r['cond_G']:.3g}",
                     "inf" if math.isinf(r["kappa_m"]) else f"{r['kappa_m']:.3g}"])
    t1 = _md(["family", "paper q3 [deg]", "lambda", "m* eq 11 [kg]", "batch [kg]", "flexible eq 8 [kg]",
              "cond(H+lambda)", "cond(G*_33)", "kappa(m*) = ||G||/(n'Gn)"], rows)
    rnd = c["random"]
    s = c["sensitivity"]
    S = s["S"]
    t2 = _md(["configuration", "d ln m*/d ln lambda_1", "d ln m*/d ln lambda_2", "d ln m*/d ln lambda_3"],
             [[i + 1, *(f"{x:.3g}" for x in S[i])] for i in range(S.shape[0])])
    fit = c["fit"]
    lines = [
        t1, "",
        f"Random poses inside the joint limits (500 of them with the elbow straight to within 1e-9 rad): "
        f"{rnd['n']} evaluated, {rnd['n_inf']} returned inf, {rnd['bad']} neither finite-positive nor inf, "
        f"{rnd['mismatches']} scalar/batch disagreements; largest finite m* {rnd['max_finite']:.3g} kg.", "",
        f"Eq 11 as an estimator of lambda (paper's three configurations, n = -x, at the Table 3 High lambda): "
        f"condition number of the sensitivity matrix **{s['cond']:.3g}**.", "",
        t2, "",
        "Problems: " + ("none." if not c["problems"] else "; ".join(c["problems"])), "",
        "Lambda fit (`campaign.fit.LambdaFit`, synthetic m* from eq 11 at the Table 3 High lambda "
        "with lognormal noise, 5 trials per pose, 100 bootstrap resamples): " + fit["note"] + ".",
    ]
    if fit.get("rows"):
        frows = []
        for r in fit["rows"]:
            if "error" in r:
                frows.append([r["design"], "-", "-", "-", "-", r["warnings"], ("ok: " if r["ok"] else "") + r["error"][:90]])
                continue
            lam = ", ".join(f"{x:.3g}" for x in r["lam"])
            ci = ", ".join(f"[{a:.3g}, {b:.3g}]" for a, b in zip(r["ci"][0], r["ci"][1]))
            frows.append([r["design"], "inf" if math.isinf(r["cond"]) else f"{r['cond']:.3g}", lam, ci,
                          "".join("y" if x else "n" for x in r["identifiable"]), r["warnings"],
                          "ok" if r["ok"] else "; ".join(r["problems"])])
        lines += ["", _md(["design", "condition number", "lambda [kg m^2]", "95 % CI", "identifiable (1,2,3)",
                           "warnings", "verdict"], frows),
                  "", f"True lambda: {', '.join(f'{x:g}' for x in fit['lam_true'])} kg m^2."]
    return "\n".join(lines)
