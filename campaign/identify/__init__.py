"""Per-trial identification: effective mass m* (eq 10, or eq 11's impulsive limit) and restitution e (eq 12).

Identification reads only a trial's ``measured`` group, never ``truth``: the contact
interval from the piezo force, the hammer velocities from the pendulum encoder, the arm
tip's velocities from the base F/T sensor or the joint encoders, then eq 12 and eq 10 (or
the impulse estimator). A trial that cannot give a trustworthy m* is returned with
``excluded=True`` and the reason; a file that is not a trial raises
:class:`~campaign.core.errors.TrialFileError`, a dataset without a required channel
:class:`~campaign.core.errors.InputError`. One module per step (options, contact, hammer, the
three arm-velocity methods, the trial driver, loading); this package re-exports their
public names.

The methods, their equations and their measured accuracy: user guide, *Identification*
(``docs/identification.rst``).
"""

from __future__ import annotations

from .channels import base_geometry
from .contact import ContactWindow, detect_contact
from .hammer import hammer_velocity
from .loading import find_trials, identify_file, identify_files, load_trial
from .options import ACCURACY_NOTE, REQUIRED_CHANNELS, IdentifyOptions, check_identify_options
from .results import TrialIdentification
from .table import identify_trials, read_identification
from .trial import identify_trial

__all__ = [
    "ACCURACY_NOTE",
    "REQUIRED_CHANNELS",
    "ContactWindow",
    "IdentifyOptions",
    "TrialIdentification",
    "base_geometry",
    "detect_contact",
    "find_trials",
    "hammer_velocity",
    "identify_file",
    "identify_files",
    "identify_trial",
    "identify_trials",
    "load_trial",
    "read_identification",
    "check_identify_options",
]
