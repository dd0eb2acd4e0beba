"""The impact planner: IK branches, eqs 7/8/13/14 against independent routes, the contact's peak
force and the structure's response against direct integrations, and the CLI's refusals."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from campaign.cli.main import main
from campaign.model import exiit
from campaign.model.paper import configuration_q
from campaign.model.robot.floating import attach_to_floating_base
from campaign.model.robot.ik import impact_point, position_branches
from campaign.plan.directions import cone_directions, horizontal_directions
from campaign.plan.planner import ImpactPlanner
from campaign.plan.prediction import peak_amplitude_factor, pose_terms, predict
from campaign.rig.beam import Beam
from campaign.rig.contact import ContactLaw, peak_force_factor

LAMBDAS = [[0.0, 0.0, 0.0], [19.82, 4.62, 0.80], [53.18, 8.66, 2.83]]
M_B, V_B, E = 0.7, 2.0, 0.55
CONTACT = ContactLaw(537.3, 0.737, E)


@pytest.fixture(scope="module")
def beam():
    return Beam(EI=2.5e8, length=20.0, mass=200.0, damping_ratio=0.02, platform_mass=50.0)


@pytest.fixture(scope="module")
def poses(puma):
    rng = np.random.default_rng(7)
    Q = rng.uniform(puma.q_lower, puma.q_upper, size=(6, 3))
    return np.vstack([[configuration_q(c) for c in (1, 2, 3)], Q])


# -- inverse kinematics -----------------------------------------------------------------
def test_every_pose_within_the_limits_is_found_again_from_its_wrist_centre(puma):
    rng = np.random.default_rng(3)
    counts = []
    for q in rng.uniform(puma.q_lower, puma.q_upper, size=(25, 3)):
        p = impact_point(puma, q)
        res = position_branches(puma, p)
        counts.append(res.n_branches)
        assert np.any(np.all(np.abs(res.q - q) < 1e-6, axis=1)), (np.degrees(q), np.degrees(res.q))
        for qb in res.q:       # every branch hits the point, within the limits, and they are distinct
            assert np.linalg.norm(impact_point(puma, qb) - p) < 1e-9
            assert np.all(qb >= puma.q_lower - 1e-12) and np.all(qb <= puma.q_upper + 1e-12)
        d = np.abs(res.q[:, None] - res.q[None]).max(axis=2) + np.eye(res.n_branches)
        assert np.all(d > 1e-5)
    assert max(counts) == 4 and min(counts) >= 1     # the PUMA's shoulder x elbow branches


def test_a_point_beyond_the_reach_has_no_branch(puma):
    res = position_branches(puma, [2.0, 0.0, 0.0])
    assert res.n_branches == 0 and not res.reached_outside_limits


# -- eqs 7, 8, 13, 14 ------------------------------------------------------------------
def test_fixed_base_m_eff_is_eq_7_and_eq_5_holds(puma, poses):
    n = horizontal_directions(5)
    P = predict(pose_terms(puma, poses), LAMBDAS, n, mass=M_B, speed=V_B, restitution=E, contact=CONTACT)
    data = puma.model.createData()
    for i, q in enumerate(poses):
        H = exiit.inertia(puma.model, data, q)
        J = exiit.impact_jacobian(puma.model, data, q, puma.impact_frame_id)[:3]
        for g, lam in enumerate(LAMBDAS):
            for d in range(len(n)):
                m = exiit.effective_mass(puma, q, n[d], lam)
                assert P.m_eff[i, g, d] == pytest.approx(m, rel=1e-10)
                # eq 5: (H + lambda) dq = J^T n I
                lhs = (H + np.diag(lam)) @ P.dq[i, g, d]
                np.testing.assert_allclose(lhs, J.T @ n[d] * P.impulse[i, g, d], rtol=1e-9, atol=1e-12)


def test_eq_13_and_14_balance_the_hammer_and_the_arm(puma, poses):
    n = horizontal_directions(4)
    P = predict(pose_terms(puma, poses), LAMBDAS, n, mass=M_B, speed=V_B, restitution=E, contact=CONTACT)
    data = puma.model.createData()
    for i, q in enumerate(poses):
        J = exiit.impact_jacobian(puma.model, data, q, puma.impact_frame_id)[:3]
        v_a = np.einsum("dj,jk,gdk->gd", n, J, P.dq[i])       # tip velocity along n after the impact
        np.testing.assert_allclose(v_a, exiit.post_impact_velocity(P.m_eff[i], M_B, 0.0, V_B, E), rtol=1e-9)
        np.testing.assert_allclose(v_a, P.tip_velocity[i], rtol=1e-9)
        v_b_after = v_a - E * V_B                                          # eq 12 with v_a = 0
        np.testing.assert_allclose(M_B * (V_B - v_b_after), P.impulse[i], rtol=1e-12)


def test_flexible_m_eff_is_eq_8_and_the_free_flyer(puma, poses, beam):
    n = np.vstack([horizontal_directions(3), [[0.3, -0.2, 0.9]]])
    P = predict(pose_terms(puma, poses, beam=beam), LAMBDAS, n, mass=M_B, speed=V_B, restitution=E, contact=CONTACT)
    frobot = attach_to_floating_base(puma, beam.base_body())
    for i, q in enumerate(poses):
        for g, lam in enumerate(LAMBDAS):
            G8 = exiit.exiit_floating(frobot, q, lam)
            Gd = exiit.exiit_floating_direct(frobot, q, lam)
            for d in range(len(n)):
                assert P.m_eff[i, g, d] == pytest.approx(exiit.effective_mass_from_G(G8, n[d]), rel=1e-10)
                assert P.m_eff[i, g, d] == pytest.approx(exiit.effective_mass_from_G(Gd, n[d]), rel=1e-9)


def test_flexible_velocities_solve_the_free_flyer_impulse_and_conserve_momentum(puma, poses, beam):
    n = np.vstack([horizontal_directions(3), [[0.3, -0.2, 0.9]]])
    n = n / np.linalg.norm(n, axis=1)[:, None]
    P = predict(pose_terms(puma, poses, beam=beam), LAMBDAS, n, mass=M_B, speed=V_B, restitution=E, contact=CONTACT)
    frobot = attach_to_floating_base(puma, beam.base_body())
    model, data = frobot.model, frobot.model.createData()
    for i, q in enumerate(poses):
        qf = frobot.q_full(q)
        M = exiit.inertia(model, data, qf)
        J = exiit.impact_jacobian(model, data, qf, frobot.impact_frame_id)
        for g, lam in enumerate(LAMBDAS):
            Ml = M.copy()
            Ml[6:, 6:] += np.diag(lam)
            for d in range(len(n)):
                F = np.concatenate([n[d] * P.impulse[i, g, d], np.zeros(3)])
                v = np.linalg.solve(Ml, J.T @ F)           # the whole system under the impulse
                np.testing.assert_allclose(P.base_velocity[i, g, d], v[:6], rtol=1e-8, atol=1e-12)
                np.testing.assert_allclose(P.dq[i, g, d], v[6:], rtol=1e-8, atol=1e-12)
                if g == 0:   # without lambda the system is free: its linear momentum is the impulse
                    h = pin.computeCentroidalMomentum(model, data, qf, v)
                    np.testing.assert_allclose(h.linear, F[:3], rtol=1e-9, atol=1e-12)


# -- contact peak force ----------------------------------------------------------------
@pytest.mark.parametrize("p", [1.0, 1.5, 0.737])
def test_undamped_peak_force_is_the_energy_closed_form(p):
    assert peak_force_factor(0.0, p) == pytest.approx(((p + 1) / 2) ** (p / (p + 1)), rel=1e-9)


@pytest.mark.parametrize("m_eff", [3.0, 12.0, np.inf])
def test_peak_force_matches_a_two_body_integration_of_the_contact_law(m_eff):
    c = ContactLaw(537.3, 0.737, 0.58)
    m_a = 1e12 if np.isinf(m_eff) else m_eff

    def rhs(_, y):      # y = (x_b, v_b, x_a, v_a); penetration x_b - x_a
        f = float(c.force(y[0] - y[2], y[1] - y[3], 2.0))
        return [y[1], -f / M_B, y[3], f / m_a]

    sol = solve_ivp(rhs, (0, 0.2), [0.0, 2.0, 0.0, 0.0], max_step=1e-5, rtol=1e-10, atol=1e-13)
    f = np.array([float(c.force(a - b, va - vb, 2.0)) for a, va, b, vb in sol.y.T])
    mu = M_B if np.isinf(m_eff) else m_eff * M_B / (m_eff + M_B)
    assert c.peak_force(mu, 2.0) == pytest.approx(f.max(), rel=1e-4)


# -- structure -------------------------------------------------------------------------
def test_structure_peak_matches_the_structure_released_with_the_base_velocity(puma, beam):
    q = configuration_q(1)
    n = horizontal_directions(3)
    terms = pose_terms(puma, q[None], beam=beam)
    P = predict(terms, [LAMBDAS[1]], n, mass=M_B, speed=V_B, restitution=E, contact=CONTACT)
    frobot = attach_to_floating_base(puma, beam.base_body())
    M = exiit.inertia(frobot.model, frobot.model.createData(), frobot.q_full(q))[:6, :6]
    K = np.asarray(beam.stiffness)
    # modal damping zeta on every mode of the loaded structure, as the prediction assumes
    w2, phi = np.linalg.eig(np.linalg.solve(M, K))
    w2, phi = w2.real, phi.real
    phi = phi / np.sqrt(np.einsum("ij,ik,kj->j", phi, M, phi))
    B = M @ phi @ np.diag(2 * beam.damping_ratio * np.sqrt(w2)) @ phi.T @ M
    A = np.block([[np.zeros((6, 6)), np.eye(6)], [-np.linalg.solve(M, K), -np.linalg.solve(M, B)]])
    period = 1.0 / terms.frequency[0, 0]
    for d in range(len(n)):
        x0 = np.concatenate([np.zeros(6), P.base_velocity[0, 0, d]])
        sol = solve_ivp(lambda t, y: A @ y, (0, 0.6 * period), x0, method="DOP853", rtol=1e-10, atol=1e-14,
                        dense_output=True)
        t = np.linspace(0, 0.6 * period, 4000)
        peak = np.linalg.norm(sol.sol(t)[:3], axis=0).max()
        assert P.structure_peak[0, 0, d] == pytest.approx(peak, rel=0.02)


def test_peak_amplitude_factor_is_the_damped_first_peak():
    zeta = 0.05
    t = np.linspace(0, np.pi, 200001)
    wd = np.sqrt(1 - zeta**2)
    x = np.exp(-zeta * t) * np.sin(wd * t) / wd
    assert peak_amplitude_factor(zeta) == pytest.approx(x.max(), rel=1e-8)
    assert peak_amplitude_factor(0.0) == 1.0


def test_cone_directions_lie_on_the_cone():
    axis = np.array([-1.0, 0.2, 0.1])
    n = cone_directions(axis, 25.0, 9)
    a = axis / np.linalg.norm(axis)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.degrees(np.arccos(np.clip(n[1:] @ a, -1, 1))), 25.0, rtol=1e-9)
    assert n.shape == (9, 3) and np.allclose(n[0], a)


# -- the planner and its CLI -------------------------------------------------------------
def test_planner_ranks_every_candidate_by_its_objective(puma, beam):
    p = impact_point(puma, configuration_q(1))
    pl = ImpactPlanner(puma, lambdas={"a": LAMBDAS[1], "b": LAMBDAS[2]}, mass=M_B, speed=V_B, restitution=E,
                       contact_stiffness=537.3, contact_exponent=0.737, beam=beam, objective="displacement")
    pl.fit(p, horizontal_directions(6))
    rows = pl.rows()
    assert len(rows) == pl.q_.shape[0] * 2 * 6
    peaks = [r["structure_peak"] for r in rows]
    assert peaks == sorted(peaks)
    assert any(np.allclose(q, configuration_q(1), atol=1e-7) for q in pl.q_)


def run(capsys, *argv):
    status = main(["plan", *argv])
    out, err = capsys.readouterr()
    return status, out, err


def test_cli_returns_all_branches_with_their_predictions(capsys, puma):
    q = np.radians([30.0, 60.0, -60.0])
    p = impact_point(puma, q)
    point = ",".join(f"{x:.12f}" for x in p)
    status, out, err = run(capsys, "--point", point, "--horizontal", "4", "--json")
    assert status == 0, err
    d = json.loads(out)
    branches = np.radians(d["branches_dh_deg"])
    assert len(branches) == position_branches(puma, p).n_branches == 4
    assert any(np.allclose(b, q, atol=1e-7) for b in branches)
    assert len(d["candidates"]) == 4 * 3 * 4   # branches x the paper's gain sets (zero, low, high) x directions
    # the default predicts with the shipped response model
    assert d["model"] == {"file": "config/response_model.json", "kind": "joint_impedance"}
    assert d["gain_sets"] == ["zero", "low", "high"]
    # with lambdas (the paper's Table 3 here) the candidates are eq 7's
    status, out, err = run(capsys, "--point", point, "--horizontal", "4", "--json", "--lambda", "zero_low=19.82,4.62,0.80",
                           "--lambda", "high=53.18,8.66,2.83")
    assert status == 0, err
    d = json.loads(out)
    c = d["candidates"][0]
    qb = np.radians(c["q_dh_deg"])
    lam = d["lambdas"][c["gain_class"]]
    assert c["m_eff"] == pytest.approx(exiit.effective_mass(puma, qb, c["direction"], lam), rel=1e-9)


@pytest.mark.parametrize("argv, needle", [
    (["--point", "2,0,0"], "out of the arm's reach"),
    (["--point", "-0.6,-0.15,-0.15", "--direction", "0,0,0"], "zero vector"),
    (["--point", "-0.6,-0.15,-0.15", "--mass", "-1"], "--mass -1"),
    (["--point", "-0.6,-0.15,-0.15", "--speed", "0"], "object speed"),
    (["--point", "-0.6,-0.15,-0.15", "--restitution", "1.5"], "restitution"),
    (["--point", "-0.6,-0.15,-0.15", "--objective", "displacement"], "--base flexible"),
    (["--point", "-0.6,-0.15,-0.15", "--lambda", "x=1,-2,0"], "lambda"),
    (["--point", "-0.6,-0.15", "--horizontal", "3"], "--point"),
    (["--point", "-0.6,-0.15,-0.15", "--fit", "/nonexistent/lambda.json"], "no such file"),
])
def test_cli_refuses_bad_input_in_one_line(capsys, argv, needle):
    status, out, err = run(capsys, *argv)
    assert status == 2 and out == ""
    assert needle in err and len(err.strip().splitlines()) == 1


def test_structure_peak_matches_the_rig_in_the_impulsive_limit(puma):
    """A passive arm (no gravity, friction or servo: lambda = 0) struck through a contact 100x
    stiffer than the calibrated one (~5 ms against the structure's ~230 ms period), the arm and
    structure integrated as one system: the regime eq 8 assumes. The rig's peak base
    displacement must match the prediction."""
    from campaign.rig.trial import simulate_arrays
    from campaign.scene.description import make_scene

    params = {"gravity": 0.0, "arm.coulomb_scale": 0.0, "arm.viscous_scale": 0.0, "ves.mode": "ideal"}
    sc0 = make_scene(base="flexible", config=1, gain="zero", speed=2.0, params=params)
    params["contact.stiffness"] = 100.0 * float(sc0.p("contact.stiffness"))
    sc = make_scene(base="flexible", config=1, gain="zero", speed=2.0, params=params)
    truth = simulate_arrays(sc)["truth"]
    measured = np.max(np.linalg.norm(truth["base_position"].values, axis=1))
    p = sc.p
    m_b = float(p("pendulum.head_mass")) + float(p("pendulum.rod_mass")) / 3.0
    contact = ContactLaw.from_scene(sc)
    P = predict(pose_terms(puma, configuration_q(1)[None], beam=Beam.from_scene(sc)), [[0.0, 0.0, 0.0]],
                [[-1.0, 0.0, 0.0]], mass=m_b, speed=2.0, restitution=float(p("contact.restitution")), contact=contact)
    assert P.structure_peak[0, 0, 0] == pytest.approx(measured, rel=0.06)


def test_cli_reads_a_campaign_fit_and_ranks_by_a_weighted_objective(capsys, tmp_path, puma):
    fit = tmp_path / "lambda_high.json"
    fit.write_text(json.dumps({"gain_class": "high", "gains": ["high"], "lambda": [40.0, 9.0, 3.0],
                               "units": {"lambda": "kg m^2"}}))
    p = impact_point(puma, configuration_q(2))
    status, out, err = run(capsys, "--point", ",".join(f"{x:.12f}" for x in p), "--cone", "-1,0,0,20",
                           "--count", "5", "--fit", str(fit), "--base", "flexible", "--objective", "weighted",
                           "--weights", "0,1,2", "--json")
    assert status == 0, err
    d = json.loads(out)
    assert d["lambdas"] == {"high": [40.0, 9.0, 3.0]}
    cands = d["candidates"]
    assert len(cands) == len(d["branches_dh_deg"]) * 5
    f = np.array([c["peak_force"] for c in cands])
    x = np.array([c["structure_peak"] for c in cands])
    score = f / f.max() + 2.0 * x / x.max()
    np.testing.assert_allclose([c["score"] for c in cands], score, rtol=1e-12)
    assert np.all(np.diff(score) >= 0)
