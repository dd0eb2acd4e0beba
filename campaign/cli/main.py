"""The ``campaign`` command: one subcommand per stage.

Each subcommand lives in ``campaign/commands/<module>.py`` and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a callable taking the
parsed arguments and returning an exit status. Command modules import the heavy stages
lazily, so ``campaign --help`` stays fast.

Errors a user can act on (:class:`campaign.core.errors.CampaignError`, ``ValueError``, any
``OSError``: a file missing, unreadable or not writable) print one line ``campaign <cmd>:
error: ...`` and exit with status 2, without a traceback. A reader that closes the pipe
early (``campaign archive ls DIR | head``) ends the command quietly.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from .. import __version__
from ..core.errors import CampaignError

#: command modules under campaign.cli, in the order --help lists them
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
        importlib.import_module(f"campaign.cli.{name}").register(sub)
    return parser


def _one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line (an OSError names its file; a YAML error spans lines)."""
    if isinstance(exc, OSError) and not isinstance(exc, CampaignError) and exc.filename is not None:
        text = f"{exc.filename}: {exc.strerror or exc}"
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader stopped early (``| head``): nothing more to say, and nothing to say it to;
        # stdout goes to /dev/null so the interpreter's last flush cannot raise again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, as a tool killed by the broken pipe reports
    except (CampaignError, ValueError, OSError) as exc:
        print(f"campaign {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"campaign {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
