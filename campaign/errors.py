"""Exceptions the CLI turns into a one-line message and exit status 2 (no traceback)."""

from __future__ import annotations

__all__ = ["CampaignError", "InputError", "SimulationError", "TrialFileError"]


class CampaignError(Exception):
    """Base class of the errors a user can act on."""


class InputError(CampaignError, ValueError):
    """Bad input (a value, a file, an option), detected before any work starts."""


class SimulationError(CampaignError, FloatingPointError):
    """The integration failed (blow-up, non-finite state); nothing is stored."""


class TrialFileError(CampaignError, OSError):
    """A trial or campaign file is missing, corrupt, of an unknown schema, or incomplete."""
