"""What the workflow's scripts and helpers call: the simulation, fit and table jobs, the
paths of an archive's trials, configuration checks, stage digests, job logs, calibration.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`): the
workflow imports :mod:`~campaign.pipeline.paths`, :mod:`~campaign.pipeline.config` and
:mod:`~campaign.pipeline.digests` on every start, which need neither NumPy nor the rig.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "run_cells", "run_trial", "fit_lambda", "make_table", "trial_paths", "export_identification", "job_log",
    "calibrate", "load_calibration", "campaign_report", "code_digest",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "sweep": ("run_cells", "run_trial"),
    "fit": ("fit_lambda",),
    "tabulate": ("make_table",),
    "stages": ("trial_paths", "export_identification"),
    "joblog": ("job_log",),
    "calibration": ("calibrate", "load_calibration"),
    "calibration_report": ("campaign_report",),
    "digests": ("code_digest",),
})
