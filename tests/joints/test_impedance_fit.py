"""The joint impedance model: its pulse compliance against an independent integration and
eq 11, the Coulomb step against the convex problem it solves and a locked joint, the fit
recovering known parameters, and a custom pose's trial on the way in (filing, pulse)."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.core.errors import InputError
from campaign.joints.impedance import (
    ImpedanceFit,
    apparent_mass,
    friction_step,
    half_sine_shape,
    measured_pulse_shape,
    pulse_compliance,
    servo_gains,
)
from campaign.joints.lambda_fit import design_arrays
from campaign.model.exiit import effective_mass_batch
from campaign.model.paper import paper_q

POSES_DEG = [(0, 225, 90), (30, 200, 60), (-45, 180, 0), (60, 150, 120), (10, 120, 150), (-20, 210, 30)]
DIRS = [(-1, 0, 0), (-0.5, -0.8660254, 0), (0.8660254, 0.5, 0), (0, -1, 0), (-0.7071068, 0.7071068, 0),
        (0.5, -0.8660254, 0)]


@pytest.fixture(scope="module")
def arm(puma):
    Q = np.array([paper_q(np.array(q, float)) for q in POSES_DEG])
    D = np.array(DIRS, float)
    H, Jn = design_arrays(puma, Q, D)
    return Q, D, H, Jn


def test_without_servo_or_damping_the_compliance_is_h_inverse_and_the_mass_is_eq_11(puma, arm):
    Q, D, H, Jn = arm
    for shape in (half_sine_shape(7), np.array([0.7, 0.2, 0.1])):
        G = pulse_compliance(H, stiffness=np.zeros(3), damping=np.zeros(3), duration=0.07, shape=shape)
        assert np.allclose(G, np.linalg.inv(H), rtol=1e-10, atol=1e-12)
    m = apparent_mass(G, Jn, kappa_pos=np.zeros(3), kappa_neg=np.zeros(3), speed=1.5, e=0.55, m_b=0.7)
    eq11 = np.array([effective_mass_batch(puma, Q[i][None], D[i])[0] for i in range(len(Q))])
    assert np.allclose(m, eq11, rtol=1e-7)          # the matrix exponential to ~1e-10, n.G.n cancels a little


def test_the_compliance_matches_an_independent_integration_of_the_joints_under_the_pulse(arm):
    from scipy.integrate import solve_ivp

    _, _, H, _ = arm
    K, Dd, T = np.array([480.0, 650.0, 400.0]), np.array([21.0, 34.0, 15.0]), 0.07
    shape = np.array([0.1, 0.3, 0.25, 0.2, 0.1, 0.05])
    G = pulse_compliance(H[:2], stiffness=K, damping=Dd, duration=T, shape=shape)
    dt = T / shape.size
    for i in range(2):
        for j in range(3):
            def rhs(t, z, i=i, j=j):
                k = min(int(t / dt), shape.size - 1)
                u = np.zeros(3)
                u[j] = shape[k] / dt
                return np.concatenate([z[3:], np.linalg.solve(H[i], u - K * z[:3] - Dd * z[3:])])
            z = np.zeros(6)
            for k in range(shape.size):           # step by step: the force jumps at the steps
                z = solve_ivp(rhs, (k * dt, (k + 1) * dt), z, rtol=1e-11, atol=1e-13, method="DOP853").y[:, -1]
            assert np.allclose(G[i][:, j], z[3:], rtol=1e-7, atol=1e-10)
    # the servo's spring and the damping take velocity out: the tip sees a heavier arm
    G0 = pulse_compliance(H[:2], stiffness=0 * K, damping=0 * Dd, duration=T, shape=shape)
    assert np.all(np.trace(G, axis1=1, axis2=2) < np.trace(G0, axis1=1, axis2=2))


def test_the_coulomb_step_solves_its_convex_problem_and_holds_what_cannot_beat_friction():
    from scipy.optimize import minimize

    rng = np.random.default_rng(3)
    L = rng.normal(size=(40, 3, 3))
    A = L @ np.swapaxes(L, 1, 2) + 0.5 * np.eye(3)
    b = rng.normal(size=(40, 3))
    kp, kn = np.array([0.6, 0.3, 0.9]), np.array([0.4, 0.5, 0.2])
    x = friction_step(A, b, kappa_pos=kp, kappa_neg=kn)

    def objective(y, i):
        return 0.5 * y @ A[i] @ y - b[i] @ y + kp @ np.maximum(y, 0) + kn @ np.maximum(-y, 0)

    stuck = 0
    for i in range(len(b)):
        ref = minimize(objective, np.linalg.solve(A[i], b[i]), args=(i,), method="Powell",
                       options={"xtol": 1e-12, "ftol": 1e-14, "maxiter": 20000})
        assert objective(x[i], i) <= ref.fun + 1e-10
        stuck += int(np.sum(x[i] == 0))
    assert stuck > 0                                     # the draw holds some joints still
    free = friction_step(A, b, kappa_pos=0 * kp, kappa_neg=0 * kn)
    assert np.allclose(free, np.linalg.solve(A, b[:, :, None])[:, :, 0])
    assert np.all(friction_step(A, 0.1 * np.sign(b) * np.minimum(kp, kn), kappa_pos=kp, kappa_neg=kn) == 0)


@pytest.mark.parametrize("joint", [0, 1, 2])
def test_a_joint_friction_cannot_move_is_a_locked_joint_of_eq_11(puma, arm, joint):
    Q, D, H, Jn = arm
    G = np.linalg.inv(H)
    big = np.zeros(3)
    big[joint] = 1e6                                     # no blow beats it
    m = apparent_mass(G, Jn, kappa_pos=big, kappa_neg=big, speed=2.0, e=0.5, m_b=0.7)
    lam = np.zeros(3)
    lam[joint] = 1e12                                    # eq 11 with the joint's lambda unbounded
    locked = np.array([effective_mass_batch(puma, Q[i][None], D[i], lam)[0] for i in range(len(Q))])
    assert np.allclose(m, locked, rtol=1e-6)


def test_the_fit_recovers_damping_and_friction_from_synthetic_masses_of_two_gain_sets(puma):
    rng = np.random.default_rng(11)
    from campaign.design.candidates import random_candidates

    Qdeg, D = random_candidates(14, robot=puma, seed=5)
    Q = np.array([paper_q(q) for q in Qdeg])
    kz, dz = servo_gains(puma, "zero")
    kh, dh = servo_gains(puma, "high")
    Q, D = np.concatenate([Q, Q]), np.concatenate([D, D])
    K = np.array([kz] * 14 + [kh] * 14)
    Kd = np.array([dz] * 14 + [dh] * 14)
    v = np.tile([1.5, 2.5], 14)
    T = np.where(v > 2, 0.073, 0.067)
    shape = np.array([0.08, 0.2, 0.22, 0.18, 0.14, 0.1, 0.06, 0.02])
    beta, c = np.array([18.0, 29.0, 12.0]), 0.0045
    H, Jn = design_arrays(puma, Q, D)
    G = pulse_compliance(H, stiffness=K, damping=Kd + beta, duration=T, shape=shape)
    m = apparent_mass(G, Jn, kappa_pos=c * puma.coulomb_pos, kappa_neg=c * puma.coulomb_neg, speed=v, e=0.55, m_b=0.72)
    m_obs = m * np.exp(rng.normal(scale=0.005, size=m.size))
    est = ImpedanceFit(puma).fit(Q, D, m_obs, speed=v, e=np.full(v.size, 0.55), m_b=np.full(v.size, 0.72),
                                 duration=T, stiffness=K, damping=Kd, pulse_shape=shape)
    truth = np.concatenate([beta, [c]])
    got = np.concatenate([est.damping_, [est.friction_scale_]])
    lo, hi = est.params_ci_
    assert np.all(est.identifiable_) and est.condition_number_ < 1e3
    assert np.all((lo <= truth) & (truth <= hi)), (lo, got, hi)
    assert np.allclose(got, truth, rtol=0.1)
    pred = est.predict(Q, D, speed=v, m_b=0.72, stiffness=K, damping=Kd)
    assert np.max(np.abs(pred / m - 1)) < 0.02


def test_bad_inputs_are_refused_before_any_work(puma, arm):
    _, _, H, _ = arm
    with pytest.raises(InputError, match="duration"):
        pulse_compliance(H, stiffness=np.zeros(3), damping=np.zeros(3), duration=0.0, shape=[1.0])
    with pytest.raises(InputError, match="shape"):
        pulse_compliance(H, stiffness=np.zeros(3), damping=np.zeros(3), duration=0.07, shape=[0.5, -0.1])
    with pytest.raises(InputError, match="gain set"):
        servo_gains(puma, "medium")
    with pytest.raises(InputError, match="not fitted"):
        ImpedanceFit(puma).predict(np.zeros((1, 3)), [(-1.0, 0, 0)], speed=1.5, m_b=0.7, stiffness=np.zeros((1, 3)),
                                   damping=np.zeros((1, 3)))


def test_custom_pose_trials_are_filed_under_their_poses_and_give_their_measured_pulse(tmp_path):
    import h5py

    from campaign.archive import finalize_campaign, trial_path, verify, write_trial
    from campaign.core.vocabulary import misfiled
    from campaign.identify.table import identify_trials, read_identification
    from campaign.rig import simulate_arrays
    from campaign.scene.description import make_scene

    paths = []
    for n in ((-0.8660254, -0.5, 0.0), (0.8660254, 0.5, 0.0)):       # one pose, two directions
        sc = make_scene(base="fixed", config=0, q_paper_deg=(45.0, 150.0, 90.0), direction=n, gain="zero",
                        speed=1.5, repeat=0)
        paths.append(trial_path(tmp_path / "camp", sc))
        write_trial(simulate_arrays(sc), paths[-1])
    path = paths[0]
    with h5py.File(path) as f:
        attrs = dict(f.attrs)
        t, F = f["truth/t_truth"][:], f["truth/f_contact"][:]
    assert misfiled(path, attrs) is None
    wrong = tmp_path / "camp" / "fixed" / "pose-45.000_150.000_90.000-n0.000" / "zero" / "v1.500" / "r00.nc"
    assert "n30.000" in misfiled(wrong, attrs)
    # two custom poses of the same gain, speed and repeat are two cells, not a copy
    finalize_campaign(tmp_path / "camp")
    assert verify(tmp_path / "camp") == []
    identify_trials([path], tmp_path / "id.csv")      # refuses a misfiled trial
    r = read_identification([tmp_path / "id.csv"])[0]
    assert not r["excluded"]
    shape = measured_pulse_shape([path], [r["contact_start"]], [r["contact_end"]], segments=10)
    # the simulator's true force over the same steps, another channel than the piezo's
    edges = np.linspace(r["contact_start"], r["contact_end"], 11)
    fine = np.linspace(edges[0], edges[-1], 2001)
    ft = np.interp(fine, t, F)
    true_share = np.array([np.trapezoid(ft[k * 200:(k + 1) * 200 + 1], fine[k * 200:(k + 1) * 200 + 1])
                           for k in range(10)])
    true_share /= true_share.sum()
    assert shape.sum() == pytest.approx(1.0)
    assert np.max(np.abs(shape - true_share)) < 0.02
    assert int(np.argmax(shape)) < 5                     # the pulse peaks early: not a half-sine
