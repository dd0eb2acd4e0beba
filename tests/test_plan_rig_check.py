"""The rig check's table: the benchmark's CSV rendered for the campaign report."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import pytest

from campaign.tables import rig_check_table

REPO = Path(__file__).resolve().parents[1]
BENCH = REPO / "benchmarks"


def load_benchmark():
    spec = importlib.util.spec_from_file_location("plan_rig_check", BENCH / "plan_rig_check.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def summary(**over):
    row = {"point": "p", "base": "flexible", "structure": "space_class", "object_kg": 0.716, "frequency": 0.7,
           "branches": 4, "candidates": 16, "refused": 0, "pred_range": (0.002, 0.004),
           "meas_range": (0.001, 0.005), "spearman": 0.95, "best_over_worst": 0.25}
    row.update(over)
    return row


def test_benchmark_csv_round_trips_into_the_report_table(tmp_path):
    bench = load_benchmark()
    path = tmp_path / "rig.csv"
    bench.write_csv(path, [summary(), summary(base="fixed", structure="", frequency=None,
                                          pred_range=(50.0, 60.0), meas_range=(49.0, 58.0), spearman=0.5)])
    assert [p.name for p in tmp_path.iterdir()] == ["rig.csv"]          # no temporary left behind
    t = rig_check_table(path)
    flex, fixed = t.rows
    # displacements in mm, forces in N
    assert flex["predicted"] == "2-4" and flex["measured"] == "1-5" and flex["quantity"].endswith("[mm]")
    assert flex["base"] == "flexible (space_class)" and flex["f1"] == pytest.approx(0.7)
    assert fixed["predicted"] == "50-60" and fixed["quantity"] == "peak contact force [N]" and fixed["f1"] is None
    assert fixed["spearman"] == pytest.approx(0.5) and flex["best_over_worst"] == pytest.approx(0.25)
    assert "| 16 (0) |" in t.to_markdown()


def test_empty_csv_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "rig.csv"
    path.write_text(",".join(load_benchmark().CSV_COLUMNS) + "\n")
    with pytest.raises(ValueError, match="rig.csv: no rows"):
        rig_check_table(path)


def test_committed_rig_check_covers_both_points_every_base_and_both_objects():
    with open(BENCH / "plan_rig_check.csv", newline="") as fh:
        src = list(csv.DictReader(fh))
    cells = {(r["point"], r["base"], r["structure"]) for r in src}
    assert cells == {(p, b, s) for p in ("config 1 wrist centre", "side point")
                     for b, s in (("fixed", ""), ("flexible", "space_class"), ("flexible", "stiff_mast"))}
    assert len({r["object_kg"] for r in src}) == 2
    # every base of every point has simulated candidates, so each correlation is a number
    assert all(int(r["candidates"]) >= 8 for r in src)
    t = rig_check_table(BENCH / "plan_rig_check.csv")
    assert all(-1.0 <= r["spearman"] <= 1.0 and 0.0 < r["best_over_worst"] <= 1.0 for r in t.rows)
