"""What the workflow's jobs after the simulations share: their trials, and the campaign's
identification as one file.

A job after the simulations reads its trials from the job manifests of the simulation jobs
before it (:mod:`campaign.archive.jobs`), or, when the workflow re-analyses an archive, is
given the archive's trial files themselves: :func:`trial_paths` takes either.
:func:`export_identification` joins a campaign's identification tables into one CSV (the
committed reference's ``archive/reference.identification.csv``), keeping the rows of an
existing one that the tolerance policy calls the same identification.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from ..archive import job_trial_paths
from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.tolerance import identification_differences, worst

__all__ = ["trial_paths", "export_identification"]


def trial_paths(sources: Sequence[str | os.PathLike], *, archive_dir: str | os.PathLike) -> list[str]:
    """The trial files of a job's sources: job manifests (``*.json``: the trials they list,
    as ``<archive_dir>/<path>``) or trial files (taken as they are), in the order given."""
    sources = [str(s) for s in sources]
    manifests = [s for s in sources if s.endswith(".json")]
    if manifests and len(manifests) != len(sources):
        raise InputError(f"a job's trials come from job manifests or trial files, not both: {sources[:4]}")
    return job_trial_paths(archive_dir, manifests) if manifests else sources


def export_identification(tables: Iterable[str | os.PathLike], out_csv: str | os.PathLike) -> Path:
    """Join identification tables (:func:`campaign.identify.table.identify_trials`, all with
    the same columns) into one CSV, every trial in path order; written atomically.

    A row of an existing ``out_csv`` with the same columns is kept as it is where the new
    row of its trial is the same identification under the tolerance policy
    (:func:`campaign.core.tolerance.identification_differences`: another machine's
    arithmetic moves identification's fits by roundoff), so a rerun anywhere rewrites only
    the rows that moved; a file that would not change is not written. Prints how many rows
    were kept, with the largest difference, and each row that moved, with its worst result.
    """
    header: list[str] | None = None
    rows: list[list[str]] = []
    for table in tables:
        with open(table, newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            head = next(reader)
            if header is not None and head != header:
                raise InputError(f"{table}: its columns differ from the other identification tables'")
            header = head
            rows += list(reader)
    if header is None:
        raise InputError("no identification table to join")
    key = header.index("path")
    rows = _keep_same_rows(header, sorted(rows, key=lambda r: r[key]), Path(out_csv))
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    out = Path(out_csv)
    if not (out.is_file() and out.read_text(encoding="utf-8") == buf.getvalue()):
        write_atomic(out_csv, buf.getvalue())
    return out


def _keep_same_rows(header: list[str], rows: list[list[str]], existing: Path) -> list[list[str]]:
    """``rows`` with each one an existing table holds the same identification of replaced by
    the existing row (see :func:`export_identification`)."""
    try:
        with open(existing, newline="", encoding="utf-8") as fh:
            old = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError, csv.Error):
        return rows
    if not old or old[0] != header:
        return rows
    key = header.index("path")
    before = {r[key]: r for r in old[1:] if len(r) == len(header)}
    out, kept, moved = [], [], []
    for row in rows:
        was = before.get(row[key])
        found = (identification_differences(dict(zip(header, was, strict=True)), dict(zip(header, row, strict=True)),
                                            name=row[key]) if was is not None else [])
        if was is not None and worst(found).ok:
            out.append(was)
            kept.append(worst(found))
        else:
            out.append(row)
            if was is not None:
                moved.append(worst(found))
    if kept:
        print(f"kept {len(kept)} of {len(rows)} rows as they were (the same identification); largest difference "
              f"{worst(kept)}")
    for d in moved:
        print(f"moved beyond the tolerance, rewritten: {d}")
    return out
