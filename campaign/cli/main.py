"""The ``campaign`` command: one subcommand per stage.

Each subcommand lives in a module of :mod:`campaign.cli` (:data:`campaign.cli.commands.COMMANDS`)
that defines ``register(subparsers)``, which adds its parser and sets ``func`` to a callable
taking the parsed arguments and returning an exit status. Only the module of the subcommand
given on the command line is imported (with the stages it uses); the others are listed by
their help line alone, so ``campaign --help`` imports no stage.

Errors a user can act on print one line ``campaign <cmd>: error: ...`` on stderr, without a
traceback: a usage error (an unknown option, a missing argument, a value of the wrong type;
with a hint to ``--help``), bad input (:class:`campaign.core.errors.CampaignError`,
``ValueError``, any ``OSError``: a file missing, unreadable or not writable) and a bad
``SOURCE_DATE_EPOCH`` exit with status 2, before any work; an output that could not be
written part-way (:class:`campaign.core.errors.WriteError`: a full disk) with status 1.
A reader that closes the pipe early (``campaign archive ls DIR | head``) ends the command
quietly.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from .. import __version__
from ..core.errors import CampaignError, WriteError
from ..core.files import source_date_epoch
from .args import OneLineParser
from .commands import COMMANDS, HELP


def _chosen(argv: list[str]) -> str | None:
    """The subcommand named on the command line (the first argument that is not an option)."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg if arg in COMMANDS else None
    return None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``campaign`` parser with the full parser of the subcommand in ``argv`` (every
    subcommand's when ``argv`` is None) and the help line of the others."""
    parser = OneLineParser(
        prog="campaign",
        description="Impact dynamics of long-reach manipulators: the simulated VES-II campaign "
        "(Yoshida, Mavroidis & Dubowsky). One subcommand per stage.",
    )
    parser.add_argument("--version", action="version", version=f"campaign {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    wanted = set(COMMANDS.values()) if argv is None else {COMMANDS[c] for c in [_chosen(argv)] if c}
    done: set[str] = set()
    for name, module in COMMANDS.items():
        if module in done:
            continue
        if module in wanted:
            importlib.import_module(f"campaign.cli.{module}").register(sub)
            done.add(module)
        else:
            sub.add_parser(name, help=HELP[name])
    return parser


def _one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line (an OSError names its file; a YAML error spans lines)."""
    if isinstance(exc, OSError) and not isinstance(exc, CampaignError) and exc.filename is not None:
        text = f"{exc.filename}: {exc.strerror or exc}"
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


#: subcommands whose work is many small fits (identification, lambda's bootstrap): BLAS
#: threads only cost there (10-40x the CPU for the same wall time on a multi-core machine)
ONE_BLAS_THREAD = frozenset({"identify", "fit-lambda", "tables"})
#: the variables OpenBLAS, OpenMP and MKL read for their thread count, when numpy loads them
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def pin_blas_threads(command: str | None) -> None:
    """One BLAS thread for a subcommand of :data:`ONE_BLAS_THREAD`, by setting each of
    :data:`BLAS_THREAD_VARIABLES` the user has not set, before numpy is imported (it has
    no effect after, so nothing is changed then)."""
    if command in ONE_BLAS_THREAD and "numpy" not in sys.modules:
        for name in BLAS_THREAD_VARIABLES:
            os.environ.setdefault(name, "1")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    pin_blas_threads(_chosen(argv))
    try:
        # before any stage is imported: numpy reads the variable on import, with a traceback
        source_date_epoch()
    except CampaignError as exc:
        print(f"{' '.join(['campaign', *filter(None, [_chosen(argv)])])}: error: {exc}", file=sys.stderr)
        return 2
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader stopped early (``| head``): nothing more to say, and nothing to say it to;
        # stdout goes to /dev/null so the interpreter's last flush cannot raise again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, as a tool killed by the broken pipe reports
    except WriteError as exc:
        print(f"campaign {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 1
    except (CampaignError, ValueError, OSError) as exc:
        print(f"campaign {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"campaign {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
