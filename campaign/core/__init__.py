"""The ground floor: errors, the vocabulary (bases, gain sets, trial paths), the tolerance
policy, atomic files, YAML, lazy imports and timers.

The names below, but for the lazy-import helpers themselves, are imported on first use
(:func:`campaign.core.lazy.lazy_exports`): the workflow imports this package on every start,
a dry run included, and pays only for what it uses. The modules:
:mod:`~campaign.core.errors`, :mod:`~campaign.core.vocabulary`, :mod:`~campaign.core.tolerance`,
:mod:`~campaign.core.files`, :mod:`~campaign.core.yamlfile`, :mod:`~campaign.core.lazy`,
:mod:`~campaign.core.progress`, :mod:`~campaign.core.timing`.
"""

from __future__ import annotations

from .lazy import LazyModule, lazy_exports

__all__ = [
    "LazyModule", "lazy_exports", "CampaignError", "InputError", "SimulationError", "TrialFileError", "WriteError",
    "bases", "gain_sets", "gain_classes", "trial_relpath", "misfiled", "Difference", "compare", "differences",
    "worst", "identification_differences", "write_atomic", "check_output_file", "check_output_dir", "sha256_file",
    "source_date_epoch", "config_dir", "config_file", "read_yaml", "yaml_load", "Timer",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "errors": ("CampaignError", "InputError", "SimulationError", "TrialFileError", "WriteError"),
    "vocabulary": ("bases", "gain_sets", "gain_classes", "trial_relpath", "misfiled"),
    "tolerance": ("Difference", "compare", "differences", "worst", "identification_differences"),
    "files": ("write_atomic", "check_output_file", "check_output_dir", "sha256_file", "source_date_epoch"),
    "yamlfile": ("config_dir", "config_file", "read_yaml", "yaml_load"),
    "timing": ("Timer",),
})
