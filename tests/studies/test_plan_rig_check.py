"""The impact planner checked on the rig (campaign.studies.plan_rig_check) and its table, the
study's CSV rendered for the campaign report."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.report.tables import rig_check_table
from campaign.studies import plan_rig_check as bench
from campaign.studies.common import write_csv


def summary(**over):
    row = {"point": "p", "base": "flexible", "structure": "space_class", "object_kg": 0.716, "frequency": 0.7,
           "branches": 4, "candidates": 16, "refused": 0, "pred_range": (0.002, 0.004),
           "meas_range": (0.001, 0.005), "spearman": 0.95, "best_over_worst": 0.25, "spearman_at_once": 0.7,
           "best_over_worst_at_once": 0.3, "spearman_release": 0.6, "best_over_worst_release": 0.8}
    row.update(over)
    return row


def test_study_csv_round_trips_into_the_report_table(tmp_path):
    path = tmp_path / "rig.csv"
    write_csv(path, bench.csv_rows([summary(), summary(base="fixed", structure="", frequency=None,
                                                       pred_range=(50.0, 60.0), meas_range=(49.0, 58.0),
                                                       spearman=0.5)]), bench.CSV_COLUMNS)
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
    path.write_text(",".join(bench.CSV_COLUMNS) + "\n")
    with pytest.raises(ValueError, match="rig.csv: no rows"):
        rig_check_table(path)


def test_rank_scores_of_hand_made_candidates():
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
    from campaign.plan.directions import horizontal_directions
    from campaign.plan.factory import build_planner

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

    dirs = horizontal_directions(2)
    settings = (("no gravity", {"gravity": 0.0}),)
    rows = bench.sign_asymmetry(1.0, dirs, speeds=(), gains=("zero",), settings=settings)
    assert [(r["speed_m_s"], r["rig"], r["gain"]) for r in rows] == [(1.0, "no gravity", "zero")]
    diff, excursion = rows[0]["largest_pm_n_difference"], rows[0]["largest_joint_excursion_rad"]
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
    assert diff == pytest.approx(max(want_diff), rel=1e-12)
    assert excursion == pytest.approx(max(want_exc), rel=1e-12)
