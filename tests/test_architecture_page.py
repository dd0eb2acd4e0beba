"""The architecture page (docs/architecture.rst) names the package's layers as
:data:`campaign.LAYERS` declares them, bottom up."""

from __future__ import annotations

import re
from pathlib import Path

from campaign import LAYERS

REPO = Path(__file__).resolve().parents[1]


def test_the_architecture_page_lists_the_layers_bottom_up():
    text = (REPO / "docs" / "architecture.rst").read_text(encoding="utf-8")
    table = text.split("The layers\n", 1)[1].split("The rule\n", 1)[0]
    assert re.findall(r"^   \* - ``(\w+)``$", table, re.M) == list(LAYERS)
