"""The campaign's report: Tables 2-4 beside the paper's values, the figures
(:mod:`campaign.report.figures`, one module per figure) and HTML pages.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`).
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "figures", "Table", "table2", "table3", "table4", "write_tables", "fit_gain_classes", "TABLE_FILES",
    "markdown_page", "markdown_to_html",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "tables": ("Table", "table2", "table3", "table4", "write_tables", "fit_gain_classes", "TABLE_FILES"),
    "html": ("markdown_page", "markdown_to_html"),
})
