"""The ``campaign`` command: one subcommand per stage.

Each subcommand lives in ``campaign/commands/<module>.py`` and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a callable taking the
parsed arguments and returning an exit status. Command modules import the heavy stages
lazily, so ``campaign --help`` stays fast.

Errors a user can act on (:class:`campaign.errors.CampaignError`, ``ValueError``,
``FileNotFoundError``) print one line ``campaign <cmd>: error: ...`` and exit with status 2,
without a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from . import __version__
from .errors import CampaignError

#: command modules under campaign.commands, in the order --help lists them
COMMANDS = ("meff", "plan", "map", "trial", "sweep", "design", "archive", "identify", "calibrate", "bench")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="campaign",
        description="Impact dynamics of long-reach manipulators: the simulated VES-II campaign "
        "(Yoshida, Mavroidis & Dubowsky). One subcommand per stage.",
    )
    parser.add_argument("--version", action="version", version=f"campaign {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"campaign.commands.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (CampaignError, ValueError, FileNotFoundError) as exc:
        print(f"campaign {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"campaign {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
