"""The planner's post-contact term: the structure's peak with the arm still moving after the impact."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from campaign.core.errors import InputError
from campaign.model.robot import load_robot
from campaign.model.robot.floating import attach_to_floating_base
from campaign.model.robot.ik import impact_point
from campaign.plan.post_contact import (
    ArmAfterImpact,
    peak_displacement,
    pulse_peak_displacement,
    unit_responses,
)
from campaign.plan.prediction import pose_terms, predict
from campaign.rig.beam import Beam
from campaign.rig.contact import ContactLaw, pulse_shape
from campaign.scene.description import make_scene, rig_values

Q = np.radians([-121.9, -27.4, 0.0])      # the rig check's side point, branch 2
LAMBDA = [19.82, 4.62, 0.80]
N_DIRS = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, -0.8, 0.0]])


@pytest.fixture(scope="module")
def puma():
    return load_robot("puma560")


def beam_of(**params):
    return Beam.from_scene(make_scene(base="flexible", params={"flexible.structure": "space_class", **params}))


def run_predict(puma, beam, arm, *, lam=LAMBDA):
    terms = pose_terms(puma, Q[None], beam=beam)
    contact = ContactLaw(537.0, 0.74, 0.58)
    P = predict(terms, [lam], N_DIRS, mass=2.0, speed=2.0, restitution=0.58, contact=contact, arm=arm,
                gain_names=["g"])
    return terms, P


def integrated_peak(puma, beam, *, kp, kd, gravity, lam, p, pulse=None):
    """The same linear coupled system assembled from scratch and integrated with solve_ivp: the
    release velocities from the full free-flyer model's impulse balance, not from eq 8's parts;
    with ``pulse = (T, shape)`` the impulse enters instead as the force ``J^T p f(t) / int f``
    over ``T`` on the free-flyer model (no lambda), ``f`` the shape interpolated linearly."""
    frobot = attach_to_floating_base(puma, beam.base_body())
    model = frobot.model
    data = model.createData()
    qf = frobot.q_full(Q)
    M = pin.crba(model, data, qf)
    M = np.triu(M) + np.triu(M, 1).T
    J = pin.computeFrameJacobian(model, data, qf, frobot.impact_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    # impulsive phase: (M + diag(0, lambda)) dv = J^T p (eq 8's free base, eq 13's joints)
    Ml = M.copy()
    Ml[6:, 6:] += np.diag(lam)
    v0 = np.linalg.solve(Ml, J.T @ p)
    gmodel = pin.Model(model)
    gmodel.gravity.linear = np.array([0.0, 0.0, -gravity])
    dG = pin.computeGeneralizedGravityDerivatives(gmodel, gmodel.createData(), qf)
    K = np.zeros((9, 9))
    K[:6, :6] = beam.stiffness
    K[6:, 6:] = np.diag(kp)
    K += dG
    C = np.zeros((9, 9))
    C[:6, :6] = beam.damping
    C[6:, 6:] = np.diag(kd)
    Minv = np.linalg.inv(M)

    f1 = pose_terms(puma, Q[None], beam=beam).frequency[0, 0]
    t = np.linspace(0.0, 1.0 / f1, 4001)
    if pulse is None:
        def rhs(t, z):
            return np.concatenate([z[9:], -Minv @ (K @ z[:9] + C @ z[9:])])
        sol = solve_ivp(rhs, (0.0, t[-1]), np.concatenate([np.zeros(9), v0]), t_eval=t, rtol=1e-10, atol=1e-13)
        return float(np.max(np.linalg.norm(sol.y[:3], axis=0)))
    T, shape = pulse
    grid = np.linspace(0.0, T, shape.size)
    area = np.trapezoid(shape, grid)
    Q_in = Minv @ J.T @ p / area

    def rhs(t, z):
        return np.concatenate([z[9:], -Minv @ (K @ z[:9] + C @ z[9:]) + Q_in * np.interp(t, grid, shape, right=0.0)])
    z = np.zeros(18)
    # integrate the pulse on its own (the force is only piecewise smooth), then the free response
    first = solve_ivp(rhs, (0.0, T), z, rtol=1e-10, atol=1e-13, max_step=T / (shape.size - 1), dense_output=True)
    rest = solve_ivp(rhs, (T, t[-1]), first.y[:, -1], t_eval=t[t > T], rtol=1e-10, atol=1e-13)
    x = np.concatenate([first.sol(t[t <= T])[:3], rest.y[:3]], axis=1)
    return float(np.max(np.linalg.norm(x, axis=0)))


@pytest.mark.parametrize("gains", [(np.zeros(3), np.zeros(3), 0.0),                      # free joints
                                   (np.array([477.0, 653.0, 397.0]), np.array([3.8, 5.2, 3.2]), 9.81)])
def test_peak_matches_an_independent_integration_of_the_coupled_system(puma, gains):
    kp, kd, g = gains
    beam = beam_of()
    viscous = np.array([17.5, 28.7, 12.1])
    arm = ArmAfterImpact(gains={"g": (kp, kd)}, viscous=viscous, gravity=g, samples=256, pulse=False)
    _, P = run_predict(puma, beam, arm)
    for d, n in enumerate(N_DIRS):
        p = n / np.linalg.norm(n) * P.impulse[0, 0, d]
        ref = integrated_peak(puma, beam, kp=kp, kd=kd + viscous, gravity=g, lam=LAMBDA, p=p)
        assert P.structure_peak[0, 0, d] == pytest.approx(ref, rel=2e-4)


@pytest.mark.parametrize("gains", [(np.zeros(3), np.zeros(3), 0.0),                      # free joints
                                   (np.array([477.0, 653.0, 397.0]), np.array([3.8, 5.2, 3.2]), 9.81)])
def test_pulse_matches_an_independent_integration_under_the_contact_force(puma, gains):
    # the stiff mast: its quarter period (~56 ms) is shorter than the contact, so the pulse matters
    kp, kd, g = gains
    beam = Beam.from_scene(make_scene(base="flexible", params={"flexible.structure": "stiff_mast"}))
    viscous = np.array([17.5, 28.7, 12.1])
    arm = ArmAfterImpact(gains={"g": (kp, kd)}, viscous=viscous, gravity=g, samples=256)
    contact = ContactLaw(537.0, 0.74, 0.58)
    terms = pose_terms(puma, Q[None], beam=beam)
    P = predict(terms, [LAMBDA], N_DIRS, mass=2.0, speed=2.0, restitution=0.58, contact=contact, arm=arm,
                gain_names=["g"])
    _, shape = pulse_shape(contact.damping, contact.exponent)
    for d, n in enumerate(N_DIRS):
        p = n / np.linalg.norm(n) * P.impulse[0, 0, d]
        T = float(P.contact_duration[0, 0, d])
        assert 0.05 < T < 0.2
        ref = integrated_peak(puma, beam, kp=kp, kd=kd + viscous, gravity=g, lam=np.zeros(3), p=p,
                              pulse=(T, np.asarray(shape)))
        assert P.structure_peak[0, 0, d] == pytest.approx(ref, rel=2e-3)


def test_a_short_pulse_recovers_the_impulse_at_once(puma):
    beam = beam_of()
    arm = ArmAfterImpact(gains={"g": (np.array([477.0, 653.0, 397.0]), np.array([3.8, 5.2, 3.2]))},
                         viscous=np.array([17.5, 28.7, 12.1]), samples=128)
    terms = pose_terms(puma, Q[None], beam=beam)
    X = np.linalg.solve(terms.H, np.swapaxes(terms.J, 1, 2))[:, None]
    kp, damping, _ = arm.matrices(["g"], 3)
    p = (N_DIRS / np.linalg.norm(N_DIRS, axis=1)[:, None] * 3.0)[None, None]
    _, shape = pulse_shape(ContactLaw(537.0, 0.74, 0.58).damping, 0.74)
    R, _ = unit_responses(terms, X, kp, damping, gravity=9.81, samples=128)
    at_once = peak_displacement(R, p)
    errors = []
    for T in (0.2, 0.02, 0.002, 1e-7):                 # the last shorter than the finest grid step
        pulsed = pulse_peak_displacement(terms, X, kp, damping, p, np.full(p.shape[:3], T), shape=shape,
                                         gravity=9.81, samples=128)
        errors.append(np.max(np.abs(pulsed / at_once - 1)))
    # the pulse's centroid delays the peak by about T/4: the difference falls with T
    assert errors[0] > errors[1] > errors[2] and errors[2] < 2e-3 and errors[0] > 0.01
    assert errors[3] < 2e-3


def test_joints_stopped_at_once_give_the_structure_released_with_the_locked_arms_momentum(puma):
    # undamped structure, no gravity, a derivative gain so large the joints stop within microseconds:
    # the base then carries the whole impulse as one rigid body (closed form over its modes)
    beam = beam_of(**{"flexible.damping_ratio": 0.0})
    arm = ArmAfterImpact(gains={"g": (np.zeros(3), np.full(3, 1e6))}, viscous=np.zeros(3), gravity=0.0,
                         samples=512, pulse=False)
    terms, P = run_predict(puma, beam, arm)
    Mb = terms.M_full[0, :6, :6]
    w2, phi = np.linalg.eigh(np.linalg.inv(np.linalg.cholesky(Mb)) @ beam.stiffness
                             @ np.linalg.inv(np.linalg.cholesky(Mb)).T)
    phi = np.linalg.inv(np.linalg.cholesky(Mb)).T @ phi            # M_b-normalised modes
    omega = np.sqrt(w2)
    t = np.linspace(0.0, 1.0 / terms.frequency[0, 0], 20001)
    JbT = np.linalg.solve(np.linalg.inv(Mb), terms.base_from_impulse[0])   # J_b^T = M_b (M_b^-1 J_b^T)
    for d, n in enumerate(N_DIRS):
        p = n / np.linalg.norm(n) * P.impulse[0, 0, d]
        eta_dot = phi.T @ (JbT @ p)
        x = phi[:3] @ (eta_dot[:, None] * np.sin(omega[:, None] * t[None]) / omega[:, None])
        assert P.structure_peak[0, 0, d] == pytest.approx(np.max(np.linalg.norm(x, axis=0)), rel=1e-3)
    # the locked arm differs from eq 8's release with free joints: the term is not a no-op here
    assert not np.allclose(P.structure_peak, P.structure_peak_release, rtol=0.01)


def test_without_the_arm_model_the_peak_is_eq8s_release(puma):
    beam = beam_of()
    terms = pose_terms(puma, Q[None], beam=beam)
    P = predict(terms, [LAMBDA], N_DIRS, mass=2.0, speed=2.0, restitution=0.58, contact=ContactLaw(537.0, 0.74, 0.58))
    np.testing.assert_array_equal(P.structure_peak, P.structure_peak_release)


@pytest.mark.parametrize("arm, match", [
    (ArmAfterImpact(gains={}, viscous=[1.0, -2.0, 1.0]), r"viscous friction \[1.0, -2.0, 1.0\]"),
    (ArmAfterImpact(gains={"g": ([1.0, 1.0, -5.0], 0.0)}, viscous=np.zeros(3)), r"'g': Kp = \[1.0, 1.0, -5.0\]"),
    (ArmAfterImpact(gains={}, viscous=np.zeros(3), gravity=float("nan")), "gravity = nan"),
    (ArmAfterImpact(gains={}, viscous=np.zeros(3), samples=2), "samples = 2"),
])
def test_bad_arm_values_are_refused_naming_the_value(puma, arm, match):
    with pytest.raises(InputError, match=match):
        run_predict(puma, beam_of(), arm)


def test_planner_on_the_flexible_base_splits_pooled_classes_and_uses_each_sets_servo(puma):
    from campaign.plan.factory import arm_after_impact, build_planner

    planner = build_planner(base="flexible", lambdas={"zero_low": LAMBDA, "high": [53.18, 8.66, 2.83]}, speed=2.0,
                            objective="displacement", structure="space_class")
    planner.fit(impact_point(puma, Q), N_DIRS[:2])
    assert planner.gain_classes_ == ["zero", "low", "high"]
    arm = arm_after_impact(rig_values(), load_robot("puma560"))
    kp_low, kd_low = arm.gains["low"]
    kp_high, _ = arm.gains["high"]
    assert np.all(arm.gains["zero"][0] == 0) and np.all(kp_low > 0) and np.all(kp_high > 50 * kp_low)
    # zero and low share lambda, so eq 8 is the same; the servo after the impact is not
    P = planner.predictions_
    np.testing.assert_array_equal(P.structure_peak_release[:, 0], P.structure_peak_release[:, 1])
    assert not np.allclose(P.structure_peak[:, 0], P.structure_peak[:, 1], rtol=1e-4)
    rows = planner.rows()
    assert all(r["structure_peak_release"] > 0 and r["structure_peak"] > 0 for r in rows)
    # the fixed base splits them too (the peak force follows each set's servo); without the arm's
    # model the classes stay as given
    fixed = build_planner(base="fixed", lambdas={"zero_low": LAMBDA}, speed=2.0).fit(impact_point(puma, Q), N_DIRS)
    assert fixed.gain_classes_ == ["zero", "low"]
    bare = build_planner(base="fixed", lambdas={"zero_low": LAMBDA}, speed=2.0, post_contact=False)
    assert bare.fit(impact_point(puma, Q), N_DIRS).gain_classes_ == ["zero_low"]


def test_post_contact_term_is_closer_to_the_rig_than_eq8s_release(puma):
    """One candidate simulated on the rig (space-class structure, zero gains, a +y blow at the
    side point): the post-contact prediction with the impulse at once (eq 13's release with
    lambda, which carries the joints' friction) is within 6 % and closer than eq 8's release."""
    from campaign.model.paper import paper_offset_deg
    from campaign.plan.factory import build_planner
    from campaign.rig.trial import simulate_arrays

    n = np.array([0.0, 1.0, 0.0])
    planner = build_planner(base="flexible", lambdas={"zero": LAMBDA}, speed=2.0, objective="displacement",
                            structure="space_class")
    planner.arm = dataclasses.replace(planner.arm, pulse=False)
    planner.fit(impact_point(puma, Q), n[None])
    i = int(np.argmin(np.linalg.norm(planner.q_ - Q, axis=1)))
    q_paper = np.degrees(Q) - paper_offset_deg()
    scene = make_scene(base="flexible", config=None, gain="zero", speed=2.0, q_paper_deg=q_paper.tolist(),
                       params={"flexible.structure": "space_class"}, direction=n.tolist())
    truth = simulate_arrays(scene)["truth"]
    measured = float(np.max(np.linalg.norm(truth["base_position"].values, axis=1)))
    post = float(planner.predictions_.structure_peak[i, 0, 0])
    release = float(planner.predictions_.structure_peak_release[i, 0, 0])
    assert abs(post / measured - 1) < 0.06
    assert abs(post / measured - 1) < abs(release / measured - 1)


def test_a_response_that_blows_up_is_reported_not_stored(puma):
    from campaign.core.errors import SimulationError

    arm = ArmAfterImpact(gains={}, viscous=np.zeros(3), gravity=1e300)     # an absurd gravity stiffness
    with pytest.raises(SimulationError, match="post-contact response is not finite at pose"):
        with np.errstate(all="ignore"):
            run_predict(puma, beam_of(), arm)


def test_a_pulse_of_no_duration_is_refused_naming_it(puma):
    beam = beam_of()
    terms = pose_terms(puma, Q[None], beam=beam)
    X = np.linalg.solve(terms.H, np.swapaxes(terms.J, 1, 2))[:, None]
    p = np.ones((1, 1, 1, 3))
    _, shape = pulse_shape(ContactLaw(537.0, 0.74, 0.58).damping, 0.74)
    with pytest.raises(InputError, match="contact duration must be > 0 s, got -0.1"):
        pulse_peak_displacement(terms, X, np.zeros((1, 3)), np.ones((1, 3)), p, np.full((1, 1, 1), -0.1),
                                shape=shape, gravity=9.81, samples=64)
