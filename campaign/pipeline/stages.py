"""What the workflow's jobs after the simulations share: their trials, and the campaign's
identification as one file.

A job after the simulations reads its trials from the job manifests of the simulation jobs
before it (:mod:`campaign.archive.jobs`), or, when the workflow re-analyses an archive, is
given the archive's trial files themselves: :func:`trial_paths` takes either.
:func:`export_identification` joins a campaign's identification tables into one CSV (the
committed reference's ``archive/reference.identification.csv``).
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
    the same columns) into one CSV, every trial in path order; written atomically."""
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
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(sorted(rows, key=lambda r: r[key]))
    write_atomic(out_csv, buf.getvalue())
    return Path(out_csv)
