"""Recorded hits of real robots: import, archive files, and identification of m* and e by momentum balance.

A recording is what a real experiment logs: a robot's joint and end-effector samples and a
struck object's positions, each on its own clock. :mod:`~campaign.recordings.airhockey`
reads the air-hockey hitting dataset's layout, :mod:`~campaign.recordings.mapping` any CSV
layout a small YAML mapping describes; :mod:`~campaign.recordings.cleaning` drops stale
rows, repairs stamps and aligns the clocks; :mod:`~campaign.recordings.fileformat` writes
and verifies recording files and folders (the archive's conventions, no truth group);
:mod:`~campaign.recordings.identify` gives m* and e with intervals per hit;
:mod:`~campaign.recordings.export` writes a simulated trial in the air-hockey layout, to
test all of it against the rig's truth.

User guide: *Recorded hits* (``docs/recordings.rst``).
"""

from __future__ import annotations

from .airhockey import airhockey_hits, read_airhockey_hit
from .cleaning import clock_offset, drop_stale, repair_stamps
from .export import export_airhockey, truth_of
from .fileformat import (
    INDEX_COLUMNS,
    NO_LICENCE,
    Recording,
    finalize_recordings,
    is_recording_folder,
    read_recording,
    recording_files,
    verify_recordings,
    write_recording,
)
from .identify import FITS, HIT_COLUMNS, RecordedHitOptions, identify_recording
from .mapping import read_mapped_hit
from .table import check_mass, identify_folder, import_airhockey, import_mapped, write_hit_table

__all__ = [
    "INDEX_COLUMNS", "NO_LICENCE", "FITS", "HIT_COLUMNS", "Recording", "RecordedHitOptions",
    "airhockey_hits", "read_airhockey_hit", "read_mapped_hit", "clock_offset", "drop_stale", "repair_stamps",
    "export_airhockey", "truth_of", "finalize_recordings", "is_recording_folder", "read_recording",
    "recording_files", "verify_recordings", "write_recording", "identify_recording", "identify_folder",
    "import_airhockey", "import_mapped", "check_mass", "write_hit_table",
]
