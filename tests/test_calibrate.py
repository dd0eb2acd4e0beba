"""Calibration (issue 9): the objective's residuals, the force-band hinge, the set-up file's
checks, the write-back, and what the committed calibration promises (read from its record
in config/rig.yaml; no simulation)."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
import yaml

from campaign.calibrate import (
    CalibrationResult,
    force_band,
    hinge_log,
    load_calibration,
    residual_terms,
    residuals,
    write_back,
)
from campaign.errors import InputError
from campaign.paper import config_dir, load_paper


@pytest.fixture(scope="module")
def cfg():
    return load_calibration()


def _summary(f_min: float, f_max: float) -> dict:
    """A sweep summary that matches the paper exactly except for the force extremes."""
    paper = load_paper()
    t2 = paper["table2"]
    return {"m2": {c: t2["m2"][c] for c in (1, 2, 3)}, "m3": {c: t2["m3"][c] for c in (1, 2, 3)},
            "e_mean": paper["restitution_mean"], "force_min": f_min, "force_max": f_max,
            "force_low": f_min, "force_high": f_max,
            "figure5_deg": paper["figure5_joint3_displacement_deg"], "figure5_speed": 1.75}


def test_hinge_is_zero_inside_the_band_and_a_log_outside():
    assert hinge_log(50.0, low=30.0, high=70.0) == 0.0
    assert hinge_log(30.0, low=30.0, high=70.0) == 0.0 and hinge_log(70.0, low=30.0, high=70.0) == 0.0
    assert hinge_log(29.0, low=30.0) == pytest.approx(math.log(30 / 29))
    assert hinge_log(72.0, high=70.0) == pytest.approx(math.log(72 / 70))
    # continuous at the edges (a kink, no jump), and never negative
    for edge, kw in ((30.0, {"low": 30.0}), (70.0, {"high": 70.0})):
        assert hinge_log(edge * (1 - 1e-9), **kw) < 1e-8 and hinge_log(edge * (1 + 1e-9), **kw) < 1e-8
    assert all(hinge_log(x, low=30.0, high=70.0) >= 0 for x in np.linspace(1, 200, 500))


def test_force_band_is_the_papers_range_narrowed_by_the_stated_margin(cfg):
    margin = cfg["observations"]["force_band"]["margin"]
    assert 0 < margin <= 0.05
    lo, hi = force_band(cfg["observations"])
    assert (lo, hi) == pytest.approx((30.0 * (1 + margin), 70.0 * (1 - margin)))
    assert 30.0 < lo < hi < 70.0


def test_force_band_residuals_vanish_inside_the_band_and_are_named(cfg):
    obs = cfg["observations"]
    lo, hi = force_band(obs)
    terms = residual_terms(_summary(lo + 0.1, hi - 0.1), obs)
    assert list(terms) == ["table2_m2[1]", "table2_m3[1]", "table2_m2[2]", "table2_m3[2]", "table2_m2[3]",
                           "table2_m3[3]", "restitution", "force_band_low", "force_band_high", "figure5"]
    assert all(v == pytest.approx(0.0, abs=1e-12) for v in terms.values())
    # inside 30-70 N but outside the margin: the hinge already pulls
    w = math.sqrt(obs["force_band"]["weight"])
    terms = residual_terms(_summary(30.2, 69.5), obs)
    assert terms["force_band_low"] == pytest.approx(w * math.log(lo / 30.2)) and terms["force_band_low"] > 0
    assert terms["force_band_high"] == pytest.approx(w * math.log(69.5 / hi)) and terms["force_band_high"] > 0
    # one side out only
    terms = residual_terms(_summary(25.0, hi - 1.0), obs)
    assert terms["force_band_low"] > 0 and terms["force_band_high"] == 0.0
    # the vector is the terms in order
    s = _summary(25.0, 80.0)
    assert residuals(s, obs) == pytest.approx(np.array(list(residual_terms(s, obs).values())))


def test_calibration_file_needs_the_force_band_and_a_sane_margin(tmp_path):
    with open(config_dir() / "calibration.yaml") as fh:
        base = yaml.safe_load(fh)
    for mutate, match in ((lambda c: c["observations"].pop("force_band"), "missing force_band"),
                          (lambda c: c["observations"].__setitem__("force_low", {"weight": 1.0}), "unknown force_low"),
                          (lambda c: c["observations"]["force_band"].__setitem__("margin", 0.4), "margin")):
        c = yaml.safe_load(yaml.safe_dump(base))
        mutate(c)
        path = tmp_path / "calibration.yaml"
        path.write_text(yaml.safe_dump(c))
        with pytest.raises(InputError, match=match):
            load_calibration(path)


def test_write_back_records_the_named_residuals(tmp_path, cfg):
    rig = tmp_path / "rig.yaml"
    shutil.copy(config_dir() / "rig.yaml", rig)
    s = _summary(31.0, 68.0)
    terms = residual_terms(s, cfg["observations"])
    params = {"contact.stiffness": 600.0, "contact.exponent": 0.75}
    res = CalibrationResult(params_=params, objective_=0.0, residuals_=np.array(list(terms.values())),
                            residual_names_=list(terms), summary_=s,
                            sensitivity_={k: [0.0] * len(terms) for k in params}, n_evaluations_=1,
                            start_=params, success_=True, message_="test")
    write_back(res, rig)
    tree = yaml.safe_load(rig.read_text())
    assert tree["contact"]["stiffness"]["value"] == 600.0 and tree["contact"]["exponent"]["value"] == 0.75
    rec = tree["calibration"]
    assert set(rec["residuals"]) == set(terms) and rec["residuals"]["force_band_low"] == 0.0
    assert "note" in tree["contact"]["stiffness"]      # comments and notes kept


def test_the_committed_calibration_meets_the_issues_targets():
    # read from the record `campaign calibrate` wrote into config/rig.yaml (no simulation)
    paper = load_paper()
    with open(config_dir() / "rig.yaml") as fh:
        tree = yaml.safe_load(fh)
    rec = tree["calibration"]
    s = rec["summary"]
    for name in ("m2", "m3"):
        for c in (1, 2, 3):
            assert abs(s[name][str(c)] / paper["table2"][name][c] - 1) < 0.10, (name, c)
    assert abs(s["e_mean"] - paper["restitution_mean"]) < 0.03
    lo, hi = paper["impact_force_range_N"]
    assert lo <= s["force_min"] and s["force_max"] <= hi, (s["force_min"], s["force_max"])
    assert abs(s["figure5_deg"] / paper["figure5_joint3_displacement_deg"] - 1) < 0.10
    # the recorded values are the rig's values
    for key, v in rec["values"].items():
        section, leaf = key.split(".", 1)
        assert tree[section][leaf]["value"] == pytest.approx(v, rel=1e-9)
