"""Exceptions the CLI turns into a one-line message (no traceback) and an exit status: 1 for
:class:`WriteError`, 2 for the others; and the wording their messages share."""

from __future__ import annotations

import difflib
from collections.abc import Sequence

__all__ = ["CampaignError", "InputError", "SimulationError", "TrialFileError", "WriteError", "allowed_names"]


def allowed_names(value: str, known: Sequence[str], *, limit: int = 12) -> str:
    """``did you mean ...?`` for a near miss of ``value``, else the known names (at most ``limit``)."""
    close = difflib.get_close_matches(value, list(known), n=3, cutoff=0.6)
    if close:
        return f"did you mean {', '.join(close)}?"
    shown = ", ".join(sorted(known)[:limit])
    more = f", ... ({len(known)} in all)" if len(known) > limit else ""
    return f"known: {shown}{more}"


class CampaignError(Exception):
    """Base class of the errors a user can act on."""


class InputError(CampaignError, ValueError):
    """Bad input (a value, a file, an option), detected before any work starts."""


class SimulationError(CampaignError, FloatingPointError):
    """The integration failed (blow-up, non-finite state); nothing is stored."""


class TrialFileError(CampaignError, OSError):
    """A trial or campaign file is missing, corrupt, of an unknown schema, or incomplete."""


class WriteError(CampaignError, OSError):
    """Writing an output failed part-way (a full disk, an I/O error) after the work started;
    nothing is left under the output's final or temporary name.

    Constructed as ``WriteError(errno, message)``; its text is the message alone.
    """

    def __str__(self) -> str:
        return str(self.strerror) if self.strerror else super().__str__()
