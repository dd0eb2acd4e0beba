"""The scatter model the response model's intervals carry: its fit recovers a known scatter
and tail, its intervals cover what they say on draws from it (slow blows and light m* too), it
widens where the tip's velocity change and the speed shrink, and a model file's scatter model
is read back or refused."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from campaign.core.errors import InputError
from campaign.joints.impacts import Impacts
from campaign.joints.modelfile import ModelFileError, load_model, shipped_model_path
from campaign.joints.scatter import ScatterModel, fit_scatter, tip_velocity_change
from campaign.joints.setting import Setting
from campaign.model.paper import configuration_q

TRUE = ScatterModel(floor={"zero": 0.004, "high": 0.008}, velocity_noise={"zero": 0.0005, "high": 0.001},
                    speed_noise={"zero": 0.002, "high": 0.006}, small_mass=0.003, structure={"stiff_mast": 0.002},
                    flexible_floor={"zero": 0.0, "high": 0.01}, dof=6.0)


def _draw(model: ScatterModel, n: int, seed: int):
    """Residuals drawn from ``model`` at random gain sets, bases, speeds (0.5-3 m/s) and m*
    (3-300 kg, a 0.5 kg hammer)."""
    rng = np.random.default_rng(seed)
    gains = list(rng.choice(["zero", "high"], size=n))
    structures = list(rng.choice(np.array([None, "stiff_mast"], dtype=object), size=n))
    speed = rng.uniform(0.5, 3.0, size=n)
    m = np.exp(rng.uniform(np.log(3.0), np.log(300.0), size=n))
    dv = tip_velocity_change(m, speed, 0.5, 0.55)
    sd = np.array([model.sd([g], [d], [v], [mm], structure=s)[0]
                   for g, d, v, mm, s in zip(gains, dv, speed, m, structures, strict=True)])
    r = sd * model.scale * rng.standard_t(model.dof, size=n)
    return {"residuals": r, "gains": gains, "dv": dv, "speed": speed, "m_eff": m, "structures": structures}, sd


def test_the_fit_recovers_a_known_scatter_and_its_intervals_cover_what_they_say():
    draw, _ = _draw(TRUE, 3000, 1)
    fitted = fit_scatter(**draw, dof=(6.0, 6.0))
    assert fitted.dof == 6.0 and fitted.n_residuals == 3000
    for g in ("zero", "high"):
        assert math.isclose(fitted.floor[g], TRUE.floor[g], rel_tol=0.3), g
        assert math.isclose(fitted.velocity_noise[g], TRUE.velocity_noise[g], rel_tol=0.3), g
    assert math.isclose(fitted.small_mass, 0.003, rel_tol=0.3)
    # at one m* the tip's velocity change goes with the speed: the two velocity terms share
    # the slow blows' scatter, whose sum is what holds
    for g in ("zero", "high"):
        slow = [fitted.sd([g], [d], [0.5], [20.0])[0] for d in tip_velocity_change([20.0], 0.5, 0.5, 0.55)]
        true = [TRUE.sd([g], [d], [0.5], [20.0])[0] for d in tip_velocity_change([20.0], 0.5, 0.5, 0.55)]
        assert math.isclose(slow[0], true[0], rel_tol=0.2), g
    assert math.isclose(fitted.flexible_floor["high"], 0.01, rel_tol=0.3) and fitted.flexible_floor["zero"] < 0.004
    # on fresh draws from the same model, each level covers its share, slow blows and light m* too
    draw, _ = _draw(TRUE, 4000, 2)
    sd = np.array([fitted.sd([g], [d], [v], [m], structure=s)[0] for g, d, v, m, s in
                   zip(draw["gains"], draw["dv"], draw["speed"], draw["m_eff"], draw["structures"], strict=True)])
    covered = {level: np.abs(draw["residuals"]) <= fitted.quantile(level) * sd for level in (0.90, 0.95)}
    for level, hit in covered.items():
        assert abs(np.mean(hit) - level) < 0.015, (level, np.mean(hit))
        for part in (draw["speed"] < 1.0, draw["m_eff"] < 10.0):
            assert abs(np.mean(hit[part]) - level) < 0.04, (level, np.mean(hit[part]))


def test_the_fit_chooses_the_tails_from_both_levels():
    chosen = {}
    for dof in (3.0, 200.0):                      # one gain set on the fixed base: a quick fit
        draw, _ = _draw(dataclasses.replace(TRUE, dof=dof), 2000, 4)
        keep = [g == "zero" and s is None for g, s in zip(draw["gains"], draw["structures"], strict=True)]
        draw = {k: [x for x, k_ in zip(v, keep, strict=True) if k_] for k, v in draw.items()}
        chosen[dof] = fit_scatter(**draw, dof=(3.0, 200.0)).dof
    assert chosen[3.0] <= 6.0 and chosen[200.0] >= 20.0, chosen


def test_the_scatter_grows_as_the_tip_moves_less_the_blow_slows_and_on_the_structure():
    sd = TRUE.sd(["high"] * 3, [0.3, 0.03, 0.003], [2.0] * 3, [20.0] * 3)
    assert np.all(np.diff(sd) > 0)
    assert math.isclose(sd[-1], math.sqrt(0.008 ** 2 + (0.001 / 0.003) ** 2 + (0.006 / 2.0) ** 2 + (0.003 / 2) ** 2))
    slow, fast = TRUE.sd(["zero"] * 2, [0.1] * 2, [0.5, 3.0], [20.0] * 2)
    assert slow > fast and math.isclose(slow ** 2 - fast ** 2, 0.002 ** 2 * (1 / 0.25 - 1 / 9.0))
    light, heavy = TRUE.sd(["zero"] * 2, [0.1] * 2, [2.0] * 2, [5.0, 50.0])
    assert math.isclose(light ** 2 - heavy ** 2, 0.003 ** 2 * (4.0 - 0.04))
    assert TRUE.sd(["zero"], [0.1], [2.0], [20.0], structure="stiff_mast")[0] > TRUE.sd(["zero"], [0.1], [2.0], [20.0])[0]
    assert math.isclose(TRUE.sd(["high"], [0.1], [2.0], [20.0], structure="stiff_mast")[0],
                        math.sqrt(0.008 ** 2 + 0.01 ** 2 + (0.001 ** 2 + 0.002 ** 2) / 0.01 + (0.006 / 2.0) ** 2
                                  + (0.003 / 2) ** 2))
    assert TRUE.sd(["zero"], [0.0], [2.0], [math.inf])[0] == math.inf      # m* unbounded: the tip does not move
    # a heavy-tailed t spans more than the normal's 1.96 sd at 95 % (unit variance)
    assert TRUE.quantile(0.95) > 1.96 > TRUE.quantile(0.90)
    assert math.isclose(dataclasses.replace(TRUE, dof=200.0).quantile(0.95), 1.96, rel_tol=0.01)


def test_tip_velocity_change_is_what_eq10_divides_by():
    dv = tip_velocity_change([20.0, math.inf], 2.0, 0.5, 0.55)
    assert math.isclose(dv[0], 1.55 * 2.0 * (20.0 * 0.5 / 20.5) / 20.0) and dv[1] == 0.0


GOOD = {"floor": {"zero": 0.1}, "velocity_noise": {"zero": 0.0}, "speed_noise": {"zero": 0.0}, "small_mass": 0.0,
        "structure": {}, "flexible_floor": {"zero": 0.0}, "dof": 5.0, "n_residuals": 3}


@pytest.mark.parametrize("change, words", [
    ({"floor": {"zero": -0.1}}, "floor of 'zero' must be a finite number >= 0"),
    ({"velocity_noise": {"low": 0.0}}, "name other gain sets"),
    ({"speed_noise": {"zero": 0.0, "high": 0.0}}, "floor and speed_noise name other gain sets"),
    ({"speed_noise": {"zero": math.inf}}, "speed_noise of 'zero' must be a finite number >= 0"),
    ({"small_mass": -0.01}, "small_mass must be a finite number >= 0"),
    ({"small_mass": True}, "small_mass must be a finite number >= 0"),
    ({"structure": {"x": math.nan}}, "structure of 'x'"),
    ({"dof": 1.0}, "dof must be in"),
    ({"n_residuals": None}, "n_residuals an integer"),
])
def test_a_bad_scatter_model_is_refused_with_one_line(change, words):
    with pytest.raises(InputError) as err:
        ScatterModel.from_dict({**GOOD, **change})
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("key", ["speed_noise", "small_mass", "n_residuals"])
def test_a_scatter_model_without_a_term_is_refused(key):
    with pytest.raises(InputError, match=f"no key '{key}'"):
        ScatterModel.from_dict({k: v for k, v in GOOD.items() if k != key})
    assert ScatterModel.from_dict(GOOD).to_dict() == {**GOOD, "dof": 5.0}


def test_unknown_gain_sets_and_structures_are_named():
    with pytest.raises(InputError, match="no gain set 'low'"):
        TRUE.sd(["low"], [0.1], [2.0], [20.0])
    with pytest.raises(InputError, match="no structure 'space_class'"):
        TRUE.sd(["zero"], [0.1], [2.0], [20.0], structure="space_class")


def test_the_shipped_model_carries_its_scatter_model_and_a_bad_one_is_refused(tmp_path):
    setting = Setting.from_rig()
    doc = json.loads(shipped_model_path().read_text(encoding="utf-8"))
    sm = ScatterModel.from_dict(doc["fit"]["scatter_model"])
    assert set(sm.floor) == {"zero", "low", "high"} and set(sm.structure) == {"space_class", "stiff_mast"}
    model = load_model(shipped_model_path(), setting=setting)
    # the interval widens as the blow gets lighter (the tip's velocity change and the speed shrink)
    imp = Impacts(q=[configuration_q(2)] * 2, direction=[-1, 0, 0], speed=[3.0, 0.5], gain="high")
    m, lo, hi = model.predict_interval(imp)
    assert np.log(hi[1] / m[1]) > np.log(hi[0] / m[0]) > 0
    doc["fit"]["scatter_model"]["floor"]["high"] = -1.0
    path = tmp_path / "model.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="fit.scatter_model: scatter model: floor of 'high'"):
        load_model(path, setting=setting)
