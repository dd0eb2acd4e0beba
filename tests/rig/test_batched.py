"""A simulation job's trials (campaign.rig.batch.simulate_batch): each trial is its one-trial
result (campaign.rig.simulate_arrays) bit for bit, a failing trial is reported and leaves the
others unchanged, a bad scene is refused before any trial is simulated.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from campaign.core.errors import InputError, SimulationError
from campaign.model.paper import gain_counts
from campaign.rig import simulate_arrays
from campaign.rig.batch import simulate_batch
from campaign.rig.trial import build
from campaign.scene.description import make_scene

ROOT = Path(__file__).resolve().parents[2]


def _assert_same(one, batched, label):
    """Every channel of ``batched`` equals ``one`` bit for bit, and so do the root attributes."""
    assert not isinstance(batched, Exception), (label, batched)
    assert batched.attrs == one.attrs, label
    for group in ("measured", "truth"):
        a, b = one[group], batched[group]
        assert set(a.data_vars) == set(b.data_vars), (label, group)
        assert a.attrs == b.attrs, (label, group)
        for name, var in a.data_vars.items():
            np.testing.assert_array_equal(b.data_vars[name].values, var.values, err_msg=f"{label}: {group}/{name}")
        for name, var in a.coords.items():
            np.testing.assert_array_equal(b.coords[name].values, var.values, err_msg=f"{label}: {group}/{name}")


def _campaign_scenes(config_file):
    """Every trial of a campaign config: (base, configuration, gain, speed, repeat) scenes."""
    cfg = yaml.safe_load((ROOT / config_file).read_text())
    scenes = []
    for base, sweep in cfg["bases"].items():
        speeds = sweep.get("speeds", cfg["speeds"])
        repeats = sweep.get("repeats", cfg["repeats"])
        for config in sweep["configurations"]:
            for gain in sweep["gains"]:
                for speed in speeds:
                    for repeat in range(repeats):
                        scenes.append(make_scene(base=base, config=config, gain=gain, speed=float(speed),
                                                 repeat=repeat, gains_counts=gain_counts(gain),
                                                 campaign_seed=int(cfg["campaign_seed"])))
    return scenes


def _check_batch(scenes, integration=None):
    batched = simulate_batch(scenes, integration=integration)
    assert len(batched) == len(scenes)
    for scene, got in zip(scenes, batched, strict=True):
        _assert_same(simulate_arrays(scene, integration=integration), got, scene.name)


def test_every_trial_of_the_reduced_campaign_equals_its_one_trial_result():
    scenes = _campaign_scenes("config/tests/ci.yaml")
    assert {s.base for s in scenes} == {"fixed", "flexible"}
    assert {s.gain for s in scenes} == {"zero", "low", "high"}
    _check_batch(scenes)


def test_the_ideal_scene_equals_its_one_trial_results():
    _check_batch([make_scene(scene="ideal", config=c, speed=v) for c in (1, 2, 3) for v in (1.0, 2.5)])


def test_the_stress_corners_equal_their_one_trial_results_or_are_refused_alike():
    from campaign import bench

    groups: dict = {}
    for case in bench.stress_cases(reduced=True):
        scene = case.make()
        try:
            build(scene, integration=case.integration)
        except ValueError as err:   # InputError, or the robot's own check of a pose
            # refused before any work, by the batch as by the one-trial path
            with pytest.raises(type(err), match=re.escape(str(err))):
                simulate_batch([scene], integration=case.integration)
            continue
        key = tuple(sorted((case.integration or {}).items()))
        groups.setdefault(key, []).append(scene)
    assert sum(len(g) for g in groups.values()) >= 5
    for key, scenes in groups.items():
        _check_batch(scenes, dict(key) or None)


def test_failing_trials_are_reported_and_leave_the_others_unchanged(monkeypatch):
    import importlib

    batch_module = importlib.import_module("campaign.rig.batch")
    cells = ((1, "high", 1.5), (2, "low", 2.5), (3, "high", 2.5), (1, "zero", 2.5), (2, "high", 1.5))
    scenes = [make_scene(config=c, gain=g, speed=v, gains_counts=gain_counts(g), campaign_seed=1996)
              for c, g, v in cells]
    real_build = batch_module.build

    def build_destabilised(scene, **kwargs):
        # deliberately unstable: the joint damping of trials 2 and 4 made negative (energy fed
        # in at every step), after the input checks, as a destabilised plant would be. Far
        # beyond what RK4 at the servo substep can follow (trial 2) the joints' stop events
        # cascade; moderately (trial 4) the state grows until it is no longer finite.
        rig = real_build(scene, **kwargs)
        scale = {scenes[2].sha256: -1e6, scenes[4].sha256: -1e2}.get(scene.sha256)
        if scale is not None:
            rig.plant.viscous = scale * np.abs(rig.plant.viscous)
        return rig

    monkeypatch.setattr(batch_module, "build", build_destabilised)
    done = []
    out = simulate_batch(scenes, on_done=lambda i, v: done.append(i))
    assert sorted(done) == [0, 1, 2, 3, 4]
    assert isinstance(out[2], SimulationError) and "events within one servo tick" in str(out[2]), out[2]
    assert isinstance(out[4], SimulationError) and "blew up" in str(out[4]), out[4]
    for i in (0, 1, 3):
        _assert_same(simulate_arrays(scenes[i]), out[i], scenes[i].name)


def test_the_batch_refuses_a_bad_scene_before_simulating_any():
    good = make_scene(config=1, speed=1.5)
    bad = make_scene(config=1, speed=1.5, params={"contact.stiffness": 1.0})
    done = []
    with pytest.raises(InputError, match="contact.stiffness"):
        simulate_batch([good, bad], on_done=lambda i, v: done.append(i))
    assert done == []


def test_a_failing_trial_of_a_job_is_named_and_the_others_are_written(tmp_path, monkeypatch):
    import importlib

    from campaign import archive
    from campaign.core.vocabulary import trial_relpath
    from campaign.pipeline.sweep import run_cells

    batch_module = importlib.import_module("campaign.rig.batch")

    real_build = batch_module.build

    def build_destabilised(scene, **kwargs):
        rig = real_build(scene, **kwargs)
        if scene.speed == 2.5:      # the job's second trial: negative joint damping (see above)
            rig.plant.viscous = -1e2 * np.abs(rig.plant.viscous)
        return rig

    monkeypatch.setattr(batch_module, "build", build_destabilised)
    with pytest.raises(SimulationError, match=r"1 of 2 trials failed.*fixed/config1/high/v2\.500/r00: the integration "
                                              r"blew up"):
        run_cells([("fixed", 1, "high")], archive_dir=tmp_path, speeds=[1.5, 2.5], repeats=1,
                         campaign_seed=1996)
    monkeypatch.setattr(batch_module, "build", real_build)
    good = tmp_path / trial_relpath("fixed", 1, "high", 1.5, 0)
    assert not (tmp_path / trial_relpath("fixed", 1, "high", 2.5, 0)).exists()
    one = simulate_arrays(make_scene(config=1, gain="high", speed=1.5, gains_counts=gain_counts("high"),
                                     campaign_seed=1996))
    for group in ("measured", "truth"):
        stored = archive.open_trial_arrays(good, group=group)
        for name, var in one[group].data_vars.items():
            np.testing.assert_array_equal(stored.data_vars[name].values, var.values, err_msg=f"{group}/{name}")


def test_campaign_sweep_writes_each_trial_as_campaign_trial_would_and_refuses_bad_input(tmp_path, capsys):
    from campaign import archive
    from campaign.cli.main import main

    assert main(["sweep", "--configs", "2", "--gains", "low", "--speeds", "1.5,2.5", "--campaign-seed", "7",
                 "--out", str(tmp_path), "--quiet"]) == 0
    files = sorted(tmp_path.rglob("*.nc"))
    assert [f.relative_to(tmp_path).as_posix() for f in files] == [
        "fixed/config2/low/v1.500/r00.nc", "fixed/config2/low/v2.500/r00.nc"]
    one = simulate_arrays(make_scene(config=2, gain="low", speed=2.5, gains_counts=gain_counts("low"), campaign_seed=7))
    stored = archive.open_trial_arrays(files[1], group="truth")
    for name, var in one["truth"].data_vars.items():
        np.testing.assert_array_equal(stored.data_vars[name].values, var.values, err_msg=name)
    capsys.readouterr()
    assert main(["sweep", "--speeds", "1.5,25", "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "25" in err[0] and "pendulum" in err[0]
    assert not (tmp_path / "bad").exists()
