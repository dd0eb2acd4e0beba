"""The widening study: trials outside the shipped model's domain, the rates they need, and
the coverage of intervals widened with them."""

from __future__ import annotations

import math

import pytest

from campaign.joints.domain import WIDENING, widen_interval
from campaign.joints.modelfile import load_model, shipped_model_path
from campaign.studies.widening import Settings, coverage, fit_rates, group, measure


@pytest.fixture(scope="module")
def model():
    return load_model(shipped_model_path())


@pytest.fixture(scope="module")
def rows(model):
    return measure(36001, model=model, settings=Settings.quick())


def test_a_quick_run_strikes_outside_the_domain_and_reads_the_models_interval(model, rows):
    assert 2 <= len(rows) <= 3                       # 0.3 and 4.2 m/s, a 1.2 kg head (one may be refused)
    lo_v, hi_v = model.domain_.speed
    k = model.interval_quantile(0.95)
    for r in rows:
        assert r["seed"] == 36001 and r["quantile"] == k
        assert r["residual"] == pytest.approx(math.log(r["m_model"] / r["m_identified"]))
        if r["kind"] == "speed":
            side, bound = ("speed_below", lo_v) if r["speed"] < lo_v else ("speed_above", hi_v)
            assert r["excursions"][side] == pytest.approx(abs(math.log(r["speed"] / bound)))
        else:                                        # a heavier hammer: the model's free object of its mass
            assert r["kind"] == "hammer" and r["mass"] > model.domain_.mass[1]
            assert r["excursions"]["mass_above"] == pytest.approx(math.log(r["mass"] / model.domain_.mass[1]))
        # the row's own sd is the model's: its interval is m* exp(+-k sd)
        assert r["sd"] > 0 and math.isfinite(r["sd"])
    assert {r["kind"] for r in rows} >= {"speed"}


def test_rates_make_the_widened_intervals_cover_what_they_were_fitted_to(rows):
    rates, counts = fit_rates(rows, level=1.0)
    assert set(rates) == set(WIDENING) and all(v > 0 for v in rates.values())
    assert sum(counts.values()) == sum(len(r["excursions"]) == 1 for r in rows)
    table = coverage(rows, {q: v * (1 + 1e-9) for q, v in rates.items()})
    assert table[-1]["group"] == "all" and table[-1]["trials"] == len(rows)
    assert table[-1]["widened_covered"] == 1.0
    assert table[-1]["widened_covered"] >= table[-1]["own_covered"]


def synthetic(residual, sd, d, quantity="speed_below", k=2.0):
    return dict(seed=0, kind="speed", gain="low", speed=0.3, mass=0.7, m_identified=10.0,
                m_model=10.0 * math.exp(residual), residual=residual, sd=sd, quantile=k, excursions={quantity: d})


def test_the_rate_is_the_level_quantile_of_what_each_trial_needs():
    # needs: 0 (inside its own interval), then sqrt((r/k)^2 - s^2) / d = 0.03, 0.04, 0.05 per unit distance
    k, s, d = 2.0, 0.01, 0.5
    rs = [synthetic(0.01, s, d)] + [synthetic(k * math.hypot(s, need * d), s, d) for need in (0.03, 0.04, 0.05)]
    rates, counts = fit_rates(rs, level=0.75)
    assert counts["speed_below"] == 4 and rates["speed_below"] == pytest.approx(0.04)
    # every quantity no trial reached gets the largest measured rate
    assert rates["direction"] == rates["mass_above"] == pytest.approx(0.04)
    table = {r["group"]: r for r in coverage(rs, {q: v * (1 + 1e-9) for q, v in rates.items()})}
    assert table["speed 0.3 m/s"]["trials"] == 4 and table["speed 0.3 m/s"]["own_covered"] == 0.25
    assert table["speed 0.3 m/s"]["widened_covered"] == 0.75        # all but the trial needing 0.05
    m, lo, hi = 10.0, 10.0 * math.exp(-k * s), 10.0 * math.exp(k * s)
    wlo, whi = widen_interval(m, lo, hi, 0.05 * d, quantile=k)
    assert math.log(whi / m) == pytest.approx(k * math.hypot(s, 0.05 * d))


def test_groups_name_what_lies_outside():
    assert group(synthetic(0.0, 0.01, 0.2)) == "speed 0.3 m/s"
    assert group({**synthetic(0.0, 0.01, 0.2, "mass_above"), "kind": "hammer", "mass": 1.2333}) == "hammer 1.23 kg"
    assert group({**synthetic(0.0, 0.01, 0.2, "m_eff_above"), "kind": "m_eff"}) == "m* above (in-domain speed)"
