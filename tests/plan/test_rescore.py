"""The planner with a response model on the flexible base: ranked ideally coupled, its best
candidates predicted again through the rig's VES-II loop, and ranked on what they carry."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.cli import plan as cli_plan
from campaign.core.errors import InputError
from campaign.model.robot.ik import impact_point
from campaign.plan import RESCORE, build_planner, horizontal_directions, planner_model, predict_model

POINT_Q = np.radians([30.0, 60.0, -60.0])        # a point with four branches


@pytest.fixture(scope="module")
def model():
    return planner_model()[0]


def _planner(model, rescore, structure="stiff_mast"):
    planner = build_planner(base="flexible", model=model, speed=2.0, structure=structure)
    planner.rescore = rescore
    return planner.fit(impact_point(model.setting.robot, POINT_Q), horizontal_directions(2))


def test_the_best_candidates_carry_the_loop_and_the_rest_the_ideal_coupling(model):
    ideal, mixed = _planner(model, 0), _planner(model, 5)
    assert RESCORE > 0 and mixed.rescored_.sum() == 5 and not ideal.rescored_.any()
    P, I = mixed.predictions_, ideal.predictions_
    # the rescored are the five best of the ideal ranking
    best = {tuple(r) for r in ideal.ranking_[:5]}
    assert {tuple(x) for x in np.argwhere(mixed.rescored_)} == best
    rest = ~mixed.rescored_
    assert np.array_equal(P.m_eff[rest], I.m_eff[rest]) and np.array_equal(P.structure_peak[rest], I.structure_peak[rest])
    # each rescored candidate is what the loop predicts for it
    loop = predict_model(model.setting.robot, mixed.q_, model, mixed.gain_classes_, mixed.directions_,
                         mass=mixed.mass, speed=mixed.speed, restitution=mixed.restitution,
                         contact=model.setting.contact, flexible=True, structure="stiff_mast", coupling="loop")
    at = mixed.rescored_
    assert np.allclose(P.m_eff[at], loop.m_eff[at], rtol=2e-3)
    assert np.allclose(P.structure_peak[at], loop.structure_peak[at], rtol=2e-3)
    assert not np.allclose(P.m_eff[at], I.m_eff[at], rtol=1e-3)        # the loop moves them
    # ranked on what each carries; rows say which coupling
    rows = mixed.rows()
    assert [r["score"] for r in rows] == sorted(r["score"] for r in rows)
    assert sum(r["coupling"] == "loop" for r in rows) == 5
    assert all(r["coupling"] == "ideal" for r in ideal.rows())


def test_the_fixed_base_has_nothing_to_rescore_and_a_bad_count_is_refused(model):
    fixed = build_planner(base="fixed", model=model, speed=2.0)
    fixed.fit(impact_point(model.setting.robot, POINT_Q), horizontal_directions(2))
    assert not fixed.rescored_.any() and "coupling" not in fixed.rows()[0]
    for bad in (-1, 2.5, True):
        planner = build_planner(base="flexible", model=model, speed=2.0)
        planner.rescore = bad
        with pytest.raises(InputError, match="rescore"):
            planner.fit(impact_point(model.setting.robot, POINT_Q), horizontal_directions(2))


def test_the_cli_help_names_the_rescored_count():
    assert f"the best {RESCORE} are predicted again through the VES-II loop" in " ".join(cli_plan.EPILOG.split())
