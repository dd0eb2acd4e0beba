"""Validity map of eq 8: identified m* over eq 8's prediction against contact duration / period.

Eq 8 treats the base as a free body during the contact (the structure's spring and damper
transmit no impulse). That holds when the contact is short against the structure's
periods; this figure shows, from a sweep of structure stiffnesses
(the study :mod:`campaign.studies.space_structure`, data ``eq8_validity.csv``), how far the
identified m* departs from eq 8 as the contact duration T_c grows against the first-mode
period T_1 (arm on top), with the band where they agree within a tolerance shaded and the
largest ratio below which every point lies in it marked. The measured map and what it
shows: user guide, *Calibration and validation*, "Two structures and the validity of eq 8"
(``docs/calibration.rst``).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable, Mapping

import numpy as np

from ...core.vocabulary import HIGH, LOW, ZERO
from . import style

__all__ = ["read_rows", "holds_below", "draw_validity", "make"]

#: marker and colour per series: the four Table 4 cells, the passive arm (lambda = 0)
_SERIES = {"1-low": ("o", style.GAIN_COLOR[LOW]), "1-high": ("o", style.GAIN_COLOR[HIGH]),
           "2-low": ("s", style.GAIN_COLOR[LOW]), "2-high": ("s", style.GAIN_COLOR[HIGH]),
           "passive 1": ("^", style.GAIN_COLOR[ZERO]), "passive 2": ("v", style.GAIN_COLOR[ZERO])}


def read_rows(path: str | os.PathLike) -> list[dict]:
    """The validity map's CSV as rows of ``cell``, ``ratio`` (T_c/T_1), ``eq8``,
    ``identified``, ``truth`` [kg] and ``structure``."""
    rows = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            rows.append({"structure": r["structure"], "cell": r["cell"], "ratio": float(r["Tc_over_T1"]),
                         "eq8": float(r["eq8_kg"]), "identified": float(r["identified_kg"]),
                         "truth": float(r["truth_kg"])})
    if not rows:
        raise ValueError(f"{path}: no rows; the validity map needs the sweep's data")
    return rows


def holds_below(rows: Iterable[Mapping], *, key: str = "identified", tolerance: float = 0.05) -> float:
    """Largest T_c/T_1 below which every point's ``key`` / eq 8 lies within ``tolerance``
    (0.0 when the smallest ratio already misses)."""
    ok = 0.0
    for ratio, err in sorted((r["ratio"], abs(r[key] / r["eq8"] - 1.0)) for r in rows):
        if err > tolerance:
            break
        ok = ratio
    return ok


def draw_validity(rows: Iterable[Mapping], *, tolerance: float = 0.05):
    """Draw the map: identified m* / eq 8 - 1 [%] against T_c/T_1 (log axis), one series per
    Table 4 cell and per passive configuration, the +-tolerance band shaded, and the ratio
    below which every calibrated (and every passive) point is inside it marked."""
    rows = list(rows)
    fig, axes = style.new_figure(1, 1, width=7.5, height=3.6, squeeze=False)
    ax = axes[0, 0]
    ax.axhspan(-100 * tolerance, 100 * tolerance, color="#dddddd", zorder=0,
               label=f"eq 8 within {100 * tolerance:.0f} %")
    for cell in sorted({r["cell"] for r in rows}):
        marker, color = _SERIES.get(cell, ("x", style.PAPER_COLOR))
        pts = sorted((r["ratio"], 100 * (r["identified"] / r["eq8"] - 1)) for r in rows if r["cell"] == cell)
        x, y = np.array(pts).T
        ax.plot(x, y, ls="none", marker=marker, ms=4, mfc="none" if cell.startswith("passive") else color,
                color=color, label=cell + (" (lambda = 0)" if cell.startswith("passive") else ""))
    for group, ls in (("calibrated", "-"), ("passive", "--")):
        sel = [r for r in rows if r["cell"].startswith("passive") == (group == "passive")]
        if sel:
            r_ok = holds_below(sel, tolerance=tolerance)
            if r_ok > 0:
                ax.axvline(r_ok, color=style.PAPER_COLOR, lw=0.8, ls=ls)
                ax.text(r_ok, ax.get_ylim()[1], f" {group}: T_c/T_1 <= {r_ok:.3g}", fontsize=7, va="top",
                        rotation=90, ha="right")
    ax.set_xscale("log")
    ax.axhline(0.0, color=style.PAPER_COLOR, lw=0.5)
    ax.set_xlabel("contact duration / first-mode period T_c / T_1")
    ax.set_ylabel("identified m* / eq 8 - 1 [%]")
    ax.legend(fontsize=6.5, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.suptitle("Where eq 8 (flexible base as a free body) predicts the identified m*", fontsize=9.5)
    return fig


def make(csv_path: str | os.PathLike, png: str | os.PathLike, pdf: str | os.PathLike | None = None, *,
         tolerance: float = 0.05):
    """Draw the map from its CSV and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw_validity(read_rows(csv_path), tolerance=tolerance), png, pdf)
