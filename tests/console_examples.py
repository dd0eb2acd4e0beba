"""The console examples of the README and the user guide: read, run and compared.

A console example is a ``$ campaign ...`` line followed by the output it shows, inside a
```console block of a Markdown file or a ``.. code-block:: console`` block of a
reStructuredText page. ``...`` inside a shown line matches any text (timings); a line that
is only ``...`` matches any number of lines.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

from campaign.cli.main import main

REPO = Path(__file__).resolve().parents[1]

#: a command line of an example, wherever it stands in a file
COMMAND_LINE = re.compile(r"^[ \t]*\$ campaign\b", re.M)
_RST_CONSOLE = re.compile(r"^([ \t]*)\.\. code-block:: console[ \t]*$")
_RST_OPTION = re.compile(r"^:[\w-]+:")


def markdown_console_blocks(text: str) -> list[str]:
    """The text of every ```console block of a Markdown file."""
    return re.findall(r"```console\n(.*?)```", text, re.S)


def rst_console_blocks(text: str) -> list[str]:
    """The text of every ``.. code-block:: console`` block of a reStructuredText page,
    dedented, its options (``:caption:`` ...) left out."""
    lines = text.splitlines()
    blocks = []
    for i, line in enumerate(lines):
        directive = _RST_CONSOLE.match(line)
        if not directive:
            continue
        indent = len(directive.group(1))
        body = []
        for following in lines[i + 1:]:
            if following.strip() and len(following) - len(following.lstrip()) <= indent:
                break
            body.append(following)
        content = [b for b in body if b.strip()]
        if not content:
            continue
        margin = min(len(b) - len(b.lstrip()) for b in content)
        body = [b[margin:] for b in body]
        while body and (not body[0].strip() or _RST_OPTION.match(body[0])):
            body.pop(0)
        blocks.append("\n".join(body).strip("\n") + "\n")
    return blocks


def console_examples(text: str, *, rst: bool = False) -> list[tuple[str, list[str]]]:
    """(command, shown output lines) of every ``$ `` line of every console block."""
    blocks = rst_console_blocks(text) if rst else markdown_console_blocks(text)
    examples: list[tuple[str, list[str]]] = []
    for block in blocks:
        for line in block.splitlines():
            if line.startswith("$ "):
                examples.append((line[2:], []))
            elif examples:
                examples[-1][1].append(line)
    # a blank line after an output separates it from the next command
    return [(command, "\n".join(shown).rstrip("\n").splitlines()) for command, shown in examples]


def file_examples(path: Path) -> list[tuple[str, list[str]]]:
    """The console examples of a README (Markdown) or a guide page (reStructuredText)."""
    return console_examples(path.read_text(encoding="utf-8"), rst=path.suffix == ".rst")


def sources() -> list[Path]:
    """README.md and every page of the guide that shows a ``$ campaign`` command."""
    pages = sorted(p for p in (REPO / "docs").glob("*.rst") if COMMAND_LINE.search(p.read_text(encoding="utf-8")))
    return [REPO / "README.md", *pages]


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


def scratch_folder(root: Path) -> Path:
    """``root`` laid out like the repository's root for the examples' relative paths: an
    ``archive/`` holding the committed ``archive/reference`` (a link, read only)."""
    (root / "archive").mkdir()
    (root / "archive" / "reference").symlink_to(REPO / "archive" / "reference")
    return root


def run_example(command: str, shown: list[str], folder: Path, monkeypatch, capsys) -> None:
    """Run ``command`` through :func:`campaign.cli.main.main` in ``folder`` and assert that its
    stdout and stderr match ``shown`` and that it exits with 2 if ``shown`` is an error, else 0."""
    argv = shlex.split(command, comments=True)
    assert argv[0] == "campaign"
    monkeypatch.chdir(folder)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    try:
        status = main(argv[1:])
    except SystemExit as exc:      # a usage error: argparse ends the process
        status = exc.code
    out, err = capsys.readouterr()
    actual = (out + err).rstrip("\n").splitlines()
    expected_status = 2 if any(": error: " in line for line in shown) else 0
    assert status == expected_status, out + err
    assert matches(shown, actual), "\n".join(["shown:", *shown, "actual:", *actual])
