"""The report and the user guide as a reader sees them: built, opened in headless Chromium,
checked and photographed.

``make screenshots`` (or ``python tests/screenshots.py``) builds the reduced campaign
(``snakemake --cores 2 --configfile config/tests/ci.yaml``), its report (``--report``) and the guide
(as ``make docs``), then opens them in headless Chromium and

* checks every category of the report: one row per figure or table, labelled (never by its
  file's path), the format a toggle and not a column, and the item a row opens by default an
  image or a page, never a PDF (Chromium shows a PDF in the report's frame as a blank pane);
  the workflow description and the captions run no sentence into the next ("ci.The");
* checks every table page of the report's campaign (the pages beside the report:
  ``results/full/*/*.html`` for ``--report results/full/report.html``; ``results/ci`` for the
  report it builds) at a narrow width: a table wider than the frame scrolls in its own box,
  the page itself is not wider than the frame;
* checks the guide pages it shows for a heading underline left as text;
* saves a PNG of each view into ``build/screenshots/`` (git-ignored), for a person to look at.

It prints one line per check and exits 1 if any fails. Without Chromium (``chromium``,
``chromium-browser``, ``google-chrome`` on the PATH, or the ``CHROMIUM`` variable) it says so
and exits 0: ``make test`` does not depend on it. Debian: ``apt-get install -y chromium``.
"""

from __future__ import annotations

import argparse
import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "build" / "screenshots"
#: the reduced campaign's configuration and the report built from it
CONFIG = "config/tests/ci.yaml"
#: how long the page's scripts may run before the picture is taken [ms of virtual time]
BUDGET_MS = 8000

#: report views to photograph: name -> (category, subcategory, row label or None, window size)
REPORT_VIEWS = {
    "report-overview": (None, None, None, (1400, 1000)),
    "report-fixed-base-figure5": ("Fixed base", "Figures", "Figure 5", (1400, 1000)),
    "report-flexible-base-figure8": ("Flexible base", "Figures", "Figure 8", (1400, 1000)),
    "report-flexible-base-table4-narrow": ("Flexible base", "Tables", "Table 4", (1000, 800)),
    "report-calibration": ("Calibration", None, None, (1400, 1000)),
    "report-planner-directions": ("Impact planner", "Maps", "directions", (1400, 1000)),
}
#: guide pages to photograph from their top (a headless picture of a page scrolled to an anchor
#: comes out with a blank band): name -> (page, window size)
GUIDE_VIEWS = {
    "guide-identification": ("identification.html", (1400, 2000)),
    "guide-design": ("design.html", (1400, 1600)),
}

#: the script the report runs after it has loaded: ``show()`` opens a view as a reader would
#: (the category, its subcategory, a row's view button); ``check()`` walks every category and
#: writes what it finds into <pre id="screenshot-check">, one JSON object a line
_REPORT_JS = r"""
function later(f) { setTimeout(f, 400); }
function note(obj) {
  var pre = document.getElementById("screenshot-check");
  if (!pre) { pre = document.createElement("pre"); pre.id = "screenshot-check"; pre.hidden = true;
              document.body.appendChild(pre); }
  pre.textContent += JSON.stringify(obj) + "\n";
}
function rows() {
  return [...document.querySelectorAll("table tbody tr")].map(function (tr) {
    return {label: tr.querySelector("td").textContent.trim(), button: tr.querySelector("a")};
  });
}
function openSub(category, subcategory, then) {
  // through the menu, as a reader goes: the report keeps a list's rows while it stays on screen
  app.setView({navbarMode: "menu"});
  later(function () {
    app.showCategory(category);
    later(function () {
      if (subcategory) { app.setView({navbarMode: "subcategory", category: category, subcategory: subcategory}); }
      later(then);
    });
  });
}
function shownKind() {
  return app.state.content + " " + (app.state.contentPath || "").slice(5, 20);
}
function show(category, subcategory, label) {
  if (!category) { app.setView({content: "rulegraph", navbarMode: "menu"}); return; }
  openSub(category, subcategory, function () {
    var row = rows().find(function (r) { return label === null || r.label.indexOf(label) >= 0; });
    if (row) { row.button.click(); }
  });
}
function check() {
  var text = function (h) { var d = document.createElement("div"); d.innerHTML = h; return d.textContent; };
  var prose = [["workflow description", text(workflow_desc)]].concat(
    Object.keys(results).map(function (p) { return ["caption of " + p, text(results[p].caption || "")]; }));
  prose.forEach(function (pair) {
    // a word, a full stop and the next sentence's first word, with no space; a dotted name
    // (campaign.rig.beam.Beam) is no sentence
    var m = pair[1].match(/(^|\s)([^\s.]+)\.([A-Z][a-z]+)\b/);
    note({check: "sentences apart: " + pair[0], ok: !m, detail: m ? pair[1].slice(Math.max(0, m.index - 30), m.index + 40) : ""});
  });
  var subs = [];
  Object.keys(categories).forEach(function (c) { Object.keys(categories[c]).forEach(function (s) { subs.push([c, s]); }); });
  function next(i) {
    if (i >= subs.length) { note({done: true}); return; }
    var c = subs[i][0], s = subs[i][1];
    openSub(c, s, function () {
      var head = [...document.querySelectorAll("table thead th")].map(function (th) { return th.textContent.trim(); });
      var found = rows(), labels = found.map(function (r) { return r.label; });
      var where = c + " / " + s;
      note({check: "one row per item: " + where, ok: new Set(labels).size === labels.length, detail: labels.join(" | ")});
      note({check: "labelled, not by a path: " + where, ok: labels.every(function (l) { return l.indexOf("/") < 0; }), detail: labels.join(" | ")});
      note({check: "format a toggle, not a column: " + where, ok: head.map(function (h) { return h.toLowerCase(); }).indexOf("format") < 0, detail: head.join(" | ")});
      function open(k) {
        if (k >= found.length) { next(i + 1); return; }
        found[k].button.click();
        later(function () {
          var kind = shownKind();
          note({check: "opens as image or page: " + where + " / " + found[k].label, ok: /^(img|html) /.test(kind), detail: kind});
          open(k + 1);
        });
      }
      open(0);
    });
  }
  next(0);
}
"""

#: the script a table page runs: is the page wider than the frame?
_TABLE_JS = r"""
window.addEventListener("load", function () {
  var pre = document.createElement("pre"); pre.id = "screenshot-check"; pre.hidden = true;
  var root = document.documentElement;
  pre.textContent = JSON.stringify({scroll: root.scrollWidth, width: window.innerWidth,
                                    boxes: document.querySelectorAll(".table-scroll").length,
                                    tables: document.querySelectorAll("table").length});
  document.body.appendChild(pre);
});
"""


def find_chromium() -> str | None:
    """The Chromium to run: the ``CHROMIUM`` variable, else the first one on the PATH."""
    if os.environ.get("CHROMIUM"):
        return os.environ["CHROMIUM"]
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def chromium(browser: str, url: str, *, size: tuple[int, int], screenshot: Path | None = None,
             budget_ms: int = BUDGET_MS) -> str:
    """The DOM of ``url`` after its scripts ran, and its picture into ``screenshot``.

    Each call runs a fresh headless browser with a new empty profile, nothing fetched from
    the network, as root too (``--no-sandbox``)."""
    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:
        args = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                f"--user-data-dir={profile}", f"--virtual-time-budget={budget_ms}",
                f"--window-size={size[0]},{size[1]}"]
        if screenshot is not None:
            subprocess.run([*args, f"--screenshot={screenshot}", url], capture_output=True, timeout=120, check=True)
        dom = subprocess.run([*args, "--dump-dom", url], capture_output=True, text=True, timeout=120, check=True)
    return dom.stdout


def _checks_in(dom: str) -> list[dict]:
    m = re.search(r'<pre id="screenshot-check"[^>]*>(.*?)</pre>', dom, re.S)
    return [json.loads(line) for line in html.unescape(m.group(1)).splitlines() if line.strip()] if m else []


def _with_script(page: Path, script: str, out: Path) -> Path:
    """A copy of ``page`` that runs ``script`` once loaded."""
    text = page.read_text(encoding="utf-8")
    at = text.rindex("</body>")
    out.write_text(text[:at] + f"<script>{script}</script>" + text[at:], encoding="utf-8")
    return out


def build(*, report: Path) -> None:
    """The reduced campaign, its report and the guide, as ``make campaign`` and ``make docs`` make them."""
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    for cmd in ([snakemake, "--cores", "2", "--configfile", CONFIG],
                [snakemake, "--configfile", CONFIG, "--report", str(report)],
                [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-n", "-q", "docs",
                 "docs/_build/html"]):
        print("screenshots: running", " ".join(cmd[1:] if cmd[0] == sys.executable else cmd), flush=True)
        subprocess.run(cmd, cwd=REPO, check=True)


def check_report(browser: str, report: Path, out: Path) -> list[tuple[str, bool, str]]:
    """Every category's rows and default views, and the prose, as the report shows them."""
    page = _with_script(report, _REPORT_JS + 'window.addEventListener("load", function () { later(check); });',
                        out / "check-report.html")
    # virtual time, a few seconds of real time: every category and every item is opened
    found = _checks_in(chromium(browser, page.as_uri(), size=(1400, 1000), budget_ms=300_000))
    results = [(c["check"], c["ok"], c.get("detail", "")) for c in found if "check" in c]
    if not any(c.get("done") for c in found):
        results.append(("the report's checks ran to the end", False, f"{len(results)} checks before it stopped"))
    return results


def table_pages(report: Path | None) -> tuple[Path, list[Path]]:
    """(folder, its table pages): those of the campaign whose report is ``report``, the pages
    beside it (``results/<campaign>/*/*.html`` for ``results/<campaign>/report.html``), or,
    with no report given, those of the reduced campaign this script builds (``results/ci``)."""
    folder = REPO / "results" / "ci" if report is None else Path(report).resolve().parent
    return folder, sorted(folder.glob("*/*.html"))


def check_tables(browser: str, out: Path, report: Path | None = None) -> list[tuple[str, bool, str]]:
    """Each table page of the campaign of ``report`` (default the reduced campaign) at a narrow
    width: no page wider than its frame."""
    results = []
    folder, pages = table_pages(report)
    for page in pages:
        copy = _with_script(page, _TABLE_JS, out / f"check-{page.parent.name}-{page.stem}.html")
        found = _checks_in(chromium(browser, copy.as_uri(), size=(600, 800)))
        m = found[0] if found else {}
        ok = bool(m) and m["scroll"] <= m["width"] and m["boxes"] == m["tables"]
        results.append((f"a wide table scrolls in its own box: {page}", ok, json.dumps(m)))
    if not pages:
        results.append(("table pages found", False, f"no {folder}/*/*.html"))
    return results


def photograph(browser: str, report: Path, guide: Path, out: Path) -> list[tuple[str, bool, str]]:
    """The views of :data:`REPORT_VIEWS` and :data:`GUIDE_VIEWS` as PNGs; the guide's text checked."""
    results = []
    for name, (category, subcategory, label, size) in REPORT_VIEWS.items():
        call = json.dumps([category, subcategory, label])[1:-1]
        script = _REPORT_JS + f'window.addEventListener("load", function () {{ later(function () {{ show({call}); }}); }});'
        page = _with_script(report, script, out / f"{name}.html")
        chromium(browser, page.as_uri(), size=size, screenshot=out / f"{name}.png")
        results.append((f"screenshot {name}.png", (out / f"{name}.png").is_file(), ""))
    for name, (path, size) in GUIDE_VIEWS.items():
        dom = chromium(browser, (guide / path).as_uri(), size=size, screenshot=out / f"{name}.png")
        text = html.unescape(re.sub(r"<[^>]+>", " ", re.sub(r"<(pre|script|style)\b.*?</\1>", " ", dom, flags=re.S)))
        runs = re.findall(r"\^{4,}|-{4,}|={4,}|~{4,}", text)
        results.append((f"no heading underline left as text: {path}", not runs, " ".join(runs[:3])))
        results.append((f"screenshot {name}.png", (out / f"{name}.png").is_file(), ""))
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--skip-build", action="store_true",
                        help="use the report and the guide already built (build/screenshots/report.html, docs/_build)")
    parser.add_argument("--out", type=Path, default=OUT, help=f"folder of the screenshots (default {OUT})")
    parser.add_argument("--report", type=Path, default=None,
                        help="check and photograph this report (implies --skip-build; default OUT/report.html)")
    args = parser.parse_args(argv)
    browser = find_chromium()
    if browser is None:
        print("screenshots: skipped: no Chromium found (chromium, chromium-browser, google-chrome on the PATH, "
              "or CHROMIUM=...); on Debian: apt-get install -y chromium")
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    report = args.report.resolve() if args.report else args.out / "report.html"
    if not (args.skip_build or args.report):
        build(report=report)
    results = (check_report(browser, report, args.out) + check_tables(browser, args.out, args.report)
               + photograph(browser, report, REPO / "docs" / "_build" / "html", args.out))
    for name, ok, detail in results:
        print(f"{'ok  ' if ok else 'FAIL'} {name}" + ("" if ok or not detail else f": {detail}"))
    failed = sum(not ok for _, ok, _ in results)
    print(f"screenshots: {len(results) - failed} of {len(results)} checks passed; pictures in {args.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
