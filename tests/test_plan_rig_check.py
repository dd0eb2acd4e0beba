"""The rig check's table: the benchmark's CSV rendered for the campaign report."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from campaign.report.tables import rig_check_table

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
           "meas_range": (0.001, 0.005), "spearman": 0.95, "best_over_worst": 0.25, "spearman_at_once": 0.7,
           "best_over_worst_at_once": 0.3, "spearman_release": 0.6, "best_over_worst_release": 0.8}
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
    assert flex["spearman_at_once"] == pytest.approx(0.7) and fixed["best_over_worst_at_once"] == pytest.approx(0.3)
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
    # the flexible rows also rank by eq 8's release alone (without the post-contact term)
    for r in t.rows:
        flexible = r["base"].startswith("flexible")
        assert (r["spearman_release"] is not None) == flexible
        assert not flexible or -1.0 <= r["spearman_release"] <= 1.0


def test_rank_scores_of_hand_made_candidates():
    bench = load_benchmark()
    s = bench.rank_scores([1.0, 2.0, 3.0, 4.0], [0.2, 0.3, 0.5, 0.8])
    assert s["spearman"] == pytest.approx(1.0) and s["best_over_worst"] == pytest.approx(0.25)
    s = bench.rank_scores([4.0, 3.0, 2.0, 1.0], [0.2, 0.3, 0.5, 0.8])
    assert s["spearman"] == pytest.approx(-1.0) and s["best_over_worst"] == pytest.approx(1.0)
    s = bench.rank_scores([1.0, 2.0], [0.2, 0.3])                   # too few to rank
    assert all(v != v for v in s.values())


def test_small_rig_check_simulates_every_candidate_and_scores_the_planner():
    """Configuration 1's point, two gain sets, the paper's direction and its opposite, fixed base and
    the space-class structure: every candidate is simulated or refused with a reason, and each
    simulated one carries the planner's own prediction."""
    from campaign.plan.factory import build_planner
    from campaign.plan.directions import horizontal_directions

    bench = load_benchmark()
    point = bench.contact_points()["config 1 wrist centre"]
    dirs = horizontal_directions(2)
    rows = bench.check_point("c1", point, directions=dirs, speed=2.0, gains=("zero", "high"),
                             bases=(("fixed", None), ("flexible", "space_class")))
    assert [(r["base"], r["structure"]) for r in rows] == [("fixed", ""), ("flexible", "space_class")]
    table3 = {"zero_low": [19.82, 4.62, 0.80], "high": [53.18, 8.66, 2.83]}
    for r in rows:
        assert r["candidates"] + r["refused"] == r["branches"] * 2 * len(dirs)
        assert r["candidates"] >= 3 and len(r["refusals"]) <= r["refused"]
        planner = build_planner(base=r["base"], lambdas=table3, speed=2.0, mass=bench.hammer_mass(),
                                structure=r["structure"] or None).fit(point, dirs)
        P = planner.predictions_
        for c in r["cands"]:
            g = planner.gain_classes_.index(c["gain"] if c["gain"] in planner.gain_classes_ else
                                            bench.GAIN_CLASS[c["gain"]])
            want = P.peak_force if r["base"] == "fixed" else P.structure_peak
            assert c["predicted"] == pytest.approx(float(want[c["branch"] - 1, g, c["d"]]), rel=1e-12)
            assert c["measured"] > 0 and 0 < c["contact"] < 0.5
        s = bench.rank_scores([c["predicted"] for c in r["cands"]], [c["measured"] for c in r["cands"]])
        assert r["spearman"] == s["spearman"] and -1.0 <= r["spearman"] <= 1.0
        assert 0.0 < r["best_over_worst"] <= 1.0
    assert "spearman_release" not in rows[0] and -1.0 <= rows[1]["spearman_release"] <= 1.0
    csv_rows = bench.csv_rows(rows)
    assert csv_rows[0]["spearman_release"] == "" and float(csv_rows[1]["spearman_release"]) == pytest.approx(
        rows[1]["spearman_release"], abs=1e-4)


def test_sign_check_reports_the_measured_difference_of_opposite_directions():
    """The sign check's difference and joint excursion are those of the rig's own trials of a +-n pair."""
    from campaign.model.robot import load_robot
    from campaign.model.robot.ik import position_branches
    from campaign.plan.directions import horizontal_directions

    bench = load_benchmark()
    dirs = horizontal_directions(2)
    settings = (("no gravity", {"gravity": 0.0}),)
    lines = bench.sign_asymmetry(1.0, dirs, speeds=(), gains=("zero",), settings=settings)
    assert len(lines) == 3 and lines[2].startswith("| 1 | no gravity | ")
    diff, excursion = lines[2].strip("| ").split(" | ")[2:4]
    # independently: each branch's two trials, the peak base displacement and the joints' excursion
    params = bench.with_structure({"gravity": 0.0}, "space_class")
    point = bench.contact_points()["config 1 wrist centre"]
    want_diff, want_exc = [], []
    for q in position_branches(load_robot("puma560"), point).q:
        peaks = []
        for n in dirs:
            truth, _, why = bench.simulate_truth("flexible", q, "zero", n, 1.0, params)
            if why is not None:
                continue
            x = np.linalg.norm(truth["base_position"].values, axis=1)
            qt = truth["q"].values[: int(np.argmax(x)) + 1]
            peaks.append(x.max())
            want_exc.append(np.abs(qt - qt[0]).max())
        if len(peaks) == 2:
            want_diff.append(abs(peaks[0] / peaks[1] - 1))
    assert want_diff, "no branch struck from both sides"
    assert diff == f"{100 * max(want_diff):.1f} %"
    assert excursion == f"{np.degrees(max(want_exc)):.0f} deg"
