"""The README's console examples, run and compared with the output they show.

Every ```console block of README.md is a sequence of ``$ campaign ...`` commands, each
followed by the output it shows. Each command runs through :func:`campaign.cli.main.main` in a
scratch folder that holds the committed ``archive/reference`` (read only), and its stdout
and stderr must match the shown lines one for one, as text, so every number agrees to the
digits shown. ``...`` inside a line matches any text (timings); a line that is only
``...`` matches any number of lines. A command whose shown output is an error line exits
with status 2, every other with 0.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from campaign.cli.main import main

REPO = Path(__file__).resolve().parents[1]


def console_examples(text: str) -> list[tuple[str, list[str]]]:
    """(command, shown output lines) of every ``$ `` line of every console block."""
    examples: list[tuple[str, list[str]]] = []
    for block in re.findall(r"```console\n(.*?)```", text, re.S):
        for line in block.splitlines():
            if line.startswith("$ "):
                examples.append((line[2:], []))
            elif examples:
                examples[-1][1].append(line)
    # a blank line after an output separates it from the next command
    return [(command, "\n".join(shown).rstrip("\n").splitlines()) for command, shown in examples]


def _line_pattern(shown: str) -> re.Pattern:
    return re.compile(".*".join(re.escape(part) for part in shown.split("...")) + r"\Z")


def matches(shown: list[str], actual: list[str]) -> bool:
    """Whether ``actual`` lines match ``shown`` (``...`` as a line: any number of lines)."""
    if not shown:
        return not actual
    head, rest = shown[0], shown[1:]
    if head.strip() == "...":
        return any(matches(rest, actual[i:]) for i in range(len(actual) + 1))
    return bool(actual) and bool(_line_pattern(head).match(actual[0])) and matches(rest, actual[1:])


EXAMPLES = console_examples((REPO / "README.md").read_text(encoding="utf-8"))


def test_the_readme_has_examples():
    commands = [c for c, _ in EXAMPLES]
    assert len(commands) >= 12 and all(c.startswith("campaign ") for c in commands), commands


def test_the_matcher_can_fail():
    assert matches(["a ... c", "...", "z"], ["a b c", "x", "y", "z"])
    assert not matches(["m* = 24.9451 kg"], ["m* = 27.0545 kg"])
    assert not matches(["a", "b"], ["a"])


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """A folder laid out like the repository's root for the examples' relative paths."""
    root = tmp_path_factory.mktemp("readme")
    (root / "archive").mkdir()
    (root / "archive" / "reference").symlink_to(REPO / "archive" / "reference")
    return root


@pytest.mark.parametrize("command, shown", EXAMPLES, ids=[c for c, _ in EXAMPLES])
def test_console_example(scratch, monkeypatch, capsys, command, shown):
    argv = shlex.split(command, comments=True)
    assert argv[0] == "campaign"
    monkeypatch.chdir(scratch)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    status = main(argv[1:])
    out, err = capsys.readouterr()
    actual = (out + err).rstrip("\n").splitlines()
    expected_status = 2 if any(": error: " in line for line in shown) else 0
    assert status == expected_status, out + err
    assert matches(shown, actual), "\n".join(["shown:", *shown, "actual:", *actual])
