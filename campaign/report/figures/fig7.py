"""Figure 7: observed restitution coefficient per configuration and gain set (Z/L/H).

Every identified fixed-base trial is one marker (Z, L, H) at its configuration; excluded
trials are left out and counted. The paper's average e (``restitution_mean`` of
``config/paper.yaml``) is the dotted line, the campaign's own mean the solid one: the paper
found e independent of configuration and gains.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...core.vocabulary import FIXED
from ...identify.table import read_identification
from . import style

__all__ = ["draw", "make"]


def draw(ident_tables: Sequence[str | os.PathLike], *, paper: Mapping[str, Any], base: str = FIXED):
    """Draw Figure 7 from identification tables (:func:`campaign.identify.table.identify_trials`).

    Parameters
    ----------
    ident_tables : sequence of path-like
        Identification CSVs; rows of other bases are ignored.
    base : {"fixed", "flexible"}

    Returns
    -------
    matplotlib.figure.Figure
    """
    rows = [r for r in read_identification(ident_tables) if r["base"] == base]
    if not rows:
        raise ValueError(f"no {base}-base trial in the identification tables {list(map(str, ident_tables))}")
    e_paper = float(paper["restitution_mean"])
    fig, ax = style.new_figure(width=5.8, height=3.6)
    info = style.cell_scatter(ax, rows, "e")
    kept = [r["e"] for r in rows if not r["excluded"] and np.isfinite(r["e"])]
    ax.axhline(e_paper, color=style.PAPER_COLOR, ls=":", lw=1.4, label=style.paper_label(f"mean e = {e_paper:g}"))
    if kept:
        mean = float(np.mean(kept))
        ax.axhline(mean, color="#225588", lw=1.0,
                   label=f"this campaign: mean e = {mean:.3f} (sd {float(np.std(kept, ddof=1)) if len(kept) > 1 else 0.0:.3f})")
    ax.set_ylim(0.0, 1.0)
    ax.set_ylabel("restitution coefficient e [1]")
    ax.legend(loc="lower left", ncol=2)
    note = f"{info['n']} trials" + (f", {info['excluded']} excluded" if info["excluded"] else "")
    ax.set_title(f"Figure 7: observed restitution coefficient, {base} base ({note})")
    return fig


def make(ident_tables: Sequence[str | os.PathLike], png: str | os.PathLike, pdf: str | os.PathLike | None = None,
         *, paper: Mapping[str, Any], base: str = FIXED):
    """Draw Figure 7 and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw(ident_tables, paper=paper, base=base), png, pdf)
