"""The contact law's finite pulse and the arm's apparent mass over the compression (the planner's force term)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from campaign.core.errors import InputError
from campaign.model.exiit import effective_mass
from campaign.model.robot import load_robot
from campaign.model.robot.ik import impact_point
from campaign.plan.compression import compression_mass
from campaign.plan.post_contact import ArmAfterImpact
from campaign.plan.prediction import pose_terms, predict
from campaign.rig.contact import ContactLaw, peak_force_factor, pulse_shape

Q = np.radians([[-121.9, -27.4, 0.0], [30.0, 60.0, -60.0]])
N_DIRS = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, -0.8, 0.0]])
KP = np.array([[0.0, 0.0, 0.0], [477.0, 653.0, 397.0]])
DAMP = np.array([[17.5, 28.7, 12.1], [21.3, 33.9, 15.2]])
CONTACT = ContactLaw(537.0, 0.737, 0.58)


@pytest.fixture(scope="module")
def puma():
    return load_robot("puma560")


def test_pulse_carries_the_momentum_and_peaks_at_the_peak_force_factor():
    d, p = CONTACT.damping, CONTACT.exponent
    tau, f = pulse_shape(d, p)
    assert np.trapezoid(f, dx=tau / (f.size - 1)) == pytest.approx(1.0 + CONTACT.restitution, rel=1e-4)
    assert f.max() == pytest.approx(peak_force_factor(d, p), rel=1e-4)
    assert f[0] == 0.0 and f[-1] == 0.0


def test_duration_of_a_linear_undamped_contact_is_half_its_period():
    c = ContactLaw(2.0e4, 1.0, 1.0)
    m = np.array([0.3, 2.0, 7.5])
    np.testing.assert_allclose(c.duration(m, 1.7), np.pi * np.sqrt(m / 2.0e4), rtol=1e-8)


def test_duration_matches_the_two_body_contact_integrated():
    m1, m2, v0 = 0.7, 6.0, 2.0
    mu = m1 * m2 / (m1 + m2)

    def rhs(_, y):
        delta, ddelta = y[0] - y[1], y[2] - y[3]
        f = float(CONTACT.force(delta, ddelta, v0))
        return [y[2], y[3], -f / m1, f / m2]

    def apart(_, y):
        return float(CONTACT.force(y[0] - y[1], y[2] - y[3], v0)) if y[0] - y[1] > 0 else -1.0
    apart.terminal, apart.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 1.0), [1e-12, 0.0, v0, 0.0], events=apart, rtol=1e-11, atol=1e-14, max_step=1e-4)
    assert CONTACT.duration(mu, v0) == pytest.approx(sol.t_events[0][0], rel=1e-3)


def test_without_servo_or_friction_it_is_eq7s_free_arm(puma):
    terms = pose_terms(puma, Q)
    m_c, force = compression_mass(terms.H, terms.J, N_DIRS, np.zeros((1, 3)), np.zeros((1, 3)), contact=CONTACT,
                                  mass=5.0, speed=2.0)
    for i, q in enumerate(Q):
        for d, n in enumerate(N_DIRS):
            assert m_c[i, 0, d] == pytest.approx(effective_mass(puma, q, n, np.zeros(3)), rel=1e-9)
    mu = m_c * 5.0 / (m_c + 5.0)
    np.testing.assert_allclose(force, CONTACT.peak_force(mu, 2.0), rtol=1e-12)


def test_matches_the_joints_integrated_under_the_pulse_to_its_peak(puma):
    terms = pose_terms(puma, Q)
    mass, speed = 5.03, 2.0
    m_c, _ = compression_mass(terms.H, terms.J, N_DIRS, KP, DAMP, contact=CONTACT, mass=mass, speed=speed)
    tau, f = pulse_shape(CONTACT.damping, CONTACT.exponent)
    frac = int(np.argmax(f)) / (f.size - 1)
    for i in range(len(Q)):
        H = terms.H[i]
        for g in range(2):
            for d, n in enumerate(N_DIRS):
                m = m_c[i, g, d]
                T = CONTACT.duration(m * mass / (m + mass), speed)      # the fixed point's own pulse
                grid = np.linspace(0.0, T, f.size)
                Jn = terms.J[i].T @ n

                def rhs(t, y, grid=grid, H=H, Jn=Jn, g=g):   # this candidate's pose and pulse
                    force = np.interp(t, grid, f)
                    return np.concatenate([y[3:], np.linalg.solve(H, Jn * force - DAMP[g] * y[3:] - KP[g] * y[:3])])
                t_peak = frac * T
                sol = solve_ivp(rhs, (0.0, t_peak), np.zeros(6), rtol=1e-10, atol=1e-13, max_step=T / 512)
                impulse = np.trapezoid(f[grid <= t_peak + 1e-15], grid[grid <= t_peak + 1e-15])
                assert m == pytest.approx(impulse / (Jn @ sol.y[3:, -1]), rel=2e-3)
    # the servo and friction make the arm heavier over the compression than the free arm
    free, _ = compression_mass(terms.H, terms.J, N_DIRS, np.zeros((1, 3)), np.zeros((1, 3)), contact=CONTACT,
                               mass=mass, speed=speed)
    assert np.all(m_c > free)


def test_fixed_base_peak_force_follows_the_compression_with_the_arm_model(puma):
    terms = pose_terms(puma, Q)
    arm = ArmAfterImpact(gains={"low": (KP[0], DAMP[0] - DAMP[0]), "high": (KP[1], DAMP[1] - DAMP[0])},
                         viscous=DAMP[0])
    kw = dict(mass=5.03, speed=2.0, restitution=0.58, contact=CONTACT, gain_names=["low", "high"])
    lams = [[19.82, 4.62, 0.80], [53.18, 8.66, 2.83]]
    P = predict(terms, lams, N_DIRS, arm=arm, **kw)
    m_c, force = compression_mass(terms.H, terms.J, N_DIRS, KP, DAMP, contact=CONTACT, mass=5.03, speed=2.0)
    np.testing.assert_allclose(P.compression_mass, m_c, rtol=1e-12)
    np.testing.assert_allclose(P.peak_force, force, rtol=1e-12)
    # lambda still sets m* and the impulse; the impulse-at-once switch gives lambda's peak force back
    bare = predict(terms, lams, N_DIRS, **kw)
    np.testing.assert_array_equal(P.m_eff, bare.m_eff)
    np.testing.assert_array_equal(P.impulse, bare.impulse)
    import dataclasses
    at_once = predict(terms, lams, N_DIRS, arm=dataclasses.replace(arm, pulse=False), **kw)
    np.testing.assert_array_equal(at_once.peak_force, bare.peak_force)
    assert at_once.compression_mass is None


def test_closer_to_the_rig_than_lambdas_peak_force(puma):
    """One fixed-base rig trial with the 5 kg head (high gains, side point, -x blow): the force
    from the compression is within 3 %, lambda's over-predicts by more."""
    from campaign.model.paper import load_paper, paper_offset_deg
    from campaign.plan.factory import build_planner
    from campaign.rig.trial import simulate_arrays
    from campaign.scene.description import make_scene

    params = {"pendulum.head_mass": 5.0}
    table3 = {k: [float(v) for v in lam] for k, lam in load_paper()["table3"].items()}
    from campaign.rig.pendulum import Pendulum
    m_b = Pendulum.from_scene(make_scene(params=params)).m_b
    n = np.array([-1.0, 0.0, 0.0])
    q = Q[0]
    out = {}
    for post in (True, False):
        pl = build_planner(base="fixed", lambdas=table3, speed=2.0, mass=m_b, params=params, post_contact=post)
        pl.fit(impact_point(puma, q), n[None])
        i = int(np.argmin(np.linalg.norm(pl.q_ - q, axis=1)))
        out[post] = float(pl.predictions_.peak_force[i, pl.gain_classes_.index("high"), 0])
    q_paper = np.degrees(q) - paper_offset_deg()
    scene = make_scene(base="fixed", config=None, gain="high", speed=2.0, q_paper_deg=q_paper.tolist(), params=params,
                       direction=n.tolist())
    measured = float(np.max(simulate_arrays(scene)["truth"]["f_contact"].values))
    assert abs(out[True] / measured - 1) < 0.03
    assert out[False] / measured - 1 > 2 * abs(out[True] / measured - 1)


def test_bad_pulse_values_are_refused():
    with pytest.raises(InputError, match="pulse samples = 2"):
        pulse_shape(0.3, 0.7, samples=2)
    with pytest.raises(InputError, match="exponent p = -1"):
        pulse_shape(0.3, -1.0)
    assert math.isfinite(pulse_shape(0.0, 1.0)[0])


def test_planner_rows_carry_the_contact_and_the_compression(puma):
    from campaign.plan.factory import build_planner

    pl = build_planner(base="fixed", lambdas={"zero_low": [19.82, 4.62, 0.80]}, speed=2.0, mass=5.03,
                       objective="force")
    rows = pl.fit(impact_point(puma, Q[0]), N_DIRS).rows()
    assert rows and all(0.1 < r["contact_duration"] < 0.3 and r["compression_mass"] > 0 for r in rows)
    # ranked by the force, which grows with the apparent mass over the compression
    order = [r["compression_mass"] for r in rows]
    assert order == sorted(order)
