"""The shared look of the campaign's figures and their atomic saving (PNG + PDF).

Import this module before ``matplotlib.pyplot`` anywhere in :mod:`campaign.report.figures`: it
selects the non-interactive Agg backend, so figures render on machines without a display
(CI, cluster nodes), and sets the rc parameters :data:`RC` of every figure.
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg", force=True)

import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
import numpy as np

from ...core.files import write_atomic
from ...core.vocabulary import HIGH, LOW, ZERO, gain_sets

__all__ = ["plt", "GAINS", "GAIN_LABEL", "GAIN_COLOR", "GAIN_MARKER", "PAPER_COLOR", "TRUTH_COLOR", "RC",
           "GAIN_OFFSET", "new_figure", "save", "paper_label", "cell_scatter"]

#: gain sets in the paper's order and how every figure draws them (Z/L/H as in Figures 6-7)
GAINS = gain_sets()
GAIN_LABEL = {ZERO: "Zero gains (Z)", LOW: "Low gains (L)", HIGH: "High gains (H)"}
GAIN_MARKER = {ZERO: "$Z$", LOW: "$L$", HIGH: "$H$"}
GAIN_COLOR = {ZERO: "#1b9e77", LOW: "#7570b3", HIGH: "#d95f02"}
PAPER_COLOR = "#444444"
TRUTH_COLOR = "#999999"

#: rc settings of every figure: readable at the size of a journal column
RC = {
    "font.size": 9.0,
    "axes.titlesize": 9.5,
    "axes.labelsize": 9.0,
    "legend.fontsize": 7.5,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.5,
    "lines.linewidth": 1.2,
    "savefig.dpi": 200,
    "pdf.fonttype": 42,  # TrueType in PDFs: text stays text
    "svg.fonttype": "none",
}


matplotlib.rcParams.update(RC)


def new_figure(nrows: int = 1, ncols: int = 1, *, width: float = 6.5, height: float = 3.2, **kwargs):
    """A figure and its axes (``plt.subplots`` arguments), constrained layout, size in inches."""
    return plt.subplots(nrows, ncols, figsize=(width, height), layout="constrained", **kwargs)


def paper_label(text: str) -> str:
    """Legend label of a published value: ``"paper: <text>"``."""
    return f"paper: {text}"


#: OpenType tables left out of the fonts embedded in PDFs (see :func:`_lean_pdf_fonts`)
PDF_DROPPED_FONT_TABLES = ("GSUB", "GPOS", "GDEF", "kern")


@contextlib.contextmanager
def _lean_pdf_fonts():
    """Embed PDF fonts without their glyph substitution, positioning and kerning tables.

    With ``pdf.fonttype`` 42 matplotlib embeds a subset of each TrueType font, made by
    fontTools with its default options, which decode and prune the font's GSUB/GPOS
    lookups: 0.15-0.2 s of CPU per figure, a third of writing the PDF. A PDF never uses
    these tables: matplotlib lays the text out itself (from the full font) and writes
    every glyph's position into the page, and viewers draw the glyphs where the page puts
    them. So the pages stay the same (the tests compare every content stream) and only the
    embedded font files shrink. Done by extending the options matplotlib asks fontTools
    for, for the duration of one ``savefig``; if matplotlib stops subsetting this way the
    fonts are simply embedded as before.
    """
    try:
        from fontTools import subset as ft_subset
    except ImportError:  # pragma: no cover - fontTools is a matplotlib dependency
        yield
        return
    base = ft_subset.Options

    class Options(base):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.drop_tables = [*self.drop_tables, *PDF_DROPPED_FONT_TABLES]

    ft_subset.Options = Options
    try:
        yield
    finally:
        ft_subset.Options = base


def save(fig, png: str | os.PathLike, pdf: str | os.PathLike | None = None) -> list[Path]:
    """Save ``fig`` as PNG (and PDF), then close it.

    Both are rendered in memory first, then each is written atomically
    (:func:`campaign.core.files.write_atomic`): a failed rendering writes nothing, and a killed
    job or a full disk never leaves a half-written figure under its final or a temporary name.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    images = []
    for path, fmt in ((png, "png"), (pdf, "pdf")):
        if path is None:
            continue
        buf = io.BytesIO()
        metadata = {"Creator": "campaign"} if fmt == "png" else {"Creator": "campaign", "CreationDate": None}
        with _lean_pdf_fonts() if fmt == "pdf" else contextlib.nullcontext():
            fig.savefig(buf, format=fmt, metadata=metadata)
        images.append((path, buf.getvalue()))
        # the first save laid the figure out (constrained layout: 0.1-0.3 s of text
        # measuring); the next one keeps those positions instead of redoing it
        fig.set_layout_engine("none")
    plt.close(fig)
    return [write_atomic(path, data) for path, data in images]


#: horizontal offset of each gain set around its configuration in Figures 6-7
GAIN_OFFSET = {ZERO: -0.22, LOW: 0.0, HIGH: 0.22}


def cell_scatter(ax, rows, column: str, *, configs=None) -> dict:
    """Scatter one identified quantity per configuration (x) and gain set (Z/L/H markers).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    rows : list of dict
        Identification rows (:func:`campaign.identify.table.read_identification`); excluded trials
        are skipped and counted.
    column : str
        The quantity (``"m_eff"``, ``"e"``).
    configs : sequence of int, optional
        Configurations on the x axis (default: those in ``rows``).

    Returns
    -------
    dict
        ``configs`` drawn, ``n`` trials drawn, ``excluded`` trials skipped,
        ``mean[(config, gain)]`` of the drawn values.
    """

    kept = [r for r in rows if not r["excluded"] and np.isfinite(r[column])]
    configs = sorted(configs if configs is not None else {int(r["config"]) for r in kept})
    means = {}
    for gain in GAINS:
        xs, ys = [], []
        for c in configs:
            vals = [r[column] for r in kept if r["gain"] == gain and int(r["config"]) == c]
            if vals:
                means[(c, gain)] = float(np.mean(vals))
            xs += [c + GAIN_OFFSET[gain]] * len(vals)
            ys += vals
        if xs:
            ax.plot(xs, ys, ls="none", marker=GAIN_MARKER[gain], ms=7, color=GAIN_COLOR[gain], alpha=0.85,
                    label=GAIN_LABEL[gain])
    ax.set_xticks(configs, [f"Configuration {c}" for c in configs])
    ax.set_xlim(min(configs) - 0.5, max(configs) + 0.5)
    return {"configs": configs, "n": sum(1 for r in kept if int(r["config"]) in configs),
            "excluded": len(rows) - len(kept), "mean": means}
