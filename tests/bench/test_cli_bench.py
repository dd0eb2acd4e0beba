"""``campaign bench work-precision`` through the CLI, at its test-sized setting ``--smoke``:
the whole command (the sweep, the per-trial cost, the table, the plot, the three files)
runs to its end in seconds. ``campaign bench stress --reduced`` runs in ``test_stress.py``.
"""

from __future__ import annotations

import json

import pytest

from campaign import bench
from campaign.cli.bench import WORK_PRECISION_FILES
from campaign.cli.main import main
from campaign.rig import build


def test_work_precision_smoke_runs_to_the_end_and_writes_its_three_files(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    out = tmp_path / "bench"
    status = main(["bench", "work-precision", "--smoke", "--out", str(out)])
    stdout, stderr = capsys.readouterr()
    assert status == 0, stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(WORK_PRECISION_FILES)
    md, js, png = (out / name for name in WORK_PRECISION_FILES)

    # the sweep: one scene, its default setting and twice its contact substeps, one repeat each
    (spec,) = bench.wp_scenes(size="smoke")
    rig = build(spec.make())
    dc, df = int(rig.substeps_contact), int(rig.substeps_free)
    result = json.loads(js.read_text())
    assert [s["label"] for s in result["scenes"]] == [spec.label] and result["repeats"] == 1
    rows = result["rows"]
    assert [(r["substeps"], r["default"], r["n"]) for r in rows] == [(f"{dc}/{df}", True, 1), (f"{2 * dc}/{df}", False, 1)]
    assert all(0 <= r["combined"] < 1e-2 and r["wall"] > 0 for r in rows)     # against the 32x reference
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    # the printed text is the Markdown file, then the files written
    lines = stdout.splitlines()
    assert lines[-1] == f"wrote {md}, {js}, {png}"
    assert stdout.startswith(md.read_text())
    text = md.read_text().splitlines()
    assert text[0].startswith("| scene | setting | substeps c/f | steps | RHS evals | median wall [ms] |")
    assert sum(line.startswith(f"| {spec.label} | ") for line in text) == 2 + 1      # two settings, one reference
    assert any(line.startswith(f"- {spec.label}: default rk4 {dc}/{df} ") for line in text)
    for header in ("| base | trials timed | median simulation [ms] |", "| base | median write_trial [ms] |",
                   "| same run, configuration 1, Zero gains, 1.5 m/s | median wall [ms] |"):
        assert any(line.startswith(header) for line in text), header
    assert text[-1].startswith("Machine: ")
    assert f"[wp] {spec.label}: default {dc}/{df}; reference" in stderr and "[cost] simulated 1 trials" in stderr


def test_the_smaller_sizes_run_a_part_of_the_full_benchmark():
    """``quick`` and ``smoke`` leave scenes and settings out; they add none of their own."""
    full = {s.label: s for s in bench.wp_scenes(size="full")}
    for size in ("quick", "smoke"):
        assert all(full[s.label] == s for s in bench.wp_scenes(size=size))
        for dc, df in ((1, 1), (25, 2)):
            assert set(bench.wp_settings(dc, df, size=size)) <= set(bench.wp_settings(dc, df, size="full"))
            assert sum(s.default for s in bench.wp_settings(dc, df, size=size)) == 1
    assert len(bench.wp_scenes(size="smoke")) == 1 < len(bench.wp_scenes(size="quick")) < len(full)
    with pytest.raises(ValueError, match="'tiny'"):
        bench.wp_scenes(size="tiny")


def test_the_plot_takes_any_number_of_scenes(tmp_path):
    """Four scenes (``--quick``'s count) fill two rows of three panels, one spare."""
    rows = [dict(scene=f"scene {i}", setting=f"rk4 {c}/1", default=c == 1, naive=False, wall=0.02 * c, ident=1e-4 / c,
                 velocity=1e-5 / c, measured=1e-3 / c, combined=1e-4 / c, front=True)
            for i in range(4) for c in (1, 2)]
    result = {"scenes": [{"label": f"scene {i}"} for i in range(4)], "rows": rows}
    path = bench.plot_work_precision(result, tmp_path / "wp.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
