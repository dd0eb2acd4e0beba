"""The response model's domain: recorded by the fit, stored and checked in the model file,
refused outside or extrapolated with a wider interval; m* without a value named; the
model file's content digest."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from campaign.core.errors import InputError
from campaign.core.vocabulary import bases, gain_sets
from campaign.joints.domain import WIDENING, Domain, Excursion, OutsideDomain, m_eff_state, widen_interval, widening
from campaign.joints.estimator import Eq11Model
from campaign.joints.impacts import Impacts
from campaign.joints.modelcheck import check_digest, content_digest
from campaign.joints.modelfile import load_model, save_model, shipped_model_path
from campaign.joints.setting import Setting
from campaign.model.paper import configuration_q, paper_q


@pytest.fixture(scope="module")
def setting():
    return Setting.from_rig()


@pytest.fixture(scope="module")
def impacts():
    Q = np.array([paper_q(np.array(q, float)) for q in [(0, 150, 90), (30, 200, 60), (-45, 180, 0)]])
    return Impacts(q=np.repeat(Q, 2, axis=0), direction=[(-1, 0, 0), (0, -1, 0)] * 3, speed=[1.2, 2.8] * 3,
                   gain=["low", "high"] * 3, m_eff=[10.0, 12.0, 20.0, 25.0, 30.0, 40.0], restitution=0.55,
                   keys=[f"t{i}.nc" for i in range(6)])


def test_the_fit_records_the_domain_of_its_trials(setting, impacts, tmp_path):
    model = Eq11Model(setting).fit(impacts)
    d = model.domain_
    assert d.speed == (1.2, 2.8) and d.gain_sets == ("high", "low") and d.base_names == ("fixed",)
    assert d.mass == (setting.hammer_mass, setting.hammer_mass) and d.max_abs_nz == 0.0
    assert d.m_eff == (10.0, 40.0) and d.structures == ()
    again = load_model(save_model(model, tmp_path / "m.json"), setting=setting)
    assert again.domain_ == d


def test_outside_the_domain_is_refused_naming_the_bound_and_the_value(setting, impacts):
    d = Eq11Model(setting).fit(impacts).domain_
    assert d.check(speed=2.0, gain="low", mass=setting.hammer_mass, direction=[-1, 0, 0], base="fixed") == []
    cases = [(dict(speed=0.5), "speed 0.5 m/s is below the model's domain (fitted on 1.2-2.8 m/s)"),
             (dict(speed=5.0), "speed 5 m/s is above"),
             (dict(mass=2.0), "object mass 2 kg is above the model's domain"),
             (dict(direction=[-0.8, 0, -0.6]), "(n_z = -0.6) is outside the model's domain"),
             (dict(m_eff=80.0), "m* 80 kg is above the model's domain (fitted on 10-40 kg)"),
             (dict(gain="zero"), "gain set 'zero' is outside the model's domain (fitted on high, low)"),
             (dict(base="flexible"), "the flexible base is outside the model's domain")]
    for what, words in cases:
        with pytest.raises(OutsideDomain) as err:
            d.check(hint=" (hint)", **what)
        assert words in str(err.value) and "\n" not in str(err.value), str(err.value)
        assert isinstance(err.value, InputError)


def test_extrapolating_returns_the_distances_and_widens_the_interval(setting, impacts):
    d = Eq11Model(setting).fit(impacts).domain_
    out = d.check(speed=5.6, mass=setting.hammer_mass / 2, direction=[-0.8, 0, -0.6], extrapolate=True)
    got = {x.quantity: x.distance for x in out}
    assert got["speed_above"] == pytest.approx(math.log(2.0))
    assert got["mass_below"] == pytest.approx(math.log(2.0))
    assert got["direction"] == pytest.approx(math.asin(0.6))
    w = widening(out)
    assert w == pytest.approx(math.hypot(WIDENING["speed_above"] * math.log(2), WIDENING["mass_below"] * math.log(2),
                                         WIDENING["direction"] * math.asin(0.6)))
    k = 2.5                                  # a t quantile, not the normal's 1.96
    lo, hi = widen_interval(20.0, 19.0, 20.0 ** 2 / 19.0, w, quantile=k)
    assert lo < 19.0 and hi > 20.0 ** 2 / 19.0 and lo * hi == pytest.approx(400.0)
    # the interval's own sd is read with the quantile it was built with, the extra added in quadrature
    assert math.log(hi / 20.0) == pytest.approx(k * math.hypot(math.log(20.0 / 19.0) / k, w))
    assert widen_interval(20.0, 19.0, 20.0 ** 2 / 19.0, 0.0, quantile=k) == pytest.approx((19.0, 20.0 ** 2 / 19.0))
    with pytest.raises(InputError, match="quantile"):
        widen_interval(20.0, 19.0, 21.0, w, quantile=0.0)
    # a gain set the model never saw has no distance: refused even when extrapolating
    with pytest.raises(OutsideDomain, match="no extrapolation is defined"):
        d.check(gain="zero", extrapolate=True)


def test_the_domain_in_a_model_file_is_checked(setting):
    good = Domain(speed=(1.5, 2.5), gain_sets=("low",), mass=(0.7, 0.7), max_abs_nz=0.0, m_eff=(8.0, 120.0),
                  base_names=("fixed", "flexible"), structures=("stiff_mast",))
    doc = good.to_json()
    assert Domain.from_json(json.loads(json.dumps(doc)), where="f", gain_sets=gain_sets(), bases=bases()) == good
    for key, value, words in (("speed_m_s", [0.0, 1.0], "0 < low <= high"), ("m_eff_kg", [1.0, math.inf], "finite"),
                              ("max_abs_direction_z", 2.0, "must be in [0, 1]"), ("bases", ["orbit"], "'orbit'"),
                              ("gain_sets", [], "list of names")):
        with pytest.raises(InputError, match=words.replace("[", r"\[")):
            Domain.from_json({**doc, key: value}, where="f", gain_sets=gain_sets(), bases=bases())


def test_the_shipped_model_holds_where_its_trials_were(setting):
    doc = json.loads(shipped_model_path().read_text(encoding="utf-8"))
    d = load_model(shipped_model_path(), setting=setting).domain_
    assert set(d.structures) == set(doc["fit"]["structure_scatter"]) and set(d.base_names) == set(bases())
    assert set(d.gain_sets) == set(gain_sets()) and d.max_abs_nz == 0.0
    speeds = {float(k.split("/v")[1].split("/")[0]) for k in doc["fit"]["residuals"]}
    assert d.speed == (min(speeds), max(speeds))
    assert d.mass[0] == pytest.approx(setting.hammer_mass, rel=1e-3)


def test_a_recoiling_tip_has_no_m_eff_and_no_warning(setting):
    model = load_model(shipped_model_path(), setting=setting)
    imp = Impacts(q=configuration_q(1)[None], direction=[(-1, 0, 0)], speed=2.0, gain="high", mass=1.5,
                  pendulum=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = model.respond(imp)
        m, lo, hi = model.predict_interval(imp)
    assert r.tip_velocity[0, 0] < 0 and m_eff_state(r.m_eff, r.tip_velocity)[0, 0] == "recoil"
    assert np.isinf(m[0]) and np.isinf(lo[0]) and np.isinf(hi[0])
    assert list(m_eff_state([30.0, np.inf, np.inf], [0.1, 0.0, -0.2])) == ["finite", "unbounded", "recoil"]


def test_the_digest_names_what_was_edited():
    doc = {"kind": "k", "parameters": {"a": 1.0, "b": [1, 2]}, "fit": {"n": 3}}
    doc["digest"] = content_digest(doc)
    check_digest(doc, "f")
    edited = json.loads(json.dumps(doc))
    edited["parameters"]["b"][1] = 3
    with pytest.raises(InputError, match=r"f: edited after its fit: parameters.b differs"):
        check_digest(edited, "f")
    edited["kind"] = "other"
    with pytest.raises(InputError, match=r"kind, parameters.b differ"):
        check_digest(edited, "f")
    with pytest.raises(InputError, match="no content digest"):
        check_digest({k: v for k, v in doc.items() if k != "digest"} | {"digest": {}}, "f")
    assert Excursion("speed_above", "x", 0.1).quantity in WIDENING
