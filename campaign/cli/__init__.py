"""The ``campaign`` command: :mod:`campaign.cli.main` (its entry point ``main``), the shared
argument reading (:mod:`campaign.cli.args`) and one module per subcommand.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`).
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "build_parser", "COMMANDS", "HELP",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "main": ("build_parser",),
    "commands": ("COMMANDS", "HELP"),
})
