"""The nonlinear twin of the planner's structure term: its linear limit is the planner's prediction,
and away from it the sign of n matters."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.studies import plan_nonlinear_twin as twin
from campaign.studies import plan_rig_check as prc


def fitted_planner(speed, head_mass=None):
    from campaign.model.paper import load_paper
    from campaign.plan.directions import horizontal_directions
    from campaign.plan.factory import build_planner

    params = None if head_mass is None else {"pendulum.head_mass": head_mass}
    table3 = {k: [float(v) for v in lam] for k, lam in load_paper()["table3"].items()}
    planner = build_planner(base="flexible", lambdas=table3, speed=speed, mass=prc.hammer_mass(params),
                            objective="displacement", structure="space_class", params=params)
    return planner.fit(prc.contact_points()["config 1 wrist centre"], horizontal_directions(2))


def test_twin_tends_to_the_planners_linear_prediction_at_small_amplitude():
    planner = fitted_planner(0.02)
    g = planner.gain_classes_.index("zero")
    for d in range(2):
        want = float(planner.predictions_.structure_peak[0, g, d])
        assert twin.twin_peak(planner, 0, g, d, dt=5e-4) == pytest.approx(want, rel=1e-2)


def test_twin_separates_opposite_directions_the_planner_predicts_equal():
    planner = fitted_planner(2.0, head_mass=5.0)
    g = planner.gain_classes_.index("zero")
    P = planner.predictions_.structure_peak
    assert P[1, g, 0] == pytest.approx(P[1, g, 1], rel=1e-9)        # +n and -n: the planner is even in n
    plus, minus = (twin.twin_peak(planner, 1, g, d, dt=5e-4) for d in range(2))
    assert abs(plus / minus - 1) > 0.01


def test_pair_difference_of_hand_made_values():
    values = {(1, "zero", 0): 1.0, (1, "zero", 1): 2.0, (1, "zero", 2): 1.1, (1, "zero", 3): 2.0,
              (2, "high", 1): 3.0}
    # pairs (0, 2): 1.0 against 1.1; (1, 3): equal; branch 2 has no opposite candidate
    assert twin.pair_difference(values, 4) == pytest.approx(1.0 - 1.0 / 1.1)
    assert np.isnan(twin.pair_difference({(1, "zero", 0): 1.0}, 4))
