"""The scatter model the response model's intervals carry: its fit recovers a known scatter
and tail, its intervals cover what they say on draws from it, it widens where the tip's
velocity change shrinks, and a model file's scatter model is read back or refused."""

from __future__ import annotations

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
                    structure={"stiff_mast": 0.002}, flexible_floor={"zero": 0.0, "high": 0.01}, dof=6.0)


def _draw(model: ScatterModel, n: int, seed: int):
    rng = np.random.default_rng(seed)
    gains = list(rng.choice(["zero", "high"], size=n))
    structures = list(rng.choice(np.array([None, "stiff_mast"], dtype=object), size=n))
    dv = np.exp(rng.uniform(np.log(0.01), np.log(0.4), size=n))
    sd = np.array([model.sd([g], [v], structure=s)[0] for g, v, s in zip(gains, dv, structures, strict=True)])
    r = sd * model.scale * rng.standard_t(model.dof, size=n)
    return r, gains, dv, structures, sd


def test_the_fit_recovers_a_known_scatter_and_its_intervals_cover_what_they_say():
    held = fit_scatter(*_draw(TRUE, 300, 3)[:3], structures=_draw(TRUE, 300, 3)[3], dof=(4.0, 4.0))
    assert held.dof == 4.0
    r, gains, dv, structures, _ = _draw(TRUE, 4000, 1)
    fitted = fit_scatter(r, gains, dv, structures=structures)
    for g in ("zero", "high"):
        assert math.isclose(fitted.floor[g], TRUE.floor[g], rel_tol=0.15)
        assert math.isclose(fitted.velocity_noise[g], TRUE.velocity_noise[g], rel_tol=0.15)
    assert math.isclose(fitted.structure["stiff_mast"], 0.002, rel_tol=0.3)
    assert math.isclose(fitted.flexible_floor["high"], 0.01, rel_tol=0.3) and fitted.flexible_floor["zero"] < 0.003
    assert 4.0 < fitted.dof < 10.0
    assert fitted.n_residuals == 4000
    # on fresh draws from the same model, each level covers its share
    r, gains, dv, structures, _ = _draw(TRUE, 4000, 2)
    sd = np.array([fitted.sd([g], [v], structure=s)[0] for g, v, s in zip(gains, dv, structures, strict=True)])
    for level in (0.90, 0.95):
        covered = np.mean(np.abs(r) <= fitted.quantile(level) * sd)
        assert abs(covered - level) < 0.015, (level, covered)


def test_the_scatter_grows_as_the_tip_moves_less_and_on_the_structure():
    sd = TRUE.sd(["high"] * 3, [0.3, 0.03, 0.003])
    assert np.all(np.diff(sd) > 0) and math.isclose(sd[-1], math.hypot(0.008, 0.001 / 0.003))
    assert TRUE.sd(["zero"], [0.1], structure="stiff_mast")[0] > TRUE.sd(["zero"], [0.1])[0]
    assert math.isclose(TRUE.sd(["high"], [0.1], structure="stiff_mast")[0],
                        math.sqrt(0.008 ** 2 + 0.01 ** 2 + (0.001 ** 2 + 0.002 ** 2) / 0.01))
    assert TRUE.sd(["zero"], [0.0])[0] == math.inf            # m* unbounded: the tip does not move
    # a heavy-tailed t spans more than the normal's 1.96 sd at 95 % (unit variance)
    assert TRUE.quantile(0.95) > 1.96 > TRUE.quantile(0.90)
    assert math.isclose(ScatterModel({"zero": 0.01}, {"zero": 0.0}, {}, {"zero": 0.0}, dof=200.0).quantile(0.95), 1.96,
                        rel_tol=0.01)


def test_tip_velocity_change_is_what_eq10_divides_by():
    dv = tip_velocity_change([20.0, math.inf], 2.0, 0.5, 0.55)
    assert math.isclose(dv[0], 1.55 * 2.0 * (20.0 * 0.5 / 20.5) / 20.0) and dv[1] == 0.0


@pytest.mark.parametrize("doc, words", [
    ({"floor": {"zero": -0.1}, "velocity_noise": {"zero": 0.0}, "structure": {}, "flexible_floor": {"zero": 0.0}, "dof": 5.0, "n_residuals": 3},
     "floor of 'zero' must be a finite number >= 0"),
    ({"floor": {"zero": 0.1}, "velocity_noise": {"low": 0.0}, "structure": {}, "flexible_floor": {"zero": 0.0}, "dof": 5.0, "n_residuals": 3},
     "name other gain sets"),
    ({"floor": {"zero": 0.1}, "velocity_noise": {"zero": 0.0}, "structure": {"x": math.nan}, "flexible_floor": {"zero": 0.0}, "dof": 5.0,
      "n_residuals": 3}, "structure of 'x'"),
    ({"floor": {"zero": 0.1}, "velocity_noise": {"zero": 0.0}, "structure": {}, "flexible_floor": {"zero": 0.0}, "dof": 1.0, "n_residuals": 3},
     "dof must be in"),
    ({"floor": {"zero": 0.1}, "velocity_noise": {"zero": 0.0}, "structure": {}, "flexible_floor": {"zero": 0.0}, "dof": 5.0}, "no key 'n_residuals'"),
])
def test_a_bad_scatter_model_is_refused_with_one_line(doc, words):
    with pytest.raises(InputError) as err:
        ScatterModel.from_dict(doc)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_unknown_gain_sets_and_structures_are_named():
    with pytest.raises(InputError, match="no gain set 'low'"):
        TRUE.sd(["low"], [0.1])
    with pytest.raises(InputError, match="no structure 'space_class'"):
        TRUE.sd(["zero"], [0.1], structure="space_class")


def test_the_shipped_model_carries_its_scatter_model_and_a_bad_one_is_refused(tmp_path):
    setting = Setting.from_rig()
    doc = json.loads(shipped_model_path().read_text(encoding="utf-8"))
    sm = ScatterModel.from_dict(doc["fit"]["scatter_model"])
    assert set(sm.floor) == {"zero", "low", "high"} and set(sm.structure) == {"space_class", "stiff_mast"}
    model = load_model(shipped_model_path(), setting=setting)
    # the interval widens as the blow gets lighter (the tip's velocity change shrinks)
    imp = Impacts(q=[configuration_q(2)] * 2, direction=[-1, 0, 0], speed=[3.0, 0.5], gain="high")
    m, lo, hi = model.predict_interval(imp)
    assert np.log(hi[1] / m[1]) > np.log(hi[0] / m[0]) > 0
    doc["fit"]["scatter_model"]["floor"]["high"] = -1.0
    path = tmp_path / "model.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="fit.scatter_model: scatter model: floor of 'high'"):
        load_model(path, setting=setting)
