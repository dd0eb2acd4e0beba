"""The console examples of README.md and of the user guide, run and compared with the output
they show.

Every ```console block of README.md and every ``.. code-block:: console`` block of a page of
``docs/`` is a sequence of ``$ campaign ...`` commands, each followed by the output it
shows (:mod:`console_examples`). Each command runs through :func:`campaign.cli.main.main`,
the commands of one file in their order, in a scratch folder of that file's own that holds
the committed ``archive/reference`` (read only); its stdout and stderr must match the shown
lines one for one, as text, so every number agrees to the digits shown. ``...`` inside a
line matches any text (timings); a line that is only ``...`` matches any number of lines.
A command whose shown output is an error line exits with status 2, every other with 0.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from console_examples import (
    COMMAND_LINE,
    REPO,
    console_examples,
    file_examples,
    matches,
    run_example,
    scratch_folder,
    sources,
)

SOURCES = sources()
EXAMPLES = [(path, command, shown) for path in SOURCES for command, shown in file_examples(path)]


def _id(path: Path, command: str) -> str:
    return f"{path.relative_to(REPO).as_posix()}: {command}"


def test_the_readme_and_the_cli_reference_have_examples():
    readme = [c for c, _ in file_examples(REPO / "README.md")]
    assert len(readme) >= 3 and all(c.startswith("campaign ") for c in readme), readme
    reference = [c for c, _ in file_examples(REPO / "docs" / "cli.rst")]
    assert len(reference) >= 20 and all(c.startswith("campaign ") for c in reference), reference


@pytest.mark.parametrize("path", SOURCES, ids=[p.relative_to(REPO).as_posix() for p in SOURCES])
def test_every_command_shown_is_in_a_console_block(path):
    """A ``$ campaign`` line outside a console block would never be run: none is."""
    text = path.read_text(encoding="utf-8")
    assert len(COMMAND_LINE.findall(text)) == len(file_examples(path))


def test_the_matcher_can_fail():
    assert matches(["a ... c", "...", "z"], ["a b c", "x", "y", "z"])
    assert not matches(["m* = 24.9451 kg"], ["m* = 27.0545 kg"])
    assert not matches(["a", "b"], ["a"])


def test_both_block_syntaxes_are_read():
    markdown = "text\n```console\n$ campaign a\nout a\n\n$ campaign b\n```\n```sh\n$ campaign c\n```\n"
    assert console_examples(markdown) == [("campaign a", ["out a"]), ("campaign b", [])]
    rst = ("text\n\n.. code-block:: console\n   :caption: two\n\n   $ campaign a\n   out a\n\n     indented\n"
           "\n   $ campaign b\nafter\n\n.. code-block:: sh\n\n   $ campaign c\n")
    assert console_examples(rst, rst=True) == [("campaign a", ["out a", "", "  indented"]), ("campaign b", [])]


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    """A scratch folder per file of examples, laid out like the repository's root."""
    folders: dict[Path, Path] = {}

    def folder(path: Path) -> Path:
        if path not in folders:
            folders[path] = scratch_folder(tmp_path_factory.mktemp(path.stem))
        return folders[path]

    return folder


@pytest.mark.parametrize("path, command, shown", EXAMPLES, ids=[_id(p, c) for p, c, _ in EXAMPLES])
def test_console_example(scratch, monkeypatch, capsys, path, command, shown):
    run_example(command, shown, scratch(path), monkeypatch, capsys)
