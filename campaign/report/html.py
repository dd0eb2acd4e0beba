"""The campaign's Markdown (tables, calibration notes) as a standalone HTML page.

Snakemake's report shows an HTML result inline and offers anything else (CSV, Markdown)
as a download only; the tables and the calibration notes are written as HTML beside their
Markdown so that the report shows them (a table too wide for the report's frame wraps its
headers and scrolls sideways in its own box). This renders the Markdown the campaign itself
writes (``campaign.report.tables.Table.to_markdown``, the calibration report): headings,
paragraphs, pipe tables, bullet lists, and inline ``code``, ``**bold**`` and ``*italic*``.
Everything else passes through as escaped text; no third-party Markdown package needed.
"""

from __future__ import annotations

import html
import re

__all__ = ["markdown_to_html", "markdown_page"]

#: the report shows a page in a frame that may be narrower than a table: headers and text
#: cells wrap, and a table still too wide scrolls sideways in its own box (its scrollbar right
#: under it, not at the bottom of a frame taller than the screen)
_STYLE = """
body { font-family: sans-serif; font-size: 14px; margin: 1em; }
.table-scroll { overflow-x: auto; max-width: 100%; margin: 0.5em 0 1em 0; }
table { border-collapse: collapse; }
th, td { border: 1px solid #bbb; padding: 0.2em 0.6em; text-align: right; vertical-align: top; }
th { background: #eee; vertical-align: bottom; }
td { font-variant-numeric: tabular-nums; }
td:first-child, th:first-child { text-align: left; }
p, li { max-width: 60em; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


def _inline(text: str) -> str:
    """Escape ``text`` and render its inline code, bold and italic spans."""
    parts = re.split(r"(`[^`]*`)", text)
    out = []
    for part in parts:
        if len(part) >= 2 and part.startswith("`") and part.endswith("`"):
            out.append(f"<code>{html.escape(part[1:-1])}</code>")
            continue
        part = html.escape(part)
        part = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", part)
        part = re.sub(r"(?<![\w*])\*(?!\s)(.+?)(?<!\s)\*(?![\w*])", r"<em>\1</em>", part)
        out.append(part)
    return "".join(out)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _is_rule(line: str) -> bool:
    return bool(re.fullmatch(r"\|?(\s*:?-{3,}:?\s*\|)+\s*:?-*:?\s*\|?", line.strip()))


def markdown_to_html(text: str) -> str:
    """HTML body of the Markdown ``text`` (the subset the module docstring names)."""
    lines = text.splitlines()
    out: list[str] = []
    para: list[str] = []

    def flush() -> None:
        if para:
            out.append(f"<p>{_inline(' '.join(para))}</p>")
            para.clear()

    i = 0
    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        heading = re.match(r"(#{1,6})\s+(.*)", stripped)
        if not stripped:
            flush()
        elif heading:
            flush()
            level = len(heading.group(1))
            out.append(f"<h{level}>{_inline(heading.group(2))}</h{level}>")
        elif stripped.startswith("|") and i + 1 < len(lines) and _is_rule(lines[i + 1]):
            flush()
            head = "".join(f"<th>{_inline(c)}</th>" for c in _cells(stripped))
            rows = []
            i += 2
            while i < len(lines) and lines[i].strip().startswith("|"):
                rows.append("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in _cells(lines[i])) + "</tr>")
                i += 1
            out.append(f"<div class=\"table-scroll\"><table>\n<thead><tr>{head}</tr></thead>\n<tbody>\n"
                       + "\n".join(rows) + "\n</tbody>\n</table></div>")
            continue
        elif re.match(r"[-*]\s+", stripped):
            flush()
            items = []
            while i < len(lines) and re.match(r"\s*[-*]\s+", lines[i]):
                item = re.sub(r"^[-*]\s+", "", lines[i].strip())
                items.append(f"<li>{_inline(item)}</li>")
                i += 1
            out.append("<ul>\n" + "\n".join(items) + "\n</ul>")
            continue
        else:
            para.append(stripped)
        i += 1
    flush()
    return "\n".join(out) + "\n"


def markdown_page(text: str, *, title: str) -> str:
    """A complete HTML page of the Markdown ``text``."""
    return (f"<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<title>{html.escape(title)}</title>\n<style>{_STYLE}</style>\n</head>\n<body>\n"
            f"{markdown_to_html(text)}</body>\n</html>\n")
