"""The user guide (docs/) builds without a single warning, has a page per stage, and the
product's text cites no tracker entries or work sessions."""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
from html import unescape
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

#: one page per stage of the campaign, each with the title it must carry
STAGE_PAGES = {
    "model": "Model and Ex-IIT",
    "rig": "The rig: a simulated VES-II",
    "archive": "The archive format",
    "identification": "Identification",
    "lambda_fit": "The lambda fit",
    "design": "Experiment design for lambda",
    "workflow": "The workflow",
    "cluster": "Running on a cluster",
    "calibration": "Calibration and validation",
    "planner": "The impact planner",
    "studies": "Studies",
    "benchmarks": "Benchmarks",
}


@pytest.fixture(scope="module")
def built_guide(tmp_path_factory):
    """The guide built as ``make docs`` builds it (warnings are errors, every reference
    checked), into a temporary folder: from a copy of docs/ beside links to the package and
    config/, so the API pages its configuration writes (docs/generated/) go into the copy,
    not into the repository."""
    root = tmp_path_factory.mktemp("guide")
    shutil.copytree(REPO / "docs", root / "docs", ignore=shutil.ignore_patterns("_build", "generated"))
    for name in ("campaign", "config"):
        (root / name).symlink_to(REPO / name)
    out = root / "html"
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-n", "-q",
         str(root / "docs"), str(out)],
        capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"sphinx-build failed:\n{proc.stderr}\n{proc.stdout}"
    assert "WARNING" not in proc.stderr, proc.stderr
    return out


@pytest.mark.slow
def test_the_guide_builds_with_a_page_per_stage_and_an_api_page_per_module(built_guide):
    index = (built_guide / "index.html").read_text(encoding="utf-8")
    for page, title in STAGE_PAGES.items():
        html = (built_guide / f"{page}.html").read_text(encoding="utf-8")
        assert f"<h1>{title}" in html, f"{page}.html lacks its title {title!r}"
        assert f'href="{page}.html"' in index, f"index.html does not link {page}.html"
    # the API reference documents the functions users import, on their package's page
    identify = (built_guide / "generated" / "campaign.identify.html").read_text(encoding="utf-8")
    assert 'id="campaign.identify.identify_trial"' in identify
    archive = (built_guide / "generated" / "campaign.archive.html").read_text(encoding="utf-8")
    assert 'id="campaign.archive.open_trial"' in archive
    # a module's page documents its functions also when its package re-exports them
    trial = (built_guide / "generated" / "campaign.rig.trial.html").read_text(encoding="utf-8")
    assert 'id="campaign.rig.trial.simulate_arrays"' in trial
    rig = (built_guide / "generated" / "campaign.rig.html").read_text(encoding="utf-8")
    assert 'id="campaign.rig.simulate"' in rig


#: a section underline docutils did not take as one (e.g. a title line glued to the paragraph
#: above it) survives as running text; -W does not catch it
_UNDERLINE = re.compile(r"\^{4,}|-{4,}|={4,}|~{4,}")
#: the project's internal design notes are not shipped: a page cannot send the reader there
_INTERNAL = re.compile(r"design brief|shared/design", re.IGNORECASE)


def _page_text(html: str) -> str:
    """The text a reader sees in a built page: tags stripped, code blocks (which may hold
    tables drawn with dashes) and scripts left out."""
    html = re.sub(r"<(pre|script|style)\b.*?</\1>", " ", html, flags=re.DOTALL | re.IGNORECASE)
    return unescape(re.sub(r"<[^>]+>", " ", html))


@pytest.mark.slow
def test_no_guide_page_shows_a_literal_heading_underline_or_cites_internal_notes(built_guide):
    pages = [p for p in built_guide.rglob("*.html") if "_static" not in p.parts and "_sources" not in p.parts]
    assert len(pages) > len(STAGE_PAGES)
    hits = []
    for page in pages:
        text = _page_text(page.read_text(encoding="utf-8"))
        for pattern in (_UNDERLINE, _INTERNAL):
            for m in pattern.finditer(text):
                context = " ".join(text[max(0, m.start() - 60):m.end() + 20].split())
                hits.append(f"{page.relative_to(built_guide)}: {m.group()!r} in ...{context}...")
    assert not hits, "\n".join(hits)


def _parsers(parser, path):
    """``(command path, parser)`` of ``parser`` and of every subcommand under it."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, f"{path} {name}")


def test_no_help_text_shows_an_escaped_percent():
    # argparse expands "%%" in an option's help, but prints a description as written
    from campaign.cli.main import build_parser

    pages = dict(_parsers(build_parser(None), "campaign"))
    assert "campaign design" in pages and "campaign archive verify" in pages
    hits = [f"{path}: {line.strip()}" for path, parser in pages.items()
            for line in parser.format_help().splitlines() if "%%" in line or "%(" in line]
    assert not hits, "\n".join(hits)


#: what a user of the package has no use for: tracker numbers and numbered work sessions
_HISTORY = re.compile(r"\bissues? #?[0-9]|\bsession [0-9]", re.IGNORECASE)
_PRODUCT = ("campaign", "workflow", "config", "benchmarks", "docs", "README.md", "Snakefile", "Makefile", "profiles")
_TEXT = {".py", ".smk", ".yaml", ".yml", ".md", ".rst", ".txt", ""}


def test_product_text_cites_no_tracker_entries_or_sessions():
    hits = []
    for top in _PRODUCT:
        root = REPO / top
        files = [root] if root.is_file() else [p for p in root.rglob("*") if p.is_file()]
        for path in files:
            if path.suffix not in _TEXT or "_build" in path.parts or "generated" in path.parts:
                continue
            for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
                if _HISTORY.search(line):
                    hits.append(f"{path.relative_to(REPO)}:{n}: {line.strip()[:100]}")
    assert not hits, "\n".join(hits)
