"""The CLI reference of the user guide (docs/cli.rst) documents every subcommand and option
of the ``campaign`` command, and no other, and its examples run every subcommand a test can
afford.

The page documents a subcommand under ``.. program:: campaign <cmd>`` (``campaign archive
ls`` for a nested one) and each of its options and positional arguments with
``.. option::``; the parsers are :func:`campaign.cli.main.build_parser`'s. The examples
themselves run in ``tests/test_readme.py``.
"""

from __future__ import annotations

import argparse
import re

import pytest

from campaign.cli.main import build_parser

from console_examples import REPO, file_examples

PAGE = REPO / "docs" / "cli.rst"
#: subcommands whose examples take minutes (a calibration, a benchmark): shown, not run
NOT_RUN = {"calibrate", "bench"}


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def programs() -> dict[str, argparse.ArgumentParser]:
    """``{"campaign meff": parser, "campaign archive ls": parser, ...}``: every leaf command."""
    found = {}
    stack = [("campaign", build_parser())]
    while stack:
        name, parser = stack.pop()
        children = _subparsers(parser)
        if not children:
            found[name] = parser
        stack += [(f"{name} {child}", p) for child, p in children.items()]
    return found


def parser_options(parser: argparse.ArgumentParser) -> set[str]:
    """The long option strings and positional metavars (or choices) of a parser, help left out."""
    out = set()
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if action.option_strings:
            out.add(max(action.option_strings, key=len))
        elif action.choices:
            out |= set(action.choices)
        else:
            out.add(action.metavar or action.dest)
    return out


def documented() -> dict[str, set[str]]:
    """``{program: names of its .. option:: entries}`` of the reference page."""
    found: dict[str, set[str]] = {}
    program = None
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        if m := re.match(r"\.\. program:: (.+?)\s*$", line):
            program = m.group(1)
            found.setdefault(program, set())
        elif m := re.match(r"\.\. option:: (\S+)", line):
            assert program, f"option {m.group(1)} before any program directive"
            found[program].add(m.group(1))
    return found


PROGRAMS = programs()


def test_every_command_has_a_section_and_nothing_else_does():
    assert set(documented()) == set(PROGRAMS)


@pytest.mark.parametrize("program", sorted(PROGRAMS))
def test_every_option_is_documented_and_every_documented_option_exists(program):
    assert documented().get(program, set()) == parser_options(PROGRAMS[program])


def test_the_examples_run_every_subcommand_but_the_long_ones():
    run = {command.split()[1] for command, _ in file_examples(PAGE)}
    assert run == set(_subparsers(build_parser())) - NOT_RUN
