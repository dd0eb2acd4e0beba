"""The VES platform's stroke: refused before simulating from eq 8's prediction, and after it."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.plan.stroke import (
    STROKE_MARGIN,
    check_scene_stroke,
    predicted_platform_peak,
)
from campaign.rig import build, simulate_arrays
from campaign.scene.description import make_scene


def _scene(stroke=None, **more):
    params = {"flexible.structure": "space_class", **more}
    if stroke is not None:
        params["ves.stroke"] = stroke
    return make_scene(base="flexible", config=2, gain="low", speed=2.5, params=params)


def _prediction(rig):
    pl = rig.plant
    return predicted_platform_peak(pl.robot, pl.q0_arm, pl.n, pl.beam, mass=pl.pend.m_b, speed=rig.scene.speed,
                                   restitution=pl.contact.restitution, contact=pl.contact)


@pytest.fixture(scope="module")
def default_trial():
    scene = _scene()
    rig = build(scene)
    peak = float(np.max(np.abs(simulate_arrays(scene)["measured"]["platform_position"].values)))
    return _prediction(rig), peak


def test_prediction_bounds_the_simulated_peak_from_above(default_trial):
    pred, peak = default_trial
    assert 0.5 < peak / pred <= 1.0           # within the margin the refusal before work keeps


def test_refused_before_any_work_beyond_the_margin(default_trial):
    pred, _ = default_trial
    stroke = 0.9 * pred / STROKE_MARGIN
    with pytest.raises(InputError, match=r"would move about .* ves.stroke = .* \(structure space_class\)"):
        check_scene_stroke(_scene(stroke))
    check_scene_stroke(_scene(1.1 * pred / STROKE_MARGIN))    # within the margin: no refusal


def test_sweep_refuses_before_any_trial_is_simulated(default_trial, tmp_path, monkeypatch):
    pred, _ = default_trial
    from campaign.pipeline import sweep as jobs

    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated a sweep the prediction refuses")

    monkeypatch.setattr(jobs, "simulate_batch", no_simulation)
    with pytest.raises(InputError, match=r"would move about"):
        jobs.run_cells([("flexible", 2, "low")], archive_dir=tmp_path, speeds=[2.5], repeats=1,
                       params={"flexible.structure": "space_class", "ves.stroke": 0.9 * pred / STROKE_MARGIN})
    assert list(tmp_path.iterdir()) == []


def test_between_the_margin_and_the_peak_the_check_after_integration_refuses(default_trial):
    pred, peak = default_trial
    stroke = 0.9 * peak                      # above pred / STROKE_MARGIN: the prediction lets it run
    assert stroke > pred / STROKE_MARGIN
    build(_scene(stroke))                    # no refusal before work
    with pytest.raises(InputError, match=r"moves .* from rest, beyond the VES platform's stroke ves.stroke"):
        simulate_arrays(_scene(stroke))
    simulate_arrays(_scene(1.1 * peak))      # within the stroke: it runs


def test_cli_refusal_before_work_exits_2_with_one_line_and_no_file(tmp_path, capsys):
    out = tmp_path / "t.nc"
    assert main(["trial", "--base", "flexible", "--speed", "2.5", "--set", "ves.stroke=0.002", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "would move about" in err and "ves.stroke = 0.002 m" in err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
