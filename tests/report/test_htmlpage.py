"""The campaign's Markdown as HTML for the report: tables, lists, headings, escaping."""

from __future__ import annotations

import re

from campaign.report.html import markdown_page, markdown_to_html
from campaign.report.tables import Table


def test_a_table_renders_cell_by_cell():
    table = Table(name="t", title="Table X: m* <kg>", columns=[("c", "config"), ("m", "m* [kg]")],
                  rows=[{"c": 1, "m": 6.956}, {"c": 2, "m": None}], notes=["lambda_2 is *not* identifiable"])
    body = markdown_to_html(table.to_markdown())
    assert "<h3>Table X: m* &lt;kg&gt;</h3>" in body
    assert "<thead><tr><th>config</th><th>m* [kg]</th></tr></thead>" in body
    assert "<tr><td>1</td><td>6.956</td></tr>" in body and "<tr><td>2</td><td>-</td></tr>" in body
    assert "<li>lambda_2 is <em>not</em> identifiable</li>" in body


def test_paragraphs_code_and_bold():
    body = markdown_to_html("# Report\n\nFit by `campaign calibrate`,\n**2 of 7** met.\n\n- a\n- b <c>\n")
    assert body == ("<h1>Report</h1>\n<p>Fit by <code>campaign calibrate</code>, <strong>2 of 7</strong> met.</p>\n"
                    "<ul>\n<li>a</li>\n<li>b &lt;c&gt;</li>\n</ul>\n")


def test_a_page_is_complete():
    page = markdown_page("text", title="T & U")
    assert page.startswith("<!DOCTYPE html>") and "<title>T &amp; U</title>" in page and page.endswith("</html>\n")


def test_a_wide_table_scrolls_in_its_own_box():
    # the report's frame can be narrower than a table: its scrollbar belongs right under it
    page = markdown_page("| a | b |\n|---|---|\n| 1 | 2 |\n", title="t")
    assert '<div class="table-scroll"><table>' in page and "</table></div>" in page
    assert re.search(r"\.table-scroll \{[^}]*overflow-x: auto", page)
