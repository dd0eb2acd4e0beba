"""The fixed-base simulated VES-II against closed forms, invariants and physical sanity."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from campaign.cli.main import main
from campaign.core.errors import InputError, SimulationError
from campaign.model import exiit
from campaign.model.paper import load_paper
from campaign.model.robot import load_robot
from campaign.rig import build, simulate
from campaign.rig.contact import damping_for_restitution, restitution_of_damping
from campaign.scene import schema
from campaign.scene.description import make_scene


def _edges(tree):
    tr = tree["truth"]
    return tuple(float(tr[k]) for k in ("v_a_pre", "v_a_post", "v_b_pre", "v_b_post"))


@pytest.mark.parametrize("e", [0.2, 0.55, 0.9])
@pytest.mark.parametrize("p", [0.8, 1.0, 1.5])
def test_damping_root_gives_restitution_of_the_contact_ode(e, p):
    # closed-form root vs an independent ODE integration of the dimensionless contact
    assert restitution_of_damping(damping_for_restitution(e, p), p) == pytest.approx(e, rel=1e-8)


@pytest.mark.parametrize("stiffness", [950.0, 4.0e6])
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_hammer_on_a_wall_rebounds_with_the_set_restitution_whatever_the_arrival_phase(stiffness, seed):
    # the arm locked by (huge) friction is a wall; the seed moves the touch inside the servo tick
    scene = make_scene(config=1, speed=1.7, seed=seed, params={
        "gravity": 0.0, "arm.coulomb_scale": 1e6, "arm.viscous_scale": 0.0, "contact.stiffness": stiffness,
        "trial.min_post_contact": 0.1, "trial.max_post_contact": 0.1})
    rig = build(scene)
    phase = (rig.t_contact / rig.servo_period) % 1.0
    tree = simulate(scene)
    va, va_post, vb, vb_post = _edges(tree)
    assert va_post == 0.0
    e = scene.p("contact.restitution")
    assert -vb_post / vb == pytest.approx(e, rel=1e-2), f"arrival phase {phase:.3f} of the servo tick"


@pytest.mark.parametrize("config", [1, 2, 3])
@pytest.mark.parametrize("speed", [1.0, 2.5])
def test_ideal_scene_post_impact_velocities_match_eq13(config, speed):
    robot = load_robot()
    tree = simulate(make_scene(scene="ideal", config=config, speed=speed))
    va, va_post, vb, vb_post = _edges(tree)
    m_b = float(tree["measured"].hammer_mass_eff)
    m1 = exiit.effective_mass(robot, tree["measured"].q_cmd.values)
    e = float(tree["truth"].e_contact)       # the restitution the contact model is set for
    va_eq13 = exiit.post_impact_velocity(m1, m_b, va, vb, e)
    vb_eq = va_eq13 - e * (vb - va)     # eq 12
    assert va_post == pytest.approx(va_eq13, rel=5e-3)
    assert vb_post == pytest.approx(vb_eq, rel=5e-3)
    # the integrated impulse is eq 14's, and the contact is close to impulsive (~1 ms)
    tr = tree["truth"]
    assert float(tr.impulse) == pytest.approx(exiit.impulse(m1, m_b, va, vb, e), rel=5e-3)
    assert float(tr.contact_end - tr.contact_start) < 2e-3


@pytest.mark.parametrize("config", [1, 3])
def test_passive_scene_energy_never_increases_after_the_touch(config):
    scene = make_scene(config=config, gain="zero", speed=2.0, params={"gravity": 0.0})
    tree = simulate(scene)
    tr = tree["truth"]
    t0 = float(tr.contact_start)
    energy = tr.energy.where(tr.t_truth >= t0, drop=True).values
    assert energy.size > 50
    assert np.all(np.diff(energy) <= 1e-9 * energy[0])
    assert energy[-1] < 0.9 * energy[0]       # friction and contact damping dissipate


@pytest.mark.parametrize("config,gain", [(2, "zero"), (3, "high"), (1, "low")])
def test_halving_the_step_changes_post_impact_velocities_by_less_than_1e4(config, gain):
    scene = make_scene(config=config, gain=gain, speed=1.8)
    rig = build(scene)
    base = _edges(simulate(scene))
    fine = _edges(simulate(scene, integration={"substeps_contact": 2 * rig.substeps_contact,
                                               "substeps_free": 2 * rig.substeps_free}))
    for a, b in zip(base[1::2], fine[1::2], strict=True):
        assert abs(a - b) <= 1e-4 * abs(b)


@pytest.fixture(scope="module")
def sweep():
    out = {}
    for config in (1, 2, 3):
        for gain in ("zero", "high"):
            for speed in (1.0, 2.5):
                out[config, gain, speed] = simulate(make_scene(config=config, gain=gain, speed=speed))
    return out


def test_default_peak_forces_lie_in_the_papers_30_70_N(sweep):
    lo, hi = load_paper()["impact_force_range_N"]
    for key, tree in sweep.items():
        peak = float(tree["truth"].peak_force)
        assert lo * 0.97 <= peak <= hi * 1.03, key


def test_zero_gain_joint3_moves_a_few_degrees_in_configuration_1_and_comes_to_rest():
    tree = simulate(make_scene(config=1, gain="zero", speed=2.0))
    tr = tree["truth"]
    q3 = np.degrees(tr.q.sel(joint="j3").values - tree["measured"].q_cmd.sel(joint="j3").item())
    assert 0.5 <= np.max(np.abs(q3)) <= 6.0
    assert tr.attrs["settled"] == 1
    assert np.all(tr.v.values[-10:] == 0.0)


def test_high_gains_give_a_larger_effective_mass_than_zero_gains(sweep):
    def m_true(tree):
        va, va_post, vb, vb_post = _edges(tree)
        return float(tree["measured"].hammer_mass_eff) * (vb - vb_post) / (va_post - va)
    for config in (1, 2, 3):
        for speed in (1.0, 2.5):
            assert m_true(sweep[config, "high", speed]) > m_true(sweep[config, "zero", speed])


def test_channels_follow_the_schema_and_a_fixed_base_carries_no_base_states(sweep):
    tree = sweep[1, "zero", 1.0]
    for group in ("measured", "truth"):
        ds = tree[group].to_dataset()
        names = {v.name for v in schema.variables(group, "fixed")}
        assert names == set(ds.data_vars)
        for name in names:
            assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
        for name in schema.FLEXIBLE_ONLY:
            assert name not in ds
    m = tree["measured"]
    assert np.allclose(np.diff(m.t_joint.values), 0.02)     # the paper's 20 ms joint samples
    # quantised encoders: every sample is a whole number of counts
    res = load_robot().encoder_resolution
    counts = m.q_enc.values / res
    assert np.allclose(counts, np.round(counts), atol=1e-6)
    # the touch happens inside the recording, after the pre-contact window
    assert 0.2 <= float(tree["truth"].contact_start) <= 0.22


def test_same_scene_and_seed_give_identical_channels():
    scene = make_scene(config=2, gain="low", speed=1.3)
    a, b = simulate(scene), simulate(scene)
    xr.testing.assert_identical(a["measured"].to_dataset(), b["measured"].to_dataset())
    xr.testing.assert_identical(a["truth"].to_dataset(), b["truth"].to_dataset())
    c = simulate(make_scene(config=2, gain="low", speed=1.3, seed=scene.seed + 1))
    assert not np.array_equal(a["measured"].f_piezo.values, c["measured"].f_piezo.values)


@pytest.mark.parametrize("argv,needle", [
    (["--speed", "0"], "speed"),
    (["--speed", "9"], "beyond what the pendulum can reach"),
    (["--speed", "1", "--config", "7"], "configuration 7"),
    (["--speed", "1", "--set", "pendulum.head_mass=-0.4"], "head_mass"),
    (["--speed", "1", "--set", "contact.stiffness=-5"], "contact.stiffness"),
    (["--speed", "1", "--gain", "high", "--set", "controller.torque_per_unit=1e-4"], "unstable"),
    (["--speed", "1", "--set", "no.such=1"], "no.such"),
])
def test_trial_cli_bad_input_exits_2_naming_the_cause_and_leaves_no_file(tmp_path, capsys, argv, needle):
    out = tmp_path / "t.nc"
    assert main(["trial", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def _diverging_rhs(monkeypatch, after=50):
    """Make the arm's dynamics diverge mid-trial (after ``after`` RK4 stages of the trial
    loop's kernel)."""
    from campaign.rig.kernels import FixedKernel
    stage = FixedKernel.stage
    calls = {"n": 0}

    def bad(self, *args, **kwargs):
        calls["n"] += 1
        xd = stage(self, *args, **kwargs)
        if calls["n"] > after:
            xd[self.sv] = [np.inf] * self.nv
        return xd

    monkeypatch.setattr(FixedKernel, "stage", bad)


def test_a_blow_up_is_reported_never_stored(monkeypatch):
    _diverging_rhs(monkeypatch)
    with pytest.raises(SimulationError, match="blew up"):
        simulate(make_scene(config=1, speed=2.0))


def test_a_blow_up_exits_2_and_leaves_no_file(monkeypatch, tmp_path, capsys):
    _diverging_rhs(monkeypatch)
    out = tmp_path / "t.nc"
    assert main(["trial", "--speed", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "blew up" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_an_integration_override_too_coarse_for_the_contact_is_refused():
    with pytest.raises(InputError, match="RK4 steps over a contact"):
        simulate(make_scene(config=1, speed=2.0, params={"contact.stiffness": 1e9, "contact.exponent": 1.0}),
                 integration={"substeps_contact": 1})


def test_contact_too_stiff_for_the_integrator_is_refused_before_simulating():
    with pytest.raises(InputError, match="too stiff"):
        build(make_scene(config=1, speed=2.0, params={"contact.stiffness": 1e14, "contact.exponent": 1.0}))


# -- the fast recording (campaign.rig.sensors) against plain per-sample Pinocchio -------------

def _plain_fixed(plant, x, xd, F):
    """F/T wrench, energy and tip speed of a fixed-base state the straightforward way: fresh
    Pinocchio data, forward kinematics, RNEA with the contact force as fext, CRBA."""
    import pinocchio as pin
    model = plant.model
    data = model.createData()
    nv = plant.nv
    q, v, a = x[:nv], x[plant.i_v], xd[plant.i_v]
    fid = plant.fid
    jid = model.frames[fid].parentJoint
    pin.forwardKinematics(model, data, q)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    f_local = data.oMi[jid].rotation.T @ (plant.n * F)
    fext[jid] = pin.Force(f_local, np.cross(model.frames[fid].placement.translation, f_local))
    pin.rnea(model, data, q, v, a, fext)
    w = data.oMi[1].act(data.f[1])
    wrench = -np.concatenate([w.linear, w.angular])
    H = pin.crba(model, data, q)
    H = np.triu(H) + np.triu(H, 1).T
    pe = pin.computePotentialEnergy(model, data, q)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
    pend = plant.pend
    th, thd = x[plant.i_th], x[plant.i_thd]
    delta = pend.radius * np.sin(th) - plant.n @ (data.oMf[fid].translation - plant.p_tip0)
    energy = (0.5 * v @ H @ v + 0.5 * pend.inertia * thd**2 + pe + pend.mgl * (1 - np.cos(th))
              + float(plant.contact.energy(delta)))
    return wrench, energy, float(plant.n @ J @ v)


def test_recorded_ft_wrench_energy_and_tip_speed_equal_plain_per_sample_pinocchio(monkeypatch):
    # end to end through simulate(): the recording's channels at samples before, in and after
    # the contact are recomputed from the sampled states with plain Pinocchio calls

    from campaign.rig import trial as sim
    from campaign.rig.sensors import StateSampler, sample_grid
    seen = {}
    real_record = sim.record_arrays

    def spy(rig, traj):
        seen["rig"], seen["traj"] = rig, traj
        return real_record(rig, traj)

    monkeypatch.setattr(sim, "record_arrays", spy)
    scene = make_scene(config=2, gain="high", speed=2.0,
                       params={"sensors.ft_noise_force": 0.0, "sensors.ft_noise_torque": 0.0})
    tree = simulate(scene)
    rig, traj = seen["rig"], seen["traj"]
    plant, sampler = rig.plant, StateSampler(rig.plant, seen["traj"])
    c0, c1, _ = traj.contacts[0]
    ms, tr = tree["measured"], tree["truth"]
    for name, rate in (("ft", scene.p("sensors.ft_rate")), ("truth", scene.p("sensors.truth_rate"))):
        t = sample_grid(float(rate), traj.t_end)
        X, XD = sampler(t)
        F = sampler.contact_force(t)
        inside = np.flatnonzero((t > c0) & (t < c1))
        moving = np.flatnonzero((t > c1) & (t <= traj.t[-1]))
        picks = [0, inside[0], inside[inside.size // 2], inside[-1], moving[0], moving[moving.size // 2], t.size - 1]
        assert F[picks[2]] > 0
        for k in picks:
            wrench, energy, tip_v = _plain_fixed(plant, X[k], XD[k], F[k])
            if name == "ft":
                got = np.concatenate([ms.ft_force.values[k], ms.ft_torque.values[k]])
                np.testing.assert_allclose(got, wrench, rtol=1e-10, atol=1e-10 * np.abs(wrench).max())
            else:
                assert tr.energy.values[k] == pytest.approx(energy, rel=1e-10)
                if traj.t_contact <= t[k] <= traj.t[-1]:
                    assert tr.tip_velocity_n.values[k] == pytest.approx(tip_v, rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("mode", ["fixed", "loop", "ideal"])
def test_fast_truth_and_wrench_helpers_equal_per_sample_evaluation(mode):
    # arbitrary states (no integration): the batched helpers against one evaluation per sample,
    # plain Pinocchio for the fixed base, the plants' own per-sample methods on a flexible base
    import pinocchio as pin

    from campaign.rig.sensors import mount_wrenches, truth_terms
    kw = {"base": "fixed"} if mode == "fixed" else {"base": "flexible", "params": {"ves.mode": mode}}
    plant = build(make_scene(config=2, gain="high", speed=2.0, **kw)).plant
    rng = np.random.default_rng(5)
    N = 12
    X = np.tile(np.zeros(plant.size), (N, 1))
    nq = plant.nv if mode != "loop" else plant.na
    X[:, :nq] = plant.q0[:nq] + rng.normal(0, 0.05, (N, nq))
    X[:, plant.i_th] = rng.normal(0.0, 0.1, N)
    X[:, plant.i_v] = rng.normal(0.0, 0.5, (N, plant.i_v.stop - plant.i_v.start))
    X[:, plant.i_thd] = rng.normal(0.0, 5.0, N)
    XD = rng.normal(0.0, 3.0, X.shape)
    F = np.where(rng.random(N) < 0.5, rng.uniform(1.0, 60.0, N), 0.0)
    pre, post = np.zeros(N, bool), np.zeros(N, bool)
    pre[:3], post[-2:] = True, True
    X[1:3, :plant.i_th] = X[0, :plant.i_th]           # the arm held still over each group
    X[1:3, plant.i_th + 1:plant.i_thd] = X[0, plant.i_th + 1:plant.i_thd]
    X[-2] = X[-1]
    pose = rng.normal(0.0, 1e-2, (N, 6))
    twist = rng.normal(0.0, 1e-1, (N, 6))
    if mode == "loop":
        energy, tip_v = truth_terms(plant, X, pre, post, pose, twist)
        for k in range(N):
            p, w = (np.zeros(6), np.zeros(6)) if pre[k] or post[k] else (pose[k], twist[k])
            assert energy[k] == pytest.approx(plant.energy_at(X[k], p, w), rel=1e-10)
            if not (pre[k] or post[k]):
                ref = plant.arm_at(X[k, :plant.na], X[k, plant.i_v], p, w)
                assert tip_v[k] == pytest.approx(ref, rel=1e-10, abs=1e-13)
        return
    energy, tip_v = truth_terms(plant, X, pre, post)
    wrench = mount_wrenches(plant, X, XD, F)
    for k in range(N):
        if mode == "fixed":
            w_ref, e_ref, v_ref = _plain_fixed(plant, X[k], XD[k], F[k])
        else:
            model = plant.fmodel
            data = model.createData()
            q7 = plant.q7(X[k, :plant.nv])
            jid = model.frames[plant.ffid].parentJoint
            pin.forwardKinematics(model, data, q7)
            fext = [pin.Force.Zero() for _ in range(model.njoints)]
            f_local = data.oMi[jid].rotation.T @ (plant.n * F[k])
            fext[jid] = pin.Force(f_local, np.cross(model.frames[plant.ffid].placement.translation, f_local))
            pin.rnea(model, data, q7, X[k, plant.i_v], XD[k, plant.i_v], fext)
            pin.updateFramePlacements(model, data)
            w = data.oMf[plant.mount_id].actInv(data.oMi[plant.arm_joint].act(data.f[plant.arm_joint]))
            w_ref = -np.concatenate([w.linear, w.angular])
            e_ref, v_ref = plant.energy(X[k]), plant.tip_speed(X[k])
        np.testing.assert_allclose(wrench[k], w_ref, rtol=1e-10, atol=1e-10 * np.abs(w_ref).max())
        assert energy[k] == pytest.approx(e_ref, rel=1e-10)
        if not (pre[k] or post[k]):
            assert tip_v[k] == pytest.approx(v_ref, rel=1e-10, abs=1e-13)
        else:
            assert tip_v[k] == 0.0


# -- parse caches: a file edited on disk is picked up ----------------------------------------

def test_cached_rig_robot_and_paper_files_pick_up_an_edit(tmp_path, monkeypatch):
    import shutil

    from campaign.core.yamlfile import config_dir
    from campaign.model.robot import ROBOTS_DIR
    from campaign.scene.description import load_rig
    # rig file: same size, rewritten at once (its mtime may not even change)
    rig = tmp_path / "rig.yaml"
    shutil.copy(config_dir() / "rig.yaml", rig)
    values, _ = load_rig(rig)
    m = values["pendulum.head_mass"]
    values["pendulum.head_mass"] = -1.0                # the caller's copy: the cache is untouched
    assert load_rig(rig)[0]["pendulum.head_mass"] == m
    text = rig.read_text()
    old = f"head_mass: {{value: {m}"
    assert old in text
    new = old[:-1] + ("1" if old[-1] != "1" else "2")
    rig.write_text(text.replace(old, new, 1))
    assert load_rig(rig)[0]["pendulum.head_mass"] == float(new.split("value: ")[1])
    # robot: drive file edited; every load hands its own model
    folder = tmp_path / "bot"
    shutil.copytree(ROBOTS_DIR / "puma560", folder)
    r1 = load_robot(folder)
    r1.model.armature[:] = 0.0
    r1.tau_max[:] = 0.0
    r2 = load_robot(folder)
    assert np.all(r2.model.armature > 0) and r2.tau_max[0] == 97.6
    drives = folder / "drives.yaml"
    drives.write_text(drives.read_text().replace("tau_max: 97.6,", "tau_max: 98.6,"))
    assert load_robot(folder).tau_max[0] == 98.6
    # paper.yaml through CAMPAIGN_CONFIG_DIR
    cfg = tmp_path / "config"
    shutil.copytree(config_dir(), cfg)
    monkeypatch.setenv("CAMPAIGN_CONFIG_DIR", str(cfg))
    n0 = load_paper()["impact_direction"]
    paper = cfg / "paper.yaml"
    text = paper.read_text()
    assert "impact_direction: [-1.0, 0.0, 0.0]" in text
    paper.write_text(text.replace("impact_direction: [-1.0, 0.0, 0.0]", "impact_direction: [0.0, 1.0, 0.0]"))
    assert load_paper()["impact_direction"] == [0.0, 1.0, 0.0] != n0


def _perturbed_state(base: str, *, seed: int):
    """(rig, x, tau, rng): configuration 2, High gains, the arm 0.05 rad (rms) off its pose,
    the plant's clock inside the VES emulator's first tick, a random servo torque."""

    from campaign.rig import trial as sim
    rig = sim.build(make_scene(base=base, config=2, gain="high", speed=2.0))
    plant = rig.plant
    rng = np.random.default_rng(seed)
    x = np.zeros(plant.size)
    x[:plant.nv] = plant.q0 + rng.normal(0.0, 0.05, plant.nv)
    plant._t = rig.t_contact + 0.0004
    return rig, x, rng.normal(0.0, 20.0, plant.nv), rng


@pytest.mark.parametrize("base", ["fixed", "flexible"])
def test_constrained_dynamics_through_locked_joints_equal_the_crba_solve(base):
    """The fast path (ABA on a model with the stuck joints locked, RNEA for the holding
    torque) solves the same constrained dynamics as the CRBA block solve it replaced, for
    every stick/slip assignment, with contact force and (flexible) a moving platform."""
    import itertools

    rig, x, tau, rng = _perturbed_state(base, seed=3)
    plant, nv = rig.plant, rig.plant.nv
    for modes in itertools.product((0, 1, -1), repeat=nv):
        modes = np.array(modes)
        v = np.where(modes == 0, 0.0, rng.normal(0.0, 0.3, nv))
        fs = plant.friction_state(modes, x[:nv])
        lam, a = plant.constrained(x[:nv], v, tau, fs)
        lam_ref, a_ref = plant.holding_torque(x[:nv], v, tau, fs.stuck)
        scale = max(1.0, float(np.max(np.abs(a_ref))))
        assert np.allclose(a, a_ref, rtol=1e-9, atol=1e-9 * scale), modes
        assert np.allclose(lam, lam_ref, rtol=1e-9, atol=1e-9 * max(1.0, float(np.max(np.abs(tau))))), modes
        assert np.all(a[fs.stuck] == 0.0)


@pytest.mark.parametrize("base", ["fixed", "flexible"])
def test_hot_path_shortcuts_give_the_same_numbers_as_the_general_forms(base):
    """The integrator's shortcuts are the general computation bit for bit: the RK4 stage
    ``rhs`` (loads and derivative inlined) equals ``evaluate``'s derivative in and out of
    contact, caught or not, for every stick/slip assignment; the tip projection on the
    axis-aligned impact direction equals ``n @ p`` and ``n @ J``; the PID on Python floats
    equals its vector law."""
    import itertools

    import pinocchio as pin

    rig, x, tau, rng = _perturbed_state(base, seed=5)
    plant, nv, t = rig.plant, rig.plant.nv, rig.plant._t
    # the head 2 mm into the tip (in contact), closing at ~1 m/s
    x[plant.i_th] = np.arcsin((plant.tip(x[:nv])[0] + 2e-3) / plant.pend.radius)
    x[plant.i_thd] = 1.0 / plant.pend.radius
    for modes, contact_v0, caught in itertools.product(itertools.product((0, 1, -1), repeat=nv),
                                                       (None, 2.0), (False, True)):
        modes = np.array(modes)
        x[plant.i_v] = np.where(modes == 0, 0.0, rng.normal(0.0, 0.3, nv))
        fs = plant.friction_state(modes, x[:nv])
        xd = plant.rhs(x, tau, fs, contact_v0, caught, t)
        xd_ref = plant.evaluate(x, tau, fs, contact_v0, caught, t)[0]
        assert np.array_equal(xd, xd_ref), (modes, contact_v0, caught)
        if contact_v0 is not None:
            assert xd[plant.i_P] > 0.0            # the contact force acted

    if base == "fixed":
        assert plant._axis == (0, -1.0)          # the paper's n = -x takes the shortcut
        s, Jn = plant.tip(x[:nv])
        J = pin.computeFrameJacobian(plant.model, plant.data, x[:nv], plant.fid, pin.LOCAL_WORLD_ALIGNED)
        p = plant.data.oMf[plant.fid].translation
        assert s == float(plant.n @ p) - plant._s0
        assert np.array_equal(Jn, plant.n @ J[:3])

    pid = rig.pid
    e_prev, e_sum = pid.e_prev, pid.e_sum
    for _ in range(5):
        q = pid.q_ref + rng.normal(0.0, 2e-3, nv)
        e = pid._ref - np.rint(q / pid.resolution)
        e_sum = e_sum + e
        u = pid._kP * e + pid._kD * (e - e_prev) + pid._kI * e_sum + pid.tau_gc
        e_prev = e
        assert np.array_equal(pid.update(q), np.minimum(np.maximum(u, -pid.tau_max), pid.tau_max))
    assert np.array_equal(pid.e_prev, e_prev) and np.array_equal(pid.e_sum, e_sum)


def test_ves_loop_shortcuts_give_the_same_numbers_as_the_plain_computation():
    """The VES loop plant's per-tick shortcuts are the plain computation bit for bit: the
    kept bias (the last state and platform motion asked for again) equals a fresh RNEA,
    and is recomputed when the state, the instant or the emulator's motion changes; the
    F/T sample as one 6-vector equals the (force, moment) pair; a tick's record columns of
    ``VesLoop.advance`` equal the named fields of ``VesLoop.step``."""
    import copy

    import pinocchio as pin

    from campaign.rig.flexible import _TICK_RECORD

    rig, x, tau, rng = _perturbed_state("flexible", seed=11)
    plant, na = rig.plant, rig.plant.na

    def fresh_bias(q, v):
        plant._bias_last = None
        return plant._bias(q, v)

    # set the platform moving: a few emulator ticks with the arm accelerating on it
    xd = np.zeros(plant.size)
    for _ in range(5):
        xd[plant.i_v] = rng.normal(0.0, 20.0, na)
        plant.on_emulator_tick(plant.t_last + plant.emulator_period, x, xd)
    t0 = plant._t = plant.t_last + 0.25 * plant.emulator_period
    assert np.any(np.asarray(plant._platform(t0)[1]) != 0.0)
    assert np.any(np.asarray(plant._platform(t0)[2]) != np.asarray(plant._platform(t0 + 5e-4)[2]))
    for _ in range(3):
        q, v = x[:na] + rng.normal(0.0, 0.01, na), rng.normal(0.0, 0.3, na)
        b = plant._bias(q, v)
        assert plant._bias(q.copy(), v.copy()) is b                      # kept
        assert np.array_equal(b, fresh_bias(q, v))
        v2 = v.copy()
        v2[0] += 1e-9
        assert np.array_equal(plant._bias(q, v2), fresh_bias(q, v2))      # another state: recomputed
        assert not np.array_equal(plant._bias(q, v2), b)
        plant._t = t0 + 0.0005                                             # another instant
        assert np.array_equal(plant._bias(q, v), fresh_bias(q, v))
        plant._t = t0

    # across an emulator tick: the tick's own instant keeps its motion, later ones move on
    q, v = x[:na].copy(), rng.normal(0.0, 0.3, na)
    t_tick = plant.t_last + plant.emulator_period
    plant._t = t_tick
    before = plant._bias(q, v)
    plant.on_emulator_tick(t_tick, x, xd)
    assert np.array_equal(plant._bias(q, v), before)
    assert np.array_equal(before, fresh_bias(q, v))
    plant._t = t_tick + 0.5 * plant.emulator_period
    assert np.array_equal(plant._bias(q, v), fresh_bias(q, v))

    qf = np.concatenate([pin.SE3ToXYZQUAT(pin.SE3.Identity()), x[:na]])
    vf, af = rng.normal(0.0, 0.2, 6 + na), rng.normal(0.0, 2.0, 6 + na)
    for F in (0.0, 25.0):
        f, m = plant._mount_wrench(qf, vf, af, F)
        assert np.array_equal(plant._mount_wrench6(qf, vf, af, F), np.concatenate([f, m]))

    loop_a, loop_b = copy.deepcopy(plant.loop), copy.deepcopy(plant.loop)
    for _ in range(4):
        w = plant.w_static + rng.normal(0.0, 5.0, 6)
        state = loop_a.step(w)
        out = loop_b.advance(w)
        assert np.array_equal(out[_TICK_RECORD],
                              np.concatenate([state.structure_pose, state.pose, state.command, state.twist]))
