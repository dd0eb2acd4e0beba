"""Work-precision: the rig's accuracy against its cost over solver settings."""

from __future__ import annotations

import dataclasses
import functools
import io
import math
import os
import statistics
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.vocabulary import FIXED, FLEXIBLE, HIGH, LOW, ZERO
from ..identify import identify_trial
from ..rig import build, simulate
from ..scene.description import make_scene
from .common import (
    ERR_FLOOR,
    REF_FACTOR,
    TARGET_FIXED,
    TARGET_FLEXIBLE,
    TARGET_REL_ERR,
    check_size,
    md_table,
    relative_error,
    short_error,
    timed_call,
)
from .naive import naive_trial


# ---------------------------------------------------------------------------------------
# work-precision
# ---------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class WPScene:
    """A representative scene of the work-precision benchmark."""

    label: str
    kwargs: dict

    def make(self):
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
        if self.naive:
            return naive_trial(scene)
        if self.default:
            return simulate(scene)
        return simulate(scene, integration={"substeps_contact": self.substeps_contact,
                                            "substeps_free": self.substeps_free})


def wp_scenes(*, size: str = "full", flexible: bool = True) -> list[WPScene]:
    """Representative scenes: configurations 2 (nearly stretched) and 3 (folded), ideal and
    default, Zero and High gains, fixed base and (when the rig accepts it) flexible base.
    ``size`` (:data:`~campaign.bench.common.SIZES`): ``quick`` keeps two scenes per base,
    ``smoke`` only the fixed-base default scene of configuration 2 at High gains."""
    high = WPScene("fixed default c2 high", dict(base=FIXED, config=2, gain=HIGH, speed=1.5))
    if check_size(size) == "smoke":
        return [high]
    out = [WPScene("fixed ideal c2", dict(base=FIXED, config=2, scene="ideal", speed=1.5)), high]
    if size == "full":
        out += [
            WPScene("fixed ideal c3", dict(base=FIXED, config=3, scene="ideal", speed=1.5)),
            WPScene("fixed default c2 zero", dict(base=FIXED, config=2, gain=ZERO, speed=1.5)),
            WPScene("fixed default c3 zero", dict(base=FIXED, config=3, gain=ZERO, speed=1.5)),
            WPScene("fixed default c3 high", dict(base=FIXED, config=3, gain=HIGH, speed=1.5)),
        ]
    if flexible:
        out += [
            WPScene("flexible loop c2 high", dict(base=FLEXIBLE, config=2, gain=HIGH, speed=1.5)),
            WPScene("flexible ideal-coupling c2 high",
                    dict(base=FLEXIBLE, config=2, gain=HIGH, speed=1.5, params={"ves.mode": "ideal"})),
        ]
        if size == "full":
            out += [
                WPScene("flexible loop c3 low", dict(base=FLEXIBLE, config=3, gain=LOW, speed=1.5)),
                WPScene("flexible ideal scene c2",
                        dict(base=FLEXIBLE, config=2, scene="ideal", speed=1.5, params={"ves.mode": "ideal"})),
            ]
    return out


def rig_available(scene) -> tuple[bool, str]:
    """Can the rig build this scene? (False, reason) while a base is not integrated yet."""
    try:
        build(scene)
    except (InputError, NotImplementedError, ImportError, AttributeError) as exc:
        return False, f"{type(exc).__name__}: {exc}"
    return True, ""


#: per size: the multiples of the default contact substeps swept, and how many of the free
#: substep multiples (None: all)
_SWEEP = {"full": ((0.125, 0.25, 0.5, 1, 2, 4, 8), None), "quick": ((0.25, 1, 4), 2), "smoke": ((1, 2), 1)}


def wp_settings(default_contact: int, default_free: int, *, size: str = "full",
                naive: bool = True, frees: Sequence[int] = (1, 2, 4)) -> list[Setting]:
    """The sweep around a scene's default (``default_contact``, ``default_free`` substeps per
    servo tick): contact substeps from 1/8x to 8x the default, free substeps ``frees`` x the
    default, a uniform 0.1 ms step (10 substeps per 1 ms tick everywhere) and the naive RK4.
    ``quick`` sweeps 1/4x, 1x and 4x with the first two ``frees``; ``smoke`` only 1x and 2x
    the default contact substeps at the default free substeps, without the uniform step and
    the naive RK4."""
    mults, n_free = _SWEEP[check_size(size)]
    frees = tuple(frees)[:n_free] if n_free else tuple(frees)
    contact = sorted({max(1, int(round(default_contact * m))) for m in mults})
    out = []
    for c in contact:
        for f in frees:
            f_abs = max(1, default_free * f)
            is_def = c == default_contact and f_abs == default_free
            out.append(Setting(f"rk4 {c}/{f_abs}", c, f_abs, default=is_def))
    if not any(s.default for s in out):   # pragma: no cover - the grid always holds it
        out.append(Setting(f"rk4 {default_contact}/{default_free}", default_contact, default_free, default=True))
    if size == "smoke":
        return out
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
        "m_eff": relative_error(ident.m_eff, ident_ref.m_eff),
        "e": relative_error(ident.e, ident_ref.e),
        "v_a_post": relative_error(float(tr.v_a_post), float(rr.v_a_post)),
        "v_b_post": relative_error(float(tr.v_b_post), float(rr.v_b_post)),
    }
    out["measured"], out["measured_worst"] = _channel_error(tree["measured"].to_dataset(), ref["measured"].to_dataset())
    out["truth"], out["truth_worst"] = _channel_error(tr.to_dataset(), rr.to_dataset())
    out["ident"] = max(out["m_eff"], out["e"])
    out["velocity"] = max(out["v_a_post"], out["v_b_post"])
    out["combined"] = max(out["ident"], out["velocity"])
    return out


def identify_tree(tree):
    """:func:`campaign.identify.identify_trial` of a simulated trial (its measured group and root attributes)."""
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
        for r, f in zip(rows, pareto_front(pts, time_tol=t), strict=True):
            r[key] = f
    for r in rows:
        r["noise"] = tol
    return tol


def work_precision(*, size: str = "full", repeats: int | None = None, flexible: bool = True,
                   log: Callable[[str], None] = print, only: str | None = None,
                   checkpoint: Callable[[dict], None] | None = None) -> dict[str, Any]:
    """Run the work-precision sweep; returns ``{"rows": [...], "scenes": [...], "skipped": [...]}``.

    Each row: scene, setting, substeps, steps, RHS evaluations, median/min/max wall and median
    CPU time per trial [s], and the errors of :func:`trial_errors`; ``front`` marks the Pareto
    front of (median wall time, max(rel. error of m*, e, v'_a, v'_b)) within its scene.
    ``size`` (:data:`~campaign.bench.common.SIZES`) chooses the scenes (:func:`wp_scenes`), the
    sweep (:func:`wp_settings`) and the default ``repeats`` (5, 3, 1).
    """

    repeats = repeats or {"full": 5, "quick": 3, "smoke": 1}[check_size(size)]
    rows, skipped, scenes = [], [], []
    for spec in wp_scenes(size=size, flexible=flexible):
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
        flex = scene.base != FIXED
        settings = wp_settings(dc, df, size=size, naive=not flex, frees=(1, 2, 4, 8) if flex else (1, 2, 4))
        n_rep = max(2, repeats - 2) if flex else repeats
        log(f"[wp] {spec.label}: default {dc}/{df}; reference {REF_FACTOR * dc}/{REF_FACTOR * df}; "
            f"{len(settings)} settings x {repeats} repeats")
        try:
            ref, ref_wall, _ = timed_call(functools.partial(simulate, scene, integration={
                "substeps_contact": REF_FACTOR * dc, "substeps_free": REF_FACTOR * df}))
            half = simulate(scene, integration={"substeps_contact": REF_FACTOR // 2 * dc,
                                                "substeps_free": REF_FACTOR // 2 * df})
        except Exception as exc:  # noqa: BLE001
            skipped.append((spec.label, f"reference failed: {type(exc).__name__}: {exc}"))
            log(f"[wp] {spec.label}: skipped, the reference failed ({type(exc).__name__}: {exc})")
            continue
        ident_ref = identify_tree(ref)
        ref_check = trial_errors(half, ref, identify_tree(half), ident_ref)
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
                _, w, c = timed_call(functools.partial(s.run, scene))
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
            errs = trial_errors(tree, ref, identify_tree(tree), ident_ref)
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
            log(f"[wp] {spec.label}: default {d['wall'] * 1e3:.0f} ms, m* {short_error(d['m_eff'])}, "
                f"e {short_error(d['e'])}, "
                f"v' {short_error(d['velocity'])}, front {'yes' if d['front'] else 'NO'}")
    return {"rows": rows, "scenes": scenes, "skipped": skipped, "repeats": repeats}


def wp_verdict(result: dict) -> list[str]:
    """Per scene: is the default on the front, within 1e-3 in m* and e, within the time target?"""
    lines = []
    for sc in result["scenes"]:
        mine = [r for r in result["rows"] if r["scene"] == sc["label"]]
        d = next(r for r in mine if r["default"])
        target = TARGET_FLEXIBLE if sc["label"].startswith(FLEXIBLE) else TARGET_FIXED
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
        dom = ", ".join(f"{r['setting']} ({r['wall'] * 1e3:.0f} ms, {short_error(r['combined'])})" for r in dominators)
        front_ok = sorted((r for r in mine if r.get("front") and "error" not in r and r is not d
                           and r["ident"] <= TARGET_REL_ERR), key=lambda r: r["wall"])
        alt = ""
        if not d["front"] and front_ok:
            b = front_ok[0]
            alt = (f" Fastest front setting within 1e-3: {b['setting']} ({b['wall'] * 1e3:.0f} ms, "
                   f"{b['rhs']} RHS evaluations vs {d['rhs']}; m* {short_error(b['m_eff'])}, e {short_error(b['e'])}, "
                   f"v' {short_error(b['velocity'])}).")
        lines.append(
            f"- {sc['label']}: default {d['setting']} {d['wall'] * 1e3:.0f} ms/trial "
            f"(target {target * 1e3:.0f} ms: {'met' if fast else 'missed'}); error m* {short_error(d['m_eff'])}, "
            f"e {short_error(d['e'])} (<= 1e-3: {'yes' if acc else 'NO'}), v' {short_error(d['velocity'])}; "
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
            short_error(r["m_eff"]), short_error(r["e"]), short_error(r["v_a_post"]), short_error(r["v_b_post"]),
            f"{short_error(r['measured'])} ({r['measured_worst']})", f"{short_error(r['truth'])} ({r['truth_worst']})",
            "/".join("yes" if r[k] else "no" for k in ("front", "front_cpu", "front_rhs")),
        ])
    return md_table(header, rows)


def format_wp_references(result: dict) -> str:
    rows = []
    for sc in result["scenes"]:
        h = sc["ref_half_error"]
        rows.append([sc["label"], f"{sc['default'][0]}/{sc['default'][1]}", f"{sc['ref'][0]}/{sc['ref'][1]}",
                     f"{sc['ref_wall'] * 1e3:.0f}", f"{sc['m_eff']:.4g}", f"{sc['e']:.4f}",
                     short_error(h["ident"]), short_error(h["velocity"]), short_error(h["truth"])])
    return md_table(["scene", "default c/f", "reference c/f", "reference wall [ms]", "m* ref [kg]", "e ref",
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
    for ax, label in zip(list(axes.flat)[:n], labels, strict=True):     # a last row may have spare panels
        mine = [r for r in result["rows"] if r["scene"] == label and math.isfinite(r.get("wall", math.nan))]
        for key, name, marker in series:
            t = np.array([r["wall"] * 1e3 for r in mine])
            e = np.array([max(r[key], ERR_FLOOR) for r in mine])
            ax.scatter(t, e, marker=marker, s=22, alpha=0.75, label=name)
        front = sorted((r["wall"] * 1e3, max(r["combined"], ERR_FLOOR)) for r in mine if r["front"])
        if front:
            ax.plot(*zip(*front, strict=True), "k--", lw=0.8, label="Pareto front (m*, e, v')")
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
        target = TARGET_FLEXIBLE if label.startswith(FLEXIBLE) else TARGET_FIXED
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
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return write_atomic(path, buf.getvalue())
