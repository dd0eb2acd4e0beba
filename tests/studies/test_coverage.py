"""The response model study's coverage table: groups, shares and Wilson's interval."""

from __future__ import annotations

import math

import pytest

from campaign.studies.coverage import bias_by_speed, coverage_markdown, coverage_table, decade, speed_band, wilson


def _row(base, gain, speed, m, error, c95, c90, structure=None):
    return {"base": base, "structure": structure, "gain": gain, "speed_m_s": speed, "m_identified_kg": m,
            "error": error, "covered": c95, "covered_90": c90, "model_vs_truth": error / 4}


ROWS = [_row("fixed", "high", 0.6, 8.0, -0.02, True, False), _row("fixed", "high", 1.0, 25.0, 0.01, True, True),
        _row("fixed", "zero", 2.5, 150.0, 0.04, False, False),
        _row("flexible", "zero", 2.8, 30.0, -0.01, True, True, structure="stiff_mast")]


def test_bands_and_decades():
    assert [speed_band(v) for v in (0.5, 0.99, 1.0, 2.5, 2.51, 3.0)] == \
        ["below 1.0", "below 1.0", "1.0-2.5", "1.0-2.5", "above 2.5", "above 2.5"]
    assert [decade(m) for m in (8.0, 10.0, 99.9, 150.0)] == ["1-10 kg", "10-100 kg", "10-100 kg", "100-1000 kg"]


def test_wilson_interval_holds_the_share_and_narrows_with_the_count():
    lo, hi = wilson(95, 100)
    assert lo < 0.95 < hi < 1.0 and math.isclose(lo, 0.888, abs_tol=2e-3)
    lo2, hi2 = wilson(950, 1000)
    assert hi2 - lo2 < hi - lo
    assert math.isnan(wilson(0, 0)[0])


def test_each_group_counts_its_trials():
    table = {(r["group"], r["value"]): r for r in coverage_table(ROWS)}
    assert table[("all", "all")]["trials"] == 4
    assert table[("all", "all")]["covered_95"] == 0.75 and table[("all", "all")]["covered_90"] == 0.5
    assert table[("base", "flexible stiff_mast")]["trials"] == 1
    g = table[("gain set", "high")]
    assert g["trials"] == 2 and g["median_error"] == pytest.approx(0.015) and g["worst_error"] == pytest.approx(0.02)
    assert g["bias"] == pytest.approx(-0.005) and g["bias_truth"] == pytest.approx(-0.00125)
    assert table[("speed band", "below 1.0")]["trials"] == 1 and table[("speed band", "above 2.5")]["trials"] == 1
    assert table[("m* decade", "100-1000 kg")]["covered_95"] == 0.0
    bias = {r["value"]: r for r in bias_by_speed(ROWS)}
    assert bias["fixed, 0.5-0.7 m/s"]["bias"] == pytest.approx(-0.02)
    text = coverage_markdown(coverage_table(ROWS), bias_by_speed(ROWS), seeds="Seeds: x")
    assert "| gain set | high | 2 |" in text and "Seeds: x" in text
