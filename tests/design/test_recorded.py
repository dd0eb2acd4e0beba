"""Lambda from recorded hits: identifiability of the recorded poses, the fit along what a
session determines, the range of another session's prediction, on synthetic per-hit rows
of a seven-axis test arm with a known lambda (no recorded data)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.design.recorded import (
    identifiability,
    log_sensitivity,
    prediction_range,
    read_hit_rows,
    subspace_fit,
    transfer,
)
from campaign.model.exiit import effective_mass_batch
from campaign.model.robot import load_robot

from seven_axis import POSES_DEG, hit_rows, write_arm, write_rows

#: the known lambda of the synthetic hits [kg m^2]
LAM = np.array([0.3, 0.3, 0.1, 0.1, 0.05, 0.02, 0.02])


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    folder = write_arm(tmp_path_factory.mktemp("arm") / "seven_axis")
    return folder, load_robot(folder)


@pytest.fixture(scope="module")
def hits_csv(arm, tmp_path_factory):
    _, robot = arm
    return write_rows(tmp_path_factory.mktemp("hits") / "hits.csv", hit_rows(robot, LAM, seed=1))


def test_the_rows_read_back_with_their_sessions_and_flags(arm, tmp_path):
    _, robot = arm
    rows = hit_rows(robot, LAM, hits=3)
    rows[1]["flag"] = "too few samples around the contact"
    rows = read_hit_rows(write_rows(tmp_path / "h.csv", rows), robot.nv)
    assert rows.n_flagged == 1 and rows.hit.size == 5
    assert sorted(set(rows.session)) == ["config_1", "config_2"]
    assert np.allclose(np.linalg.norm(rows.directions, axis=1), 1.0)
    # the rows' m* is eq 11's at the known lambda (2 % scatter)
    m = effective_mass_batch(robot, rows.Q, (0.0, 1.0, 0.0), LAM)
    assert np.all(np.abs(rows.m_eff / m - 1) < 0.1)


def test_one_pose_determines_one_combination_and_two_poses_two(arm):
    """Without pose scatter, each session's rows are one row of S repeated: rank 1; the two
    sessions together determine two of the seven combinations, never all."""
    _, robot = arm
    n = np.tile([0.0, 1.0, 0.0], (2, 1))
    Q = np.radians([POSES_DEG["config_1"], POSES_DEG["config_2"]])
    S, m = log_sensitivity(robot, Q, n)
    assert np.allclose(m, effective_mass_batch(robot, Q, (0.0, 1.0, 0.0)))
    one = identifiability(np.repeat(S[:1], 5, axis=0), rtol=1e-6)
    two = identifiability(S, rtol=1e-6, sigma=0.02)
    assert one["rank"] == 1 and two["rank"] == 2
    V = np.asarray(two["combinations"])
    assert np.allclose(V @ V.T, np.eye(7), atol=1e-10)            # an orthonormal basis of lambda
    # S's rows lie in the span of the determined combinations, and nothing along the others
    assert np.allclose(S @ V[2:].T, 0.0, atol=1e-10)
    se = two["standard_errors"]
    assert se[0] < se[1] and se[2] is None                        # a zero singular value: no error bar


def test_the_sensitivity_is_the_derivative_of_ln_m(arm):
    _, robot = arm
    q = np.radians([POSES_DEG["config_1"]])
    n = np.array([[0.0, 1.0, 0.0]])
    S, _ = log_sensitivity(robot, q, n, LAM)
    for j in (2, 4, 6):
        step = np.zeros(7)
        step[j] = 1e-6
        up = np.log(effective_mass_batch(robot, q, n[0], LAM + step))
        down = np.log(effective_mass_batch(robot, q, n[0], LAM - step))
        assert S[0, j] == pytest.approx(float((up - down)[0] / 2e-6), rel=1e-5)


def test_enough_poses_recover_the_known_lambda(arm, tmp_path):
    """Twelve poses spread over the workspace, exact m*: every combination is determined and
    the fit along them returns the known lambda."""
    _, robot = arm
    rng = np.random.default_rng(7)
    base = np.array(POSES_DEG["config_1"])
    poses = {f"p{k}": tuple(base + rng.uniform(-25, 25, 7)) for k in range(12)}
    rows = hit_rows(robot, LAM, poses_deg=poses, hits=1, jitter_deg=0.0, noise=0.0)
    rows = read_hit_rows(write_rows(tmp_path / "rows.csv", rows), robot.nv)
    lam, rms, rank = subspace_fit(robot, rows, rtol=1e-4)
    assert rank == 7
    assert rms < 1e-8
    assert np.allclose(lam, LAM, rtol=1e-4, atol=1e-7)


def test_one_session_does_not_determine_the_other_and_the_range_says_so(arm, hits_csv):
    _, robot = arm
    rows = read_hit_rows(hits_csv, robot.nv)
    rep = transfer(robot, rows, fit="config_1", predict="config_2")
    s1, s2 = rep["sessions"]["config_1"], rep["sessions"]["config_2"]
    assert s1["ratio_to_rigid"] > 1.05 and s2["ratio_to_rigid"] > 1.05   # the known lambda makes the arm heavier
    assert rep["both"]["rank"] < 7                                      # two sessions cannot pin seven lambdas
    assert rep["both"]["rank"] >= max(s1["identifiability"]["rank"], s2["identifiability"]["rank"])
    # the fit reproduces its own session within the hits' scatter
    assert rep["fit_lambda"]["rms_log_residual"] < 0.03
    lo, hi = rep["prediction_range"]["least"][0], rep["prediction_range"]["greatest"][0]
    truth = float(np.exp(np.mean(np.log(effective_mass_batch(robot, rows.select("config_2").Q, (0, 1, 0), LAM)))))
    assert lo <= truth <= hi
    assert hi / lo > 1.5                                                # not determined by config_1's m*
    assert lo <= rep["fit_lambda"]["predicted"] <= hi


def test_a_bounded_lambda_narrows_the_range_and_still_holds_the_truth(arm, hits_csv):
    _, robot = arm
    rows = read_hit_rows(hits_csv, robot.nv)
    A, B = rows.select("config_1"), rows.select("config_2")
    wide = prediction_range(robot, A, B)
    narrow = prediction_range(robot, A, B, lambda_max=0.5)
    assert narrow["greatest"][0] < wide["greatest"][0]
    assert narrow["least"][0] >= wide["least"][0] - 1e-9
    assert max(narrow["greatest"][1]) <= 0.5 + 1e-12
    truth = float(np.exp(np.mean(np.log(effective_mass_batch(robot, B.Q, (0, 1, 0), LAM)))))
    # the truth's lambda (<= 0.3) is one of the bounded ones, up to the fit session's scatter
    assert narrow["least"][0] * 0.97 <= truth <= narrow["greatest"][0] * 1.03


def test_a_session_lighter_than_the_rigid_arm_has_no_consistent_lambda(arm, tmp_path):
    _, robot = arm
    rows = hit_rows(robot, LAM, hits=3)
    for r in rows:
        if r["session"] == "config_1":
            r["m_eff"], r["m_eff_lo"], r["m_eff_hi"] = 1.0, 0.9, 1.1
    rows = read_hit_rows(write_rows(tmp_path / "h.csv", rows), robot.nv)
    rng = prediction_range(robot, rows.select("config_1"), rows.select("config_2"))
    assert rng == {"least": None, "greatest": None}


@pytest.mark.parametrize("edit, names", [
    (lambda r: r.pop("m_eff_logged"), "missing column(s) m_eff_logged"),
    (lambda r: r.update(q_3="abc"), "column q_3 = 'abc' is not a number"),
    (lambda r: r.update(n_x=0.0, n_y=0.0, n_z=0.0), "is the zero vector"),
    (lambda r: r.update(m_eff=-1.0), "m_eff = -1 kg must be > 0"),
    (lambda r: r.update(m_eff_lo=9e9, m_eff_hi=1e10), "does not hold m_eff"),
])
def test_bad_rows_are_named(arm, tmp_path, edit, names):
    _, robot = arm
    rows = hit_rows(robot, LAM, hits=2)
    for r in rows:
        edit(r)
    path = tmp_path / "bad.csv"
    if "m_eff_logged" in names:
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    else:
        write_rows(path, rows)
    with pytest.raises(InputError, match=names.replace("(", r"\(").replace(")", r"\)")):
        read_hit_rows(path, robot.nv)


def test_sessions_are_checked(arm, hits_csv):
    _, robot = arm
    rows = read_hit_rows(hits_csv, robot.nv)
    with pytest.raises(InputError, match="session 'config_9' has no usable hit; sessions: .'config_1', 'config_2'."):
        transfer(robot, rows, fit="config_9", predict="config_2")
    with pytest.raises(InputError, match="both 'config_1'"):
        transfer(robot, rows, fit="config_1", predict="config_1")


def test_recorded_lambda_cli_reports_and_writes_json(arm, hits_csv, capsys):
    folder, _ = arm
    assert main(["recorded-lambda", str(hits_csv), "--robot", str(folder), "--fit", "config_1",
                 "--predict", "config_2"]) == 0
    out = capsys.readouterr().out
    assert "robot seven_axis: 7 joints; 24 hits used, 0 flagged" in out
    assert "of 7 combinations determined" in out and "not determined" in out
    assert "predicts config_2 between" in out
    assert main(["recorded-lambda", str(hits_csv), "--robot", str(folder), "--fit", "config_2",
                 "--predict", "config_1", "--json", "--lambda-max", "1"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["fit"] == "config_2" and rep["lambda_max"] == 1.0
    assert max(rep["prediction_range"]["greatest"][1]) <= 1.0 + 1e-12
