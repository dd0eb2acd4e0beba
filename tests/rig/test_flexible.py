"""The flexible long-reach base and the VES-II emulation loop in the rig."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.model import exiit
from campaign.model.robot import load_robot
from campaign.model.robot.floating import attach_to_floating_base
from campaign.rig import build, simulate
from campaign.rig.beam import Beam
from campaign.rig.integrate import integrate_trial
from campaign.scene import schema
from campaign.scene.description import make_scene


def _integrate(rig):
    p = rig.scene.p
    return integrate_trial(
        rig.plant, rig.pid, t_contact=rig.t_contact, speed=rig.scene.speed, servo_period=rig.servo_period,
        substeps_contact=rig.substeps_contact, substeps_free=rig.substeps_free, min_post=rig.min_post,
        max_post=rig.max_post, settle_velocity=p("trial.settle_velocity"), stick_velocity=p("arm.stick_velocity"),
        catch_delay=p("pendulum.catch_delay"))


def _loaded_first_mode(scene):
    """First bending frequency [Hz] of the scene's structure with the arm locked on top."""
    import pinocchio as pin

    from campaign.model.paper import paper_offset_deg

    robot = load_robot()
    q0 = np.radians(np.asarray(scene.q_paper_deg) + paper_offset_deg())
    data = robot.model.createData()
    pin.ccrba(robot.model, data, q0, np.zeros(robot.nv))
    beam = Beam.from_scene(scene)
    return float(beam.modes(tip=beam.base_body().mount.act(data.oYcrb[0]))[0][0])


def _free_base_rig(config, speed):
    """Ideal coupling with the beam's stiffness and damping removed, no gravity: a free base."""
    scene = make_scene(base="flexible", scene="ideal", config=config, speed=speed,
                       params={"ves.mode": "ideal", "flexible.trial_periods": 0.02})
    rig = build(scene)
    rig.plant.ibase._KB[:] = 0.0          # K = B = 0: nothing holds the base
    return rig


@pytest.mark.parametrize("config", [1, 2, 3])
def test_free_base_momentum_changes_exactly_by_the_contact_impulse(config):
    rig = _free_base_rig(config, 1.5)
    traj = _integrate(rig)
    plant = rig.plant
    n = plant.n
    lin0, ang0 = plant.momentum(traj.x[0])
    assert np.allclose(lin0, 0) and np.allclose(ang0, 0)
    for x in traj.x:
        lin, ang = plant.momentum(x)
        P, S = x[plant.i_P], x[plant.i_S]
        scale_l = max(abs(P), 1e-12)
        scale_a = max(np.linalg.norm(S), 1e-12)
        assert np.linalg.norm(lin - P * n) <= 1e-6 * scale_l
        assert np.linalg.norm(ang - S) <= 1e-6 * scale_a
    # and the hammer lost what the arm and base gained: I_p thetadot / r balances P
    pend = plant.pend
    i_end = int(np.searchsorted(traj.t, traj.contacts[0][1]))
    x_end = traj.x[i_end]
    hammer = pend.inertia * (traj.x[0][plant.i_thd] - x_end[plant.i_thd]) / pend.radius
    assert hammer == pytest.approx(x_end[plant.i_P], rel=2e-3)   # arc vs line: cos(theta) ~ 1 - 1e-3


@pytest.mark.parametrize("config", [1, 2, 3])
@pytest.mark.parametrize("speed", [1.0, 2.5])
def test_free_base_post_impact_velocity_matches_eq8_and_eq13(config, speed):
    rig = _free_base_rig(config, speed)
    traj = _integrate(rig)
    beam = Beam.from_scene(rig.scene)
    frobot = attach_to_floating_base(load_robot(), beam.base_body())
    m8 = exiit.effective_mass(frobot, rig.plant.q0_arm)
    m_b = rig.plant.pend.m_b
    e = rig.plant.contact.restitution
    va_eq13 = exiit.post_impact_velocity(m8, m_b, 0.0, speed, e)
    assert traj.v_a_post == pytest.approx(va_eq13, rel=5e-3)
    assert traj.v_b_post == pytest.approx(va_eq13 - e * speed, rel=5e-3)


@pytest.fixture(scope="module")
def config2_high():
    out = {}
    for mode in ("loop", "ideal"):
        out[mode] = simulate(make_scene(base="flexible", config=2, gain="high", speed=2.0,
                                        params={"ves.mode": mode}))
    return out


def test_ves_loop_peak_base_displacement_is_within_5_percent_of_the_ideal_coupling(config2_high):
    peak = {m: float(np.abs(t["measured"].base_position.sel(axis="x")).max()) for m, t in config2_high.items()}
    assert peak["ideal"] > 1e-5
    assert abs(peak["loop"] - peak["ideal"]) < 0.05 * peak["ideal"]


def test_flexible_trial_carries_base_channels_and_lasts_several_base_periods(config2_high):
    tree = config2_high["loop"]
    m = tree["measured"]
    names = {v.name for v in schema.variables("measured", "flexible")}
    assert names == set(m.to_dataset().data_vars)
    assert {v.name for v in schema.variables("truth", "flexible")} == set(tree["truth"].to_dataset().data_vars)
    scene = make_scene(base="flexible", config=2)
    beam = Beam.from_scene(scene)
    f1 = _loaded_first_mode(scene)
    duration = float(m.t_base[-1]) - float(tree["truth"].contact_start)
    assert duration * f1 >= scene.p("flexible.trial_periods") - 1e-9   # periods of the loaded first mode
    # at least one and a half periods after the contact (Figure 9's peaks and their decay)
    assert (float(m.t_base[-1]) - float(tree["truth"].contact_end)) * f1 >= 1.5
    # the platform follows its command, which follows the structure
    x = m.base_position.sel(axis="x").values
    assert np.corrcoef(x, m.platform_position.sel(axis="x").values)[0, 1] > 0.95
    assert float(m.base_mass) == pytest.approx(beam.base_body().mass)


def test_base_motion_is_larger_for_configuration_2_and_for_high_gains():
    peak = {}
    for config in (1, 2):
        for gain in ("low", "high"):
            tree = simulate(make_scene(base="flexible", config=config, gain=gain, speed=2.0))
            peak[config, gain] = float(np.abs(tree["measured"].base_position.sel(axis="x")).max())
    for gain in ("low", "high"):
        assert peak[2, gain] > peak[1, gain]
    for config in (1, 2):
        assert peak[config, "high"] > peak[config, "low"]


@pytest.mark.parametrize("setting,needle", [
    ("flexible.beam_EI=-2.5e8", "beam_EI"),
    ("flexible.beam_length=-1", "beam_length"),
    ("flexible.beam_mass=0", "beam_mass"),
    ("ves.latency=5", "latency"),
    ("ves.rate=5", "rate"),      # below 10x the first mode (0.70 Hz with the arm on top)
    ("ves.stroke=0.001", "ves.stroke"),    # the base moves ~3 mm at 1.5 m/s: beyond a 1 mm stroke
])
def test_flexible_bad_input_exits_2_naming_the_cause_and_leaves_no_file(tmp_path, capsys, setting, needle):
    out = tmp_path / "t.nc"
    assert main(["trial", "--base", "flexible", "--speed", "1.5", "--set", setting, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_fixed_base_scene_ignores_the_beam_entirely():
    # a fixed-base scene with a nonsensical beam still builds: it needs no base
    rig = build(make_scene(base="fixed", params={"flexible.trial_periods": 1.0}))
    assert not hasattr(rig.plant, "beam")
    with pytest.raises(InputError):
        build(make_scene(base="flexible", params={"ves.rate": 5.0}))


def test_a_flexible_trial_writes_and_reads_back_through_the_archive(config2_high, tmp_path):
    # measured and truth share variable names (base_position, ...) with different clocks
    from campaign.archive import open_trial, write_trial
    path = write_trial(config2_high["loop"], tmp_path / "t.nc")
    m = open_trial(path)
    t = open_trial(path, group="truth")
    assert m.base_position.dims == ("t_base", "axis")
    assert t.base_position.dims == ("t_truth", "axis")
    np.testing.assert_array_equal(m.base_position.values, config2_high["loop"]["measured"].base_position.values)


def test_stroke_check_names_the_axis_limit_and_passes_within_it():
    from campaign.rig.trial import check_stroke

    pose = np.zeros((5, 6))
    pose[2, 1] = -0.12
    check_stroke(pose, stroke=0.15, stroke_rotation=0.26)          # within: no error
    with pytest.raises(InputError, match="ves.stroke = 0.1 m"):
        check_stroke(pose, stroke=0.1, stroke_rotation=0.26)
    pose[3, 5] = 0.3
    with pytest.raises(InputError, match="ves.stroke_rotation"):
        check_stroke(pose, stroke=0.15, stroke_rotation=0.26)
