"""Importing sessions of recorded hits into a recording folder, and the per-hit identification table."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Any

from ..core.errors import InputError
from ..core.files import write_atomic
from .airhockey import airhockey_hits, read_airhockey_hit
from .fileformat import NO_LICENCE, finalize_recordings, read_recording, recording_files, write_recording
from .identify import HIT_COLUMNS, RecordedHitOptions, identify_recording
from .mapping import read_mapped_hit

__all__ = ["check_mass", "import_airhockey", "import_mapped", "identify_folder", "write_hit_table"]


def check_mass(object_mass: Any, *, option: str = "--object-mass") -> float:
    """The object's mass [kg], refused when missing or not a positive number."""
    if object_mass is None:
        raise InputError(f"{option} is missing: the object's mass [kg] is not in the recording; give it")
    try:
        mass = float(object_mass)
    except (TypeError, ValueError):
        raise InputError(f"{option} {object_mass!r}: not a number (kg)") from None
    if not (mass > 0 and mass < float("inf")):
        raise InputError(f"{option} {object_mass!r}: must be a positive mass in kg")
    return mass


def import_airhockey(sources: list[str | os.PathLike], out: str | os.PathLike, *, object_mass: Any,
                     licence: str = NO_LICENCE) -> list[tuple[Path, dict[str, Any]]]:
    """Import every hit of each session folder of the air-hockey layout into the recording folder ``out``.

    Each session folder's name is its session; the folder is finalized (index, README,
    manifest) afterwards. Returns (file written, import report) per hit.
    """
    mass = check_mass(object_mass)
    plans = [(Path(src).name, airhockey_hits(src)) for src in sources]  # every source checked before any work
    recs = []
    for session, hits in plans:
        for hit, robot_file, object_file, obj in hits:
            rec = read_airhockey_hit(robot_file, object_file, object_mass=mass, session=session, hit=hit,
                                     licence=licence)
            rec.attrs["object_number"] = int(obj)
            rec.attrs["object_mass_source"] = "given to the import (--object-mass)"
            recs.append(rec)
    # every hit read and checked before the first is written
    done = [(write_recording(rec, out), _report(rec)) for rec in recs]
    finalize_recordings(out)
    return done


def _report(rec) -> dict[str, Any]:
    return {**{k: v for k, v in rec.attrs["robot_attrs"].items() if k != "rows_read"},
            "clock_offset": rec.attrs["object_attrs"]["clock_offset"]}


def import_mapped(mapping: str | os.PathLike, out: str | os.PathLike, *, object_mass: Any = None,
                  licence: str | None = None) -> list[tuple[Path, dict[str, Any]]]:
    """Import the hit a mapping file describes (:mod:`campaign.recordings.mapping`) into ``out``."""
    mass = None if object_mass is None else check_mass(object_mass)
    rec = read_mapped_hit(mapping, object_mass=mass, licence=licence)
    path = write_recording(rec, out)
    finalize_recordings(out)
    return [(path, _report(rec))]


def identify_folder(folder: str | os.PathLike, opts: RecordedHitOptions | None = None) -> list[dict[str, Any]]:
    """One row (:func:`campaign.recordings.identify.HIT_COLUMNS`) per hit of a recording folder."""
    files = recording_files(folder)
    if not files:
        raise InputError(f"{folder}: no recorded hits (<session>/hit_<N>.nc); import some with campaign import")
    return [identify_recording(read_recording(f), opts) for f in files]


def write_hit_table(rows: list[dict[str, Any]], path: str | os.PathLike) -> Path:
    """Write the per-hit rows as CSV (numbers to 6 significant digits)."""
    n_joints = max(sum(1 for c in r if c.startswith("q_")) for r in rows)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=HIT_COLUMNS(n_joints), lineterminator="\n", extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: (f"{float(v):.6g}" if isinstance(v, float) or hasattr(v, "dtype") else v)
                         for k, v in row.items()})
    return write_atomic(path, buf.getvalue())
