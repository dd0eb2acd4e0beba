"""The response model: its closed-form limits, the friction step, the VES loop against the ideal
coupling, the pose's second derivative, the estimator family, save and load, and one small
end-to-end check of the shipped model on rig trials."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from campaign.joints.emulated_base import Loop
from campaign.joints.friction import StickSlip, stick_slip
from campaign.joints.impacts import Impacts
from campaign.joints.impedance_model import JointImpedance
from campaign.joints.modelfile import load_model, shipped_model_path
from campaign.joints.response import respond
from campaign.joints.setting import Setting
from campaign.joints.terms import arm_terms
from campaign.model.exiit import effective_mass
from campaign.model.paper import paper_q
from campaign.model.robot.floating import attach_to_floating_base
from campaign.rig.beam import Beam
from campaign.rig.contact import ContactLaw

POSES_DEG = [(0, 150, 90), (30, 200, 60), (-45, 180, 0), (10, 120, 150)]
DIRS = [(-1, 0, 0), (-0.5, -0.8660254, 0), (0.8660254, 0.5, 0), (0, -1, 0)]
#: a stiff contact: a pulse of about 0.3 ms, the impulsive limit for the arm (the pose moves by
#: ~1e-5 rad during it)
STIFF = ContactLaw(1.0e8, 1.0, 0.6)
#: the rig's own contact law (a 60-80 ms pulse)
SOFT = ContactLaw(537.302, 0.737176, 0.576812)


@pytest.fixture(scope="module")
def poses():
    return np.array([paper_q(np.array(q, float)) for q in POSES_DEG]), np.array(DIRS, float)


def _passive(terms, n, contact, **kw):
    nv = terms.nv
    args = dict(kp=np.zeros(nv), kd=np.zeros(nv), damping=np.zeros(nv), coulomb_pos=np.zeros(nv),
                coulomb_neg=np.zeros(nv), directions=n[:, None, :], speed=1.5, mass=0.7, restitution=0.6,
                contact=contact, gravity=0.0, servo_period=0.0, window=False)
    args.update(kw)
    return respond(terms, **args)


def test_without_servo_damping_and_friction_a_short_pulse_gives_eq_11_with_lambda_zero(puma, poses):
    Q, n = poses
    r = _passive(arm_terms(puma, Q), n, STIFF)
    eq7 = [effective_mass(puma, Q[i], n[i], None) for i in range(len(Q))]
    assert np.allclose(r.m_eff[:, 0], eq7, rtol=2e-4)


def test_a_very_short_pulse_is_the_impulsive_limit_whatever_the_joints_resistance(puma, poses):
    # the servo, the damping and friction act over a 26 us pulse only (over 0.3 ms the joints'
    # viscous damping alone, 18-29 N m s/rad on 1-3 kg m^2, would take 0.2-0.5 %)
    Q, n = poses
    r = _passive(arm_terms(puma, Q), n, ContactLaw(1.0e10, 1.0, 0.6), kp=[500.0, 650.0, 400.0], kd=[4.0, 5.0, 3.0], damping=[18.0, 29.0, 12.0],
                 coulomb_pos=[1.5, 0.8, 0.4], coulomb_neg=[1.7, 0.5, 0.3], gravity=9.81)
    eq7 = [effective_mass(puma, Q[i], n[i], None) for i in range(len(Q))]
    assert np.allclose(r.m_eff[:, 0], eq7, rtol=5e-4)
    # over the rig's 70 ms pulse the same joints look much heavier
    slow = _passive(arm_terms(puma, Q), n, SOFT, kp=[500.0, 650.0, 400.0], kd=[4.0, 5.0, 3.0], damping=[18.0, 29.0, 12.0])
    assert np.all(slow.m_eff[:, 0] > 1.2 * np.asarray(eq7))


def test_a_rigid_structure_gives_the_fixed_base(puma, poses):
    Q, n = poses
    kw = dict(kp=[5.0, 6.5, 4.0], kd=[0.04, 0.05, 0.03], damping=[18.0, 29.0, 12.0], coulomb_pos=[1.5, 0.8, 0.4],
              coulomb_neg=[1.7, 0.5, 0.3], gravity=9.81, servo_period=1e-3)
    fixed = _passive(arm_terms(puma, Q), n, SOFT, **kw).m_eff[:, 0]
    rigid = Beam(EI=2.5e16, length=20.0, mass=200.0)
    flex = _passive(arm_terms(puma, Q, beam=rigid), n, SOFT, coupling="ideal", **kw).m_eff[:, 0]
    assert np.allclose(flex, fixed, rtol=2e-3)


def test_a_free_structure_gives_eq_8_with_lambda_zero(puma, poses):
    Q, n = poses
    soft_beam = Beam(EI=1e-3, length=20.0, mass=200.0, damping_ratio=0.0)
    r = _passive(arm_terms(puma, Q, beam=soft_beam), n, STIFF, coupling="ideal")
    frobot = attach_to_floating_base(puma, soft_beam.base_body())
    eq8 = [effective_mass(frobot, Q[i], n[i], None) for i in range(len(Q))]
    assert np.allclose(r.m_eff[:, 0], eq8, rtol=2e-4)


def test_the_loop_tends_to_the_ideal_coupling_without_latency_and_with_a_fast_platform(puma, poses):
    Q, n = poses
    beam = Beam(EI=2.5e8, length=20.0, mass=200.0)
    terms = arm_terms(puma, Q[:2], beam=beam)
    kw = dict(kp=[5.0, 6.5, 4.0], kd=[0.04, 0.05, 0.03], damping=[18.0, 29.0, 12.0], gravity=9.81, servo_period=1e-3)
    ideal = _passive(terms, n[:2], SOFT, coupling="ideal", **kw)
    near = _passive(terms, n[:2], SOFT, coupling="loop", loop=Loop(20000.0, 0.0, 2000.0), **kw)
    assert np.allclose(near.m_eff, ideal.m_eff, rtol=5e-3)
    rig = _passive(terms, n[:2], SOFT, coupling="loop", loop=Loop(1000.0, 0.002, 30.0), **kw)
    assert not np.allclose(rig.m_eff, ideal.m_eff, rtol=5e-3)      # the rig's loop does move m*


def test_the_impact_points_second_derivative_matches_the_jacobians_change(puma, poses):
    Q, _ = poses
    t = arm_terms(puma, Q)
    rng = np.random.default_rng(0)
    for i in range(len(Q)):
        dq = 1e-4 * rng.normal(size=3)
        moved = arm_terms(puma, (Q[i] + dq)[None])
        assert np.allclose(moved.J[0] - t.J[i], np.einsum("aij,j->ai", t.hessian[i], dq), atol=1e-8)


def test_the_friction_step_solves_its_convex_problem_and_keeps_stuck_joints_still():
    from scipy.optimize import minimize

    rng = np.random.default_rng(3)
    L = rng.normal(size=(6, 3, 3))
    A = L @ np.swapaxes(L, 1, 2) + 0.5 * np.eye(3)
    v = rng.normal(size=(6, 4, 3))
    kp, kn = np.array([0.6, 0.3, 0.9]), np.array([0.4, 0.5, 0.2])
    x, modes = StickSlip(A).step(v, kappa_pos=kp, kappa_neg=kn)
    for c in range(6):
        for d in range(4):
            b = A[c] @ v[c, d]

            def f(y, c=c, b=b):
                return 0.5 * y @ A[c] @ y - b @ y + kp @ np.maximum(y, 0) + kn @ np.maximum(-y, 0)
            best = minimize(f, x[c, d], method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-14}).fun
            assert f(x[c, d]) <= best + 1e-9
            assert np.all(x[c, d][modes[c, d] == 0] == 0.0)
    ref, _ = stick_slip(np.repeat(A, 4, axis=0), np.einsum("cij,cdj->cdi", A, v).reshape(-1, 3), kappa_pos=kp,
                        kappa_neg=kn)
    assert np.allclose(x.reshape(-1, 3), ref, atol=1e-12)
    # a warm start with the answer's modes gives the same answer
    again, _ = StickSlip(A).step(v, kappa_pos=kp, kappa_neg=kn, modes=modes)
    assert np.allclose(again, x, atol=1e-12)


def test_the_model_fits_back_the_joints_it_was_made_with(puma, poses):
    setting = Setting.from_rig()
    Q, n = poses
    q = np.repeat(Q, 3, axis=0)
    d = np.repeat(n, 3, axis=0)
    gains = ["zero", "low", "high"] * len(Q)
    truth = JointImpedance(setting)
    truth.set_fitted({"damping": [16.0, 30.0, 11.0], "friction_scale": 0.07, "restitution": 0.55,
                      "covariance": np.zeros((4, 4)).tolist()})
    imp = Impacts(q=q, direction=d, speed=np.tile([1.2, 2.0, 2.4], len(Q)), gain=gains)
    m = truth.predict(imp)
    fitted = JointImpedance(setting).fit(Impacts(q=q, direction=d, speed=imp.speed, gain=gains, m_eff=m,
                                                 restitution=np.full(len(m), 0.55)))
    assert np.allclose(fitted.damping_, [16.0, 30.0, 11.0], rtol=1e-4)
    assert math.isclose(fitted.friction_scale_, 0.07, rel_tol=1e-4)
    assert fitted.rms_log_residual_ < 1e-6


def test_the_shipped_model_is_for_this_rig_and_predicts_two_rig_trials(puma):
    from campaign.identify import identify_trial
    from campaign.rig.trial import simulate_arrays
    from campaign.scene.description import make_scene

    model = load_model(shipped_model_path())            # checks the rig's, paper's and robot's digests
    fitted_on = json.loads(shipped_model_path().read_text())["fit"]["residuals"]
    # fitted on the designed campaign's fixed-base trials, every gain set
    assert model.kind == "joint_impedance" and model.n_trials_ == len(fitted_on) >= 24
    assert all(t.startswith("archive/designed/fixed/") for t in fitted_on)
    assert {t.split("/")[-3] for t in fitted_on} == {"zero", "low", "high"}
    recs = []
    for base, gain, v in (("fixed", "high", 1.2), ("flexible", "low", 2.0)):
        trial = simulate_arrays(make_scene(base=base, config=0, q_paper_deg=[20.0, 160.0, 70.0], gain=gain, speed=v,
                                           direction=[-0.8660254, 0.5, 0.0], campaign_seed=5))
        recs.append(identify_trial(trial["measured"], meta=dict(trial.attrs)).to_dict())
    for rec in recs:
        imp = Impacts.from_records([rec])
        m, lo, hi = (float(x[0]) for x in model.predict_interval(imp))
        assert abs(m / rec["m_eff"] - 1.0) < 0.03 and lo < m < hi
