"""Identification tables: one CSV row per trial, written from trial files and read back.

Identification reads only each trial's ``measured`` group. The columns are the fields of
:class:`campaign.identify.results.TrialIdentification`; empty cells are NaN.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from ..core.errors import InputError, TrialFileError
from ..core.files import check_output_file, write_atomic
from ..core.timing import Timer
from ..core.vocabulary import misfiled
from ..model.robot import load_robot
from .loading import load_trial
from .options import check_identify_options
from .trial import identify_trial

__all__ = ["IDENTIFY_COLUMNS", "IDENTIFY_UNITS", "identify_trials", "read_identification"]
#: columns of an identification CSV, in order: the fields of
#: :class:`campaign.identify.TrialIdentification` (a field it gains later is appended)
IDENTIFY_COLUMNS = (
    "base", "config", "gain", "speed", "repeat", "m_eff", "e", "excluded", "reason",
    "v_a", "v_a_post", "v_b", "v_b_post", "impulse", "impulse_momentum", "peak_force", "contact_start",
    "contact_end", "theta_contact", "n_joint_pre", "n_joint_contact", "n_joint_post", "hammer_mass",
    "q_cmd", "impact_direction", "base_mass", "base_inertia", "base_com", "base_mount", "robot", "path",
)



#: units of the numeric columns
IDENTIFY_UNITS = {
    "speed": "m/s", "m_eff": "kg", "e": "1", "v_a": "m/s", "v_a_post": "m/s", "v_b": "m/s", "v_b_post": "m/s",
    "impulse": "N s", "impulse_momentum": "N s", "peak_force": "N", "contact_start": "s", "contact_end": "s",
    "theta_contact": "rad", "hammer_mass": "kg", "q_cmd": "rad (DH)", "impact_direction": "1", "base_mass": "kg",
    "base_inertia": "kg m2 (row-major 3x3)", "base_com": "m", "base_mount": "m",
}



#: columns holding several numbers (space-separated in the CSV)
_VECTOR_COLUMNS = frozenset({"q_cmd", "impact_direction", "base_inertia", "base_com", "base_mount"})



_TEXT_COLUMNS = frozenset({"base", "gain", "reason", "path", "robot"})



_INT_COLUMNS = frozenset({"config", "repeat", "n_joint_pre", "n_joint_contact", "n_joint_post"})



# ---------------------------------------------------------------------------------------
# identification
# ---------------------------------------------------------------------------------------
def _csv_value(value: Any) -> Any:
    """One identification field as a CSV cell: booleans 0/1, NaN empty, vectors space-separated."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (tuple, list)):
        return " ".join(repr(float(x)) for x in value)
    if isinstance(value, float) and not math.isfinite(value):
        return "" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value



def identify_trials(paths: Sequence[str | os.PathLike], out_csv: str | os.PathLike, *,
                    options: Mapping[str, Any] | None = None, timer: Timer | None = None) -> list[dict[str, Any]]:
    """Identify m* (eq 10) and e (eq 12) of trial files and write one CSV row per trial.

    Identification reads only each trial's ``measured`` group (:mod:`campaign.identify`).
    An excluded trial keeps its row, with ``excluded = 1`` and the reason; it never enters
    a fit or a table.

    Parameters
    ----------
    paths : sequence of path-like
        Trial files.
    out_csv : path-like
        The CSV to write (columns :data:`IDENTIFY_COLUMNS`; empty cells are NaN), checked
        before the first trial and written atomically (:mod:`campaign.core.files`).
    options : mapping, optional
        Fields of :class:`campaign.identify.IdentifyOptions`.
    timer : Timer, optional
        Receives the seconds spent in ``identify``.

    Returns
    -------
    list of dict
        The rows written.

    Raises
    ------
    ValueError
        An unknown identification option (named), or ``out_csv`` cannot be written (a folder,
        a device, a full disk).
    campaign.core.errors.TrialFileError
        A file is not a trial or lacks a channel (named).
    """
    timer = timer if timer is not None else Timer()
    opts = check_identify_options(options)
    check_output_file(out_csv, option="identification table")
    robots: dict[str, Any] = {}
    rows = []
    columns: list[str] | None = None
    n = len(paths)
    for i, path in enumerate(paths, 1):
        t0 = time.perf_counter()
        with timer("identify"):
            measured, attrs = load_trial(path, arrays=True)   # plain arrays: no xarray in the job
            name = str(attrs.get("robot") or measured.attrs.get("robot") or "")
            if not name:
                raise TrialFileError(f"{path}: no 'robot' attribute in the trial")
            wrong = misfiled(path, attrs)   # a trial of another cell would bias this cell's m*
            if wrong:
                raise TrialFileError(wrong)
            if name not in robots:
                robots[name] = load_robot(name)
            try:
                res = identify_trial(measured, robot=robots[name], meta={**attrs, "path": str(path)},
                                     options=opts, where=str(path))
            except InputError as exc:
                raise TrialFileError(str(exc)) from None
        if columns is None:
            names = [f.name for f in dataclasses.fields(res)]
            columns = list(IDENTIFY_COLUMNS) + [n for n in names if n not in IDENTIFY_COLUMNS]
        row = {k: _csv_value(getattr(res, k)) for k in columns}
        row["path"] = str(path)
        rows.append(row)
        state = f"excluded: {res.reason}" if res.excluded else f"m* = {res.m_eff:.3f} kg, e = {res.e:.3f}"
        print(f"[{i}/{n}] {path}: {state} ({1e3 * (time.perf_counter() - t0):.0f} ms)", flush=True)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns or list(IDENTIFY_COLUMNS), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(out_csv, buf.getvalue())
    return rows



def _parse_extra(value: str) -> Any:
    """A column this module does not know: a number, several numbers, or text."""
    try:
        return float(value) if value != "" else float("nan")
    except ValueError:
        pass
    try:
        return tuple(float(x) for x in value.split())
    except ValueError:
        return value



def read_identification(paths: Iterable[str | os.PathLike]) -> list[dict[str, Any]]:
    """Read identification CSVs (:func:`identify_trials`) back as records.

    Returns
    -------
    list of dict
        One record per trial, as :meth:`campaign.identify.TrialIdentification.to_dict`
        gives them (what :mod:`campaign.report.tables` takes), except that a number that was not
        computable is NaN: numbers as float, counts and cell indices as int, ``excluded`` as
        bool, vectors (``q_cmd``, ``impact_direction``, ``base_inertia``) as tuples of float.

    Raises
    ------
    ValueError
        A file is not an identification table (a required column is missing), named.
    """
    rows = []
    for path in paths:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            missing = [c for c in IDENTIFY_COLUMNS if c not in (reader.fieldnames or ())]
            if missing:
                raise ValueError(f"{path}: not an identification table (no column {', '.join(missing)})")
            for line, row in enumerate(reader, 2):
                out: dict[str, Any] = {}
                try:
                    for key, value in row.items():
                        if key in _TEXT_COLUMNS:
                            out[key] = value
                        elif key in _VECTOR_COLUMNS:
                            out[key] = tuple(float(x) for x in value.split())
                        elif key in _INT_COLUMNS:
                            out[key] = int(value)
                        elif key == "excluded":
                            out[key] = bool(int(value))
                        elif key in IDENTIFY_COLUMNS:
                            out[key] = float(value) if value != "" else float("nan")
                        else:  # a field identification gained after this reader: keep its meaning
                            out[key] = _parse_extra(value)
                except ValueError as exc:
                    raise ValueError(f"{path}, line {line}: bad value ({exc})") from None
                rows.append(out)
    return rows

