"""The campaign's data archive: self-describing trial files, campaign folders, verification.

One trial is one NetCDF4/HDF5 file (design brief section 6)::

    /                 ACDD-1.3 global attributes, schema version, scene JSON + sha256,
                      provenance (package version, git commit, library versions), seed
    /measured         what a real VES-II records (campaign.schema.MEASURED), one time
                      dimension per sampling clock
    /truth            what only the simulator knows (campaign.schema.TRUTH)

Every variable carries CF ``units`` and ``long_name``; every time coordinate is float64
seconds from the start of the recording (``units = "s"``, no ``standard_name``: CF keeps
``time`` for coordinates with a ``since`` epoch, and a simulated trial has none). Time
series are chunked along time and compressed losslessly (deflate + shuffle, the filters
every netCDF-4 reader has). Anyone opens a trial with plain xarray, no project import
needed::

    xr.open_dataset(path, engine="h5netcdf", group="measured")

**Writer.** Files are written with h5py in exactly the layout xarray's h5netcdf engine
writes (HDF5 dimension scales, ``_Netcdf4Dimid``, creation order tracked). Writing through
xarray/h5netcdf costs about 5 ms of Python per variable, i.e. 250-330 ms for a trial's 36
(fixed base) to 51 (flexible base) variables, six times the archive's 50 ms budget; h5py
writes the same file in 25-35 ms (``benchmarks/bench_archive.py``, ``benchmarks/README.md``).
The test suite checks that xarray decodes our files identically to files xarray writes itself
(values, dtypes, attributes, encodings).

**Reader.** For the same reason files are read with h5py, once: the integrity check reads
every array anyway, and :func:`open_trial` hands those arrays to xarray's own CF decoding
(through an in-memory data store) instead of reopening the file with the h5netcdf engine,
which took 5-8 times as long. The result is identical to ``xr.open_dataset(path,
engine="h5netcdf", group=...)``; the section "reading" below lists what of the h5netcdf layer
is reproduced and why, and the tests compare both readers on rig trials.

**Without xarray.** Importing xarray (with pandas) costs each Snakemake job ~0.6 s, more than
a job's trials take to simulate or identify. So the rig can hand :func:`write_trial` a trial
as plain arrays (:class:`campaign.schema.TrialArrays`; the same file, byte for byte) and
:func:`open_trial_arrays` reads a group into plain arrays with :func:`open_trial`'s values
(:class:`campaign.schema.GroupArrays`): the campaign's simulation and identification jobs
never import xarray. Users open trials with xarray as above.

**Integrity.** Each group stores ``content_sha256``: a digest of its attributes and of every
variable's bytes and attributes (:func:`_digest`). Readers recompute it, so a flipped byte
anywhere in the content is reported even for a file outside any campaign. A campaign
folder's ``MANIFEST.sha256`` (``sha256sum`` format) checks whole files; HDF5 bytes are not
reproducible run to run (``date_created``), so reproducibility is checked on decoded arrays
with ``xarray.testing`` instead (or on the groups' digests, which do not depend on the date).
A few corruptions make the HDF5 library crash rather than raise; :func:`verify` and
:func:`finalize_campaign` check each file in a child process so that they report it.

**Safe I/O.** Writes go to a temporary file in the target folder, then ``os.replace``: a
killed writer never leaves a file under the final name. Reads open, load and close.

Campaign folder (``archive/<name>/``)::

    <base>/config<N>/<gain>/v<speed>/r<NN>.nc     one file per trial (Scene.cell)
    index.csv                                      one row per trial with its scene parameters
    README.md                                      every variable, unit and clock (generated)
    MANIFEST.sha256                                sha256 of every other file
"""

from __future__ import annotations

from ..schema import ChannelArray, GroupArrays, TrialArrays
from .fileformat import (
    GROUPS, MANIFEST, INDEX, README, TRIAL_SUFFIX, CELL_KEYS, INDEX_COLUMNS, FILTER_KEYS, REFERENCES,
    provenance, prepare_trial, _now, _plan, _digest,
)
from .write import write_trial, trial_path, _write_h5, _create_dataset
from .read import _inspect, _inspect_isolated_many
from .decode import open_trial, open_trial_arrays, open_trial_tree, _plain
from .folder import TrialRecord, list_trials, open_campaign, to_cell_dataset
from .manifest import Problem, write_manifest, write_index, write_readme, finalize_campaign, verify

__all__ = [
    "GROUPS", "MANIFEST", "INDEX", "README", "TRIAL_SUFFIX", "CELL_KEYS", "INDEX_COLUMNS", "FILTER_KEYS",
    "REFERENCES",
    "TrialRecord", "Problem", "ChannelArray", "GroupArrays", "TrialArrays",
    "provenance", "prepare_trial", "write_trial", "open_trial", "open_trial_arrays", "open_trial_tree", "trial_path",
    "list_trials", "open_campaign", "to_cell_dataset",
    "write_manifest", "write_index", "write_readme", "finalize_campaign", "verify",
]
