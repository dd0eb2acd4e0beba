"""The architecture page (docs/architecture.rst) and the README's layout name the package's
layers as :data:`campaign.LAYERS` declares them, bottom up, and the README's layout names
only folders and files that exist."""

from __future__ import annotations

import re
from pathlib import Path

from campaign import LAYERS

REPO = Path(__file__).resolve().parents[2]


def readme_layout() -> list[str]:
    """The lines of the code block of the README's ``## Layout`` section."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text.split("\n## Layout\n", 1)[1]
    return re.search(r"```\n(.*?)```", section, re.S).group(1).splitlines()


def test_the_architecture_page_lists_the_layers_bottom_up():
    text = (REPO / "docs" / "architecture.rst").read_text(encoding="utf-8")
    table = text.split("The layers\n", 1)[1].split("The rule\n", 1)[0]
    assert re.findall(r"^   \* - ``(\w+)``$", table, re.M) == list(LAYERS)


def test_the_readme_layout_lists_the_layers_bottom_up():
    packages = [m.group(1) for line in readme_layout() if (m := re.match(r"  (\w+)/ ", line))]
    assert packages == list(LAYERS)


def test_what_the_readme_layout_names_exists():
    named = []
    for line in readme_layout():
        if line.startswith(" "):
            continue
        head = re.split(r"\s{2,}", line.strip())[0]
        named += [name.strip() for name in head.split(",")]
    assert "campaign/" in named and "Snakefile" in named
    missing = [name for name in named if not (REPO / name).exists()]
    assert missing == []
