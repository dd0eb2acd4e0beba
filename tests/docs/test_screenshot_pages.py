"""``tests/screenshots.py --report R`` checks the table pages of R's own campaign, not the
reduced campaign's: the pages beside the report it was given."""

from __future__ import annotations

from pathlib import Path

import screenshots


def test_the_table_pages_are_those_beside_the_report_given(tmp_path):
    full = tmp_path / "results" / "full"
    for page in ("tables/table2.html", "tables/table3.html", "identify/summary.html"):
        (full / page).parent.mkdir(parents=True, exist_ok=True)
        (full / page).write_text("<table></table>")
    (full / "report.html").write_text("<html></html>")
    (tmp_path / "results" / "ci" / "tables").mkdir(parents=True)
    (tmp_path / "results" / "ci" / "tables" / "table2.html").write_text("<table></table>")
    folder, pages = screenshots.table_pages(full / "report.html")
    assert folder == full.resolve()
    assert [p.relative_to(full.resolve()).as_posix() for p in pages] == \
        ["identify/summary.html", "tables/table2.html", "tables/table3.html"]


def test_without_a_report_the_reduced_campaign_it_builds_is_checked():
    folder, _ = screenshots.table_pages(None)
    assert folder == Path(screenshots.REPO) / "results" / "ci"
