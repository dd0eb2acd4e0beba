"""Figure 6: observed effective mass per configuration and gain set (Z/L/H).

Every identified fixed-base trial is one marker (Z, L, H for zero, low, high gains) at its
configuration; excluded trials (:mod:`campaign.identify`) are left out and counted. The
paper's Table 2 is drawn beside them (``config/paper.yaml``): the experiments' m2 (zero
and low gains) across the Z and L columns, m3 (high gains) across the H column, and the
link-dynamics model m1 (lambda = 0) as a dashed line across the configuration.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

from ...core import vocabulary
from ...core.vocabulary import FIXED
from ...identify.table import read_identification
from . import style

__all__ = ["draw", "make"]


def draw(ident_tables: Sequence[str | os.PathLike], *, paper: Mapping[str, Any], base: str = FIXED):
    """Draw Figure 6 from identification tables (:func:`campaign.identify.table.identify_trials`).

    Parameters
    ----------
    ident_tables : sequence of path-like
        Identification CSVs; rows of other bases are ignored.
    base : {"fixed", "flexible"}
        The base whose trials are drawn (the paper's Figure 6: fixed).

    Returns
    -------
    matplotlib.figure.Figure
    """
    rows = [r for r in read_identification(ident_tables) if r["base"] == base]
    if not rows:
        raise ValueError(f"no {base}-base trial in the identification tables {list(map(str, ident_tables))}")
    table2 = paper["table2"]
    # Table 2's experiment columns, each across the gain sets of its class (config/paper.yaml)
    columns = {column: vocabulary.gain_classes()[cls] for column, cls in vocabulary.table2_columns().items()}
    legend = "; ".join(f"{column}: {', '.join(style.GAIN_MARKER[g].strip('$') for g in gains)}"
                       for column, gains in columns.items())
    fig, ax = style.new_figure(width=5.8, height=3.8)
    info = style.cell_scatter(ax, rows, "m_eff")
    first = True
    for c in info["configs"]:
        if c not in table2["m1"]:
            continue
        off = style.GAIN_OFFSET
        kw = dict(color=style.PAPER_COLOR, lw=2.2)
        for k, (column, gains) in enumerate(columns.items()):
            ax.hlines(table2[column][c], c + off[gains[0]] - 0.09, c + off[gains[-1]] + 0.09, **kw,
                      label=style.paper_label(f"Table 2 experiments ({legend})") if first and k == 0 else None)
        ax.hlines(table2["m1"][c], c - 0.45, c + 0.45, color=style.PAPER_COLOR, lw=0.9, ls="--",
                  label=style.paper_label("Table 2 link dynamics m1 (lambda = 0)") if first else None)
        first = False
    ax.set_ylabel("effective mass m* [kg]")
    ax.set_ylim(bottom=0)
    ax.legend(loc="upper left", ncol=1)
    note = f"{info['n']} trials" + (f", {info['excluded']} excluded" if info["excluded"] else "")
    ax.set_title(f"Figure 6: observed effective mass, {base} base ({note})")
    return fig


def make(ident_tables: Sequence[str | os.PathLike], png: str | os.PathLike, pdf: str | os.PathLike | None = None,
         *, paper: Mapping[str, Any], base: str = FIXED):
    """Draw Figure 6 and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw(ident_tables, paper=paper, base=base), png, pdf)
