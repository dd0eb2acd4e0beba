"""The workflow's table jobs: Tables 2, 3 and 4 (and the studies' tables) as CSV, Markdown and HTML."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping

from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.timing import Timer
from ..identify.table import read_identification
from ..joints.lambda_fit import load_fits
from ..joints.modelfile import load_model
from ..joints.setting import display_path
from ..model.paper import load_paper
from ..report import tables
from ..report.html import markdown_page

__all__ = ["make_table"]


def _response_model(path, structure):
    """(the response model of ``path`` or None, the note Table 4 carries about it)."""
    if path is None:
        return None, None
    try:
        return load_model(path), f"response model: {display_path(path)}."
    except InputError as exc:
        return None, f"no response model column: {exc}"
def make_table(name: str, out_csv: str | os.PathLike, out_md: str | os.PathLike, *,
               ident_tables: Iterable[str | os.PathLike] = (), fits: Mapping[str, str | os.PathLike] | None = None,
               source: str | os.PathLike | None = None, out_html: str | os.PathLike | None = None,
               structure: str | None = None, model: str | os.PathLike | None = None, timer: Timer | None = None):
    """Write Table 2, 3, 4 or Table 4 under both structures (:mod:`campaign.report.tables`) as CSV,
    Markdown and HTML, each atomically.

    Parameters
    ----------
    name : {"table2", "table3", "table4", "table4_structures", "plan_rig_check"}
    out_csv, out_md : path-like
    out_html : path-like, optional
        The Markdown as a standalone HTML page (:mod:`campaign.report.html`), which
        Snakemake's report shows inline.
    ident_tables : iterable of path-like
        Identification CSVs: fixed-base ones for Table 2, flexible-base ones for Table 4.
    fits : mapping, optional
        ``{gain class: JSON of fit_lambda}`` for Tables 3 and 4, in the paper's order.
    source : path-like, optional
        For ``table4_structures``: the CSV the study :mod:`campaign.studies.space_structure`
        writes; for ``plan_rig_check``: the CSV :mod:`campaign.studies.plan_rig_check` writes.
    structure : str, optional
        For ``table4``: the structure its flexible-base trials emulate (a note names it).
    model : path-like, optional
        For ``table4``: a response model file (:mod:`campaign.joints.modelfile`) whose
        predictions fill its model column; one fitted for another rig or robot leaves the
        column empty with a note saying why.
    timer : Timer, optional

    Returns
    -------
    campaign.report.tables.Table
    """
    timer = timer if timer is not None else Timer()
    with timer("table"):
        paper = load_paper()
        records = read_identification(ident_tables)
        loaded = load_fits(fits or {})
        if name == "table2":
            table = tables.table2(records, paper=paper)
        elif name == "table3":
            table = tables.table3(loaded, paper=paper)
        elif name == "table4":
            response_model, note = _response_model(model, structure)
            table = tables.table4(records, loaded, paper=paper, structure=structure, model=response_model,
                                  model_note=note)
        elif name == "table4_structures":
            table = tables.structures_table(source, paper=paper)
        elif name == "plan_rig_check":
            table = tables.rig_check_table(source)
        else:
            raise ValueError(f"unknown table {name!r}; expected table2, table3, table4, table4_structures or "
                             "plan_rig_check")
        write_atomic(out_csv, table.to_csv())
        write_atomic(out_md, table.to_markdown())
        if out_html is not None:
            write_atomic(out_html, markdown_page(table.to_markdown(), title=table.title))
    print(table.to_markdown())
    return table

