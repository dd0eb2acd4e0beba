"""Figure 9: manipulator base motion after impact, configurations 1 and 2, High vs Low gains.

One panel per configuration; each shows the x component of the emulated base position
(measured channel ``base_position``: the structure tip's displacement from its initial
position) of one flexible-base trial per gain set, against the time from the contact start
found in the measured piezo force, in periods T_1 of the trial's own structure (its first
mode with the arm locked on top, from the scene stored in the trial), so a slow
space-class structure and a stiff mast are drawn on the same footing. Each panel states the maximum amplitude after impact per
gain set and the reduction Low gives against High, beside the paper's 20-30 %
(``figure9_low_vs_high_reduction`` of ``config/paper.yaml``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...archive import open_trial_arrays
from ...core.vocabulary import figure_cells
from ...identify import detect_contact
from ...rig.trial import structure_modes
from ...scene.description import Scene, structure_of
from . import style

__all__ = ["gains", "series", "draw", "make"]


def gains() -> tuple[str, str]:
    """The two gain sets Figure 9 compares, in drawing order, the lower first (its cells in
    ``config/paper.yaml``)."""
    low, high = dict.fromkeys(g for _, _, g in figure_cells("fig9"))
    return low, high


def series(trial: str | os.PathLike) -> dict:
    """Base x displacement of one flexible-base trial after its contact start.

    Returns
    -------
    dict
        ``t`` [s] from the contact start, ``x`` [mm], ``max_amplitude`` [mm] (largest
        ``|x|`` after the contact start), ``T1`` [s] (first-mode period of the trial's
        structure with the arm on top), ``structure``, ``speed`` [m/s], ``config``, ``gain``.
    """
    measured = open_trial_arrays(trial, group="measured")   # plain arrays: the job never imports xarray
    if "base_position" not in measured.variables:
        raise ValueError(f"{trial}: no base_position channel; Figure 9 needs a flexible-base trial")
    contact = detect_contact(np.asarray(measured["t_force"].values, float),
                             np.asarray(measured["f_piezo"].values, float),
                             float(measured["piezo_full_scale"].values))
    if contact.n_contacts == 0:
        raise ValueError(f"{trial}: no contact found in the piezo force; Figure 9 needs an impact")
    t = np.asarray(measured["t_base"].values, float) - contact.start
    x = 1e3 * np.asarray(measured["base_position"].values, float)[:, list(measured["axis"].values).index("x")]
    after = t >= 0
    scene = Scene.from_json(str(measured.attrs["scene_json"]))
    return {"t": t, "x": x, "max_amplitude": float(np.max(np.abs(x[after]))) if after.any() else float("nan"),
            "T1": 1.0 / float(structure_modes(scene)[0]),
            "structure": structure_of(scene.param_dict),
            "speed": float(measured.attrs.get("speed", np.nan)), "config": measured.attrs.get("config", "?"),
            "gain": str(measured.attrs.get("gain", "?"))}


def draw(trials: Mapping[str, str | os.PathLike], *, paper: Mapping[str, Any], t_min: float = -0.05):
    """Draw Figure 9.

    Parameters
    ----------
    trials : mapping
        ``{"<config>-<gain>": trial file}`` for configurations 1, 2 and gains low, high
        (e.g. ``{"1-low": ..., "1-high": ..., "2-low": ..., "2-high": ...}``).
    t_min : float
        Start of the time axis relative to the contact [first-mode periods T_1].

    Returns
    -------
    matplotlib.figure.Figure
    """
    configs = sorted({int(k.split("-")[0]) for k in trials})
    low, high = gains()
    for c in configs:
        for g in (low, high):
            if f"{c}-{g}" not in trials:
                raise ValueError(f"Figure 9 needs a trial for configuration {c}, {g} gains (key '{c}-{g}')")
    lo, hi = (float(v) for v in paper["figure9_low_vs_high_reduction"])
    fig, axes = style.new_figure(len(configs), 1, width=6.0, height=2.6 * len(configs) + 0.6, sharex=True,
                                 sharey=True, squeeze=False)
    t_max = 0.0
    speeds = set()
    periods = {}
    for ax, c in zip(axes[:, 0], configs, strict=True):
        amp = {}
        for g in (low, high):
            d = series(trials[f"{c}-{g}"])
            amp[g] = d["max_amplitude"]
            speeds.add(d["speed"])
            periods[d["structure"] or "structure"] = d["T1"]
            t_max = max(t_max, float(d["t"][-1]) / d["T1"])
            ax.plot(d["t"] / d["T1"], d["x"], color=style.GAIN_COLOR[g], lw=1.1,
                    label=f"{style.GAIN_LABEL[g]}: max |x| = {amp[g]:.2f} mm")
        ax.axvline(0.0, color=style.PAPER_COLOR, lw=0.6, ls=":")
        reduction = 1.0 - amp[low] / amp[high] if amp[high] > 0 else float("nan")
        ax.set_title(f"({chr(ord('a') + configs.index(c))}) configuration {c}", loc="left")
        ax.set_ylabel("base displacement x [mm]")
        ax.legend(loc="upper right", title=f"Low reduces the maximum amplitude by {100 * reduction:.0f} % "
                           f"against High (paper: {100 * lo:.0f}-{100 * hi:.0f} %)", title_fontsize=7.5,
                           framealpha=0.9, alignment="left")
    ymin, ymax = axes[0, 0].get_ylim()  # shared by the panels
    axes[0, 0].set_ylim(ymin, ymax + 0.5 * (ymax - ymin))  # room for the legends above the curves
    axes[-1, 0].set_xlabel("time after the contact start / first-mode period T_1 ("
                           + ", ".join(f"{k.replace('_', ' ')}: T_1 = {v:.3g} s" for k, v in sorted(periods.items()))
                           + ")")
    axes[-1, 0].set_xlim(t_min, t_max)
    speed = ", ".join(f"{s:g}" for s in sorted(speeds))
    fig.suptitle(f"Figure 9: manipulator base motion after impact (flexible base, impact at {speed} m/s)",
                 fontsize=9.5)
    return fig


def make(trials: Mapping[str, str | os.PathLike], png: str | os.PathLike, pdf: str | os.PathLike | None = None, *,
         paper: Mapping[str, Any]):
    """Draw Figure 9 and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw(trials, paper=paper), png, pdf)
