"""The campaign's data archive: self-describing trial files, campaign folders, verification.

One trial is one NetCDF4/HDF5 file with the groups ``/measured`` (what a real VES-II
records) and ``/truth`` (what only the simulator knows), readable with plain xarray
(``xr.open_dataset(path, engine="h5netcdf", group="measured")``). Files are written and read
with h5py in the layout xarray's h5netcdf engine writes, because going through xarray takes
about ten times as long to write and 5-8 times as long to read; each group carries a content digest its readers check. One
module per concept (file format and digest, the computing platform, writer, reader and checks, decoding, campaign
folders, the workflow's job manifests, manifest and verification); this package re-exports
their public names.

The file format, the campaign folder and the integrity checks: user guide, *The archive
format* (``docs/archive.rst``).
"""

from __future__ import annotations

from ..scene.schema import ChannelArray, GroupArrays, TrialArrays
from .decode import open_trial, open_trial_arrays, open_trial_tree
from .fileformat import (
    CELL_KEYS,
    FILTER_KEYS,
    GROUPS,
    INDEX,
    INDEX_COLUMNS,
    MANIFEST,
    README,
    REFERENCES,
    TRIAL_SUFFIX,
    content_digest,
    prepare_trial,
    provenance,
)
from .folder import TrialRecord, list_trials, open_campaign, outside_layout, read_record, to_cell_dataset, trial_files
from .jobs import (
    JOBS,
    TrialEntry,
    intact_trials,
    job_trial_paths,
    read_job_manifests,
    write_job_manifest,
    write_trial_entry,
)
from .manifest import (
    Problem,
    Verification,
    check_listed_digests,
    finalize_campaign,
    verify,
    verify_report,
    write_index,
    write_manifest,
    write_readme,
)
from .write import TRIAL_BYTES, trial_path, write_trial

__all__ = [
    "GROUPS", "MANIFEST", "INDEX", "README", "TRIAL_SUFFIX", "CELL_KEYS", "INDEX_COLUMNS", "FILTER_KEYS",
    "REFERENCES", "TRIAL_BYTES",
    "TrialRecord", "Problem", "Verification", "ChannelArray", "GroupArrays", "TrialArrays",
    "provenance", "content_digest", "prepare_trial", "write_trial", "open_trial", "open_trial_arrays", "open_trial_tree", "trial_path",
    "list_trials", "read_record", "trial_files", "outside_layout", "open_campaign", "to_cell_dataset",
    "JOBS", "TrialEntry", "write_trial_entry", "intact_trials", "write_job_manifest", "read_job_manifests",
    "job_trial_paths",
    "write_manifest", "write_index", "write_readme", "finalize_campaign", "verify", "verify_report",
    "check_listed_digests",
]
