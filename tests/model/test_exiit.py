"""The Ex-IIT (eqs 7, 8, 11, 13, 14) against the paper, a closed form and independent routes.

Expected numbers are only the paper's published values (Tables 2 and 3); everything else is
checked against a hand-derived formula, an independent computation, or a property.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy.optimize import brentq

from campaign.model import exiit
from campaign.model.paper import configuration_q, impact_direction, load_paper
from campaign.model.robot.floating import BaseBody, attach_to_floating_base
from campaign.scene.description import load_rig

# The paper's published values (Yoshida, Mavroidis & Dubowsky, Tables 2 and 3).
PAPER_M1 = {1: 6.99, 2: 19.66, 3: 4.96}      # kg, eq 11 with lambda = 0
PAPER_M2 = {1: 12.98, 2: 38.14, 3: 8.91}     # kg, experiments, Zero and Low gains
PAPER_M3 = {1: 28.45, 2: 76.45, 3: 19.11}    # kg, experiments, High gains
PAPER_LAMBDA_ZERO_LOW = [19.82, 4.62, 0.80]  # kg m^2
PAPER_LAMBDA_HIGH = [53.18, 8.66, 2.83]      # kg m^2

N_PAPER = (-1.0, 0.0, 0.0)


# -- fixtures and strategies ----------------------------------------------------------
@pytest.fixture(scope="module")
def rig_base():
    """The flexible scene's base body: platform mass and inertia of config/rig.yaml."""
    params, _ = load_rig()
    return BaseBody(mass=params["flexible.platform_mass"], inertia=np.diag(params["flexible.platform_inertia"]))


@pytest.fixture(scope="module")
def puma_flex(puma, rig_base):
    return attach_to_floating_base(puma, rig_base)


@pytest.fixture(scope="module")
def puma_odd(puma, odd_base):
    return attach_to_floating_base(puma, odd_base)


@pytest.fixture(scope="module")
def planar_odd(planar, odd_base):
    return attach_to_floating_base(planar, odd_base)


def puma_q():
    """Joint angles inside the PUMA's limits (DH, rad), drawn per joint."""
    from campaign.model.robot import load_robot

    r = load_robot("puma560")
    return st.tuples(*(st.floats(float(lo), float(hi)) for lo, hi in zip(r.q_lower, r.q_upper, strict=True))).map(np.array)


lambdas = st.lists(st.floats(0.0, 100.0), min_size=3, max_size=3).map(np.array)
directions = (st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)
              .filter(lambda v: np.linalg.norm(v) > 0.1))


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(np.asarray(b)))


def test_config_holds_the_papers_values():
    """Table 2 and 3 of config/paper.yaml are the published numbers (the CLI reads them there)."""
    paper = load_paper()
    assert paper["table2"]["m1"] == PAPER_M1
    assert paper["table2"]["m2"] == PAPER_M2
    assert paper["table2"]["m3"] == PAPER_M3
    assert paper["table3"] == {"zero_low": PAPER_LAMBDA_ZERO_LOW, "high": PAPER_LAMBDA_HIGH}
    np.testing.assert_array_equal(impact_direction(), N_PAPER)


# -- the paper ------------------------------------------------------------------------
@pytest.mark.parametrize("config", [1, 2, 3])
def test_table2_m1_within_1p5_percent(puma, config):
    m = exiit.effective_mass(puma, configuration_q(config), N_PAPER)
    assert m == pytest.approx(PAPER_M1[config], rel=0.015)


@pytest.mark.parametrize("config", [1, 2, 3])
@pytest.mark.parametrize("lam, published", [(PAPER_LAMBDA_ZERO_LOW, PAPER_M2), (PAPER_LAMBDA_HIGH, PAPER_M3)],
                         ids=["m2-zero_low", "m3-high"])
def test_table3_lambda_reproduces_table2_m2_m3_within_5_percent(puma, config, lam, published):
    m = exiit.effective_mass(puma, configuration_q(config), N_PAPER, lam)
    assert m == pytest.approx(published[config], rel=0.05)


# -- eq 8 against the free-flyer model ---------------------------------------------------
@pytest.mark.parametrize("config", [1, 2, 3])
@pytest.mark.parametrize("lam", [None, PAPER_LAMBDA_HIGH, [5.0, 0.0, 1e3]], ids=["zero", "table3-high", "mixed"])
def test_eq8_equals_free_flyer_inverse_inertia(puma_flex, config, lam):
    q = configuration_q(config)
    G8 = exiit.exiit_floating(puma_flex, q, lam)
    Gd = exiit.exiit_floating_direct(puma_flex, q, lam)
    assert rel_err(G8, Gd) < 1e-9


@given(q=puma_q(), lam=lambdas, rpy=st.tuples(*[st.floats(-np.pi, np.pi)] * 3),
       xyz=st.tuples(*[st.floats(-5.0, 5.0)] * 3), zero=st.booleans())
def test_eq8_equals_free_flyer_on_any_base_and_pose(puma_odd, q, lam, rpy, xyz, zero):
    """Off-centre base COM, tilted mount, any base pose: eq 8 (centroid, R_gh, M) == J M^-1 J^T."""
    pose = pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))
    lam = None if zero else lam
    G8 = exiit.exiit_floating(puma_odd, q, lam, base_pose=pose)
    Gd = exiit.exiit_floating_direct(puma_odd, q, lam, base_pose=pose)
    assert rel_err(G8, Gd) < 1e-9


def test_eq8_equals_free_flyer_for_the_planar_arm(planar_odd):
    rng = np.random.default_rng(3)
    for q in rng.uniform(-3.0, 3.0, size=(20, 2)):
        for lam in (None, rng.uniform(0.0, 2.0, size=2)):
            assert rel_err(exiit.exiit_floating(planar_odd, q, lam), exiit.exiit_floating_direct(planar_odd, q, lam)) < 1e-9


# -- the planar two-link arm in closed form ----------------------------------------------
# planar2 (campaign/robot/planar2): point masses m1 at the end of link 1 (length l1) and m2
# at the end of link 2 (length l2, the tip), each with a rotational inertia I about z, direct
# drives with rotor inertia a1, a2 (G = 1), joints about z.
M1, M2, L1, L2, I_LINK, A1, A2 = 2.0, 1.0, 0.5, 0.4, 1e-9, 0.01, 0.005


def planar_m_eff(q1, q2, n, lam):
    """m* = 1 / (u^T (H + lambda)^-1 u), u = J^T n, everything written out by hand.

    H11 = m1 l1^2 + m2 (l1^2 + l2^2 + 2 l1 l2 cos q2) + 2 I + a1
    H12 = m2 (l2^2 + l1 l2 cos q2) + I
    H22 = m2 l2^2 + I + a2
    J (tip, x and y rows) = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12]]
    (H + lambda)^-1 of a 2x2 matrix A = adj(A) / det(A), so
    m* = det(A) / (A22 u1^2 - 2 A12 u1 u2 + A11 u2^2).
    """
    nx, ny, _ = np.asarray(n, float) / np.linalg.norm(n)
    s1, c1, s12, c12, c2 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2), np.cos(q2)
    A11 = M1 * L1**2 + M2 * (L1**2 + L2**2 + 2 * L1 * L2 * c2) + 2 * I_LINK + A1 + lam[0][0]
    A12 = M2 * (L2**2 + L1 * L2 * c2) + I_LINK + lam[0][1]
    A22 = M2 * L2**2 + I_LINK + A2 + lam[1][1]
    u1 = nx * (-L1 * s1 - L2 * s12) + ny * (L1 * c1 + L2 * c12)
    u2 = nx * (-L2 * s12) + ny * (L2 * c12)
    return (A11 * A22 - A12**2) / (A22 * u1**2 - 2 * A12 * u1 * u2 + A11 * u2**2)


def test_planar_arm_matches_its_closed_form(planar):
    rng = np.random.default_rng(2024)
    for _ in range(200):
        q = rng.uniform(-3.1, 3.1, size=2)
        n = rng.normal(size=3)
        d = rng.uniform(0.0, 3.0, size=2)
        off = rng.uniform(-1.0, 1.0) * np.sqrt(d[0] * d[1])   # keeps a full lambda PSD
        for lam in (np.zeros((2, 2)), np.diag(d), np.array([[d[0], off], [off, d[1]]])):
            expected = planar_m_eff(q[0], q[1], n, lam)
            assert exiit.effective_mass(planar, q, n, lam) == pytest.approx(expected, rel=1e-10)


def test_planar_arm_batch_matches_its_closed_form(planar):
    rng = np.random.default_rng(11)
    Q = rng.uniform(-3.1, 3.1, size=(300, 2))
    n, lam = (0.3, -0.8, 0.5), np.array([0.2, 0.7])
    expected = [planar_m_eff(q1, q2, n, np.diag(lam)) for q1, q2 in Q]
    np.testing.assert_allclose(exiit.effective_mass_batch(planar, Q, n, lam), expected, rtol=1e-10)


# -- inf where n leaves the range ------------------------------------------------------
@pytest.mark.parametrize("q1", [0.0, 0.3, 1.234, -2.5])
def test_stretched_planar_arm_is_infinitely_heavy_along_itself(planar, planar_odd, q1):
    q = np.array([q1, 0.0])
    along = (np.cos(q1), np.sin(q1), 0.0)
    assert exiit.effective_mass(planar, q, along) == np.inf
    assert exiit.effective_mass_batch(planar, q[None], along)[0] == np.inf
    assert exiit.effective_mass(planar, q, (0.0, 0.0, 1.0)) == np.inf        # out of the plane
    # just off the singularity it is finite (the test is not vacuous) ...
    assert np.isfinite(exiit.effective_mass(planar, q + [0.0, 1e-3], along))
    # ... and a free base moves the tip along the arm, so there m* is finite again
    assert np.isfinite(exiit.effective_mass(planar_odd, q, along))


def puma_elbow_singularity(puma):
    """Arm horizontal (q2 = 0), elbow straightened until J_lin is singular; n = the lost direction."""
    model, data = puma.model, puma.model.createData()

    def jac(q3):
        return exiit.impact_jacobian(model, data, np.array([0.0, 0.0, q3]), puma.impact_frame_id)[:3]

    q3 = brentq(lambda x: np.linalg.det(jac(x)), np.radians(-90.0), np.radians(-75.0), xtol=1e-15)
    U, _, _ = np.linalg.svd(jac(q3))
    return np.array([0.0, 0.0, q3]), U[:, 2]


def test_puma_at_its_elbow_singularity_is_infinitely_heavy(puma):
    q, n = puma_elbow_singularity(puma)
    assert exiit.effective_mass(puma, q, n) == np.inf
    assert exiit.effective_mass_batch(puma, np.array([q, configuration_q(1)]), n)[0] == np.inf
    assert exiit.effective_mass(puma, q, n, PAPER_LAMBDA_HIGH) == np.inf
    assert np.isfinite(exiit.effective_mass(puma, q, N_PAPER))


def test_zero_inverse_inertia_gives_inf_not_a_division_error():
    assert exiit.effective_mass_from_G(np.zeros((6, 6)), N_PAPER) == np.inf


# -- properties -------------------------------------------------------------------------
@given(q=puma_q(), lam=lambdas)
def test_exiit_is_symmetric_positive_semidefinite(puma, puma_flex, q, lam):
    for G in (exiit.exiit_fixed(puma, q, lam), exiit.exiit_floating(puma_flex, q, lam)):
        scale = np.max(np.abs(G))
        assert np.max(np.abs(G - G.T)) <= 1e-12 * scale
        assert np.min(np.linalg.eigvalsh(0.5 * (G + G.T))) >= -1e-12 * scale


@given(q=puma_q(), lam=lambdas, extra=lambdas, n=directions)
def test_m_eff_never_decreases_when_lambda_grows(puma, puma_flex, q, lam, extra, n):
    for robot in (puma, puma_flex):
        small = exiit.effective_mass(robot, q, n, lam)
        large = exiit.effective_mass(robot, q, n, lam + extra)
        assert large >= small * (1 - 1e-10)


@given(q=puma_q(), lam=lambdas, n=directions)
def test_flexible_base_m_eff_never_exceeds_fixed(puma, puma_flex, q, lam, n):
    fixed = exiit.effective_mass(puma, q, n, lam)
    flexible = exiit.effective_mass(puma_flex, q, n, lam)
    assert flexible <= fixed * (1 + 1e-10)


@given(q=puma_q(), n=directions)
def test_flexible_base_tends_to_the_composite_rigid_body(puma_flex, q, n):
    """lambda -> inf locks the joints: the arm and base move as one rigid body of inertia M."""
    _, (_, _, R_gh, M) = exiit.exiit_floating(puma_flex, q, None, parts=True)
    u = n / np.linalg.norm(n)
    m_crb = 1.0 / (u @ (R_gh @ np.linalg.solve(M, R_gh.T))[:3, :3] @ u)
    # independently: the CRBA base block is the locked system's inertia at the base frame
    model, data = puma_flex.model, puma_flex.model.createData()
    qf = puma_flex.q_full(q)
    Mb = exiit.inertia(model, data, qf)[:6, :6]
    Jb = exiit.impact_jacobian(model, data, qf, puma_flex.impact_frame_id)[:3, :6]
    assert m_crb == pytest.approx(1.0 / (u @ Jb @ np.linalg.solve(Mb, Jb.T) @ u), rel=1e-9)

    previous = 0.0
    for big in (1e3, 1e6, 1e9):
        m = exiit.effective_mass(puma_flex, q, n, [big] * 3)
        assert previous <= m <= m_crb * (1 + 1e-12)
        previous = m
    assert m == pytest.approx(m_crb, rel=1e-6)


@given(q=puma_q(), n=directions)
def test_fixed_base_m_eff_grows_without_bound(puma, q, n):
    m0 = exiit.effective_mass(puma, q, n)
    assume(np.isfinite(m0))
    ms = [exiit.effective_mass(puma, q, n, [big] * 3) for big in (1e4, 1e6, 1e8)]
    assert m0 < ms[0] < ms[1] < ms[2]
    assert ms[2] / ms[1] > 50.0     # m* ~ lambda for lambda -> inf: no finite limit


# -- batch ------------------------------------------------------------------------------
def test_batch_equals_scalar(puma):
    rng = np.random.default_rng(5)
    Q = rng.uniform(puma.q_lower, puma.q_upper, size=(300, 3))
    q_sing, n_sing = puma_elbow_singularity(puma)
    cases = ((N_PAPER, None), (rng.normal(size=3), rng.uniform(0, 50, size=3)), (n_sing, PAPER_LAMBDA_HIGH))
    for n, lam in cases:
        QQ = np.vstack([Q, q_sing])
        batch = exiit.effective_mass_batch(puma, QQ, n, lam)
        scalar = np.array([exiit.effective_mass(puma, q, n, lam) for q in QQ])
        np.testing.assert_array_equal(np.isinf(batch), np.isinf(scalar))
        np.testing.assert_allclose(batch[np.isfinite(batch)], scalar[np.isfinite(scalar)], rtol=1e-12)
    assert np.isinf(batch[-1])


def test_batch_rejects_a_wrong_shape(puma):
    with pytest.raises(ValueError, match=r"Q must have shape \(N, 3\), got \(4, 2\)"):
        exiit.effective_mass_batch(puma, np.zeros((4, 2)))


# -- eqs 13 and 14 ----------------------------------------------------------------------
@given(m_eff=st.floats(0.1, 1e3), m_b=st.floats(0.05, 10.0), v_a=st.floats(-2.0, 2.0),
       v_b=st.floats(-3.0, 3.0), e=st.floats(0.0, 1.0))
def test_post_impact_velocity_and_impulse_satisfy_eqs_10_and_12(m_eff, m_b, v_a, v_b, e):
    va2 = exiit.post_impact_velocity(m_eff, m_b, v_a, v_b, e)
    p = exiit.impulse(m_eff, m_b, v_a, v_b, e)
    vb2 = v_b - p / m_b                                   # eq 10, the hammer's side
    assert p == pytest.approx(m_eff * (va2 - v_a), rel=1e-9, abs=1e-12)     # eq 10, the arm's side
    assert va2 - vb2 == pytest.approx(e * (v_b - v_a), rel=1e-9, abs=1e-12)  # eq 12


def test_an_infinitely_heavy_arm_is_a_wall():
    assert exiit.post_impact_velocity(np.inf, 0.4, 0.0, 2.0, 0.55) == 0.0
    assert exiit.impulse(np.inf, 0.4, 0.0, 2.0, 0.55) == pytest.approx(1.55 * 0.4 * 2.0, rel=1e-15)
    np.testing.assert_array_equal(exiit.post_impact_velocity([np.inf, 5.0], 0.4, 0.1, 2.0, 0.5)[0], 0.1)


# -- input checks -------------------------------------------------------------------------
@pytest.mark.parametrize("lam, message", [
    ([1.0, 2.0], "lambda has 2 values, the arm has 3 joints"),
    ([1.0, -2.0, 0.0], r"lambda = \[1.0, -2.0, 0.0\] must be >= 0"),
    ([1.0, np.nan, 0.0], r"lambda = \[1.0, nan, 0.0\] must be finite"),
    ([[1.0, 2.0, 0], [0, 1.0, 0], [0, 0, 1.0]], "must be symmetric"),
    ([[1.0, 2.0, 0], [2.0, 1.0, 0], [0, 0, 1.0]], "must be positive semi-definite"),
])
def test_bad_lambda_is_named(puma, lam, message):
    with pytest.raises(ValueError, match=message):
        exiit.effective_mass(puma, configuration_q(1), N_PAPER, lam)


def test_full_lambda_matrix_equals_its_diagonal_vector(puma):
    q = configuration_q(2)
    assert exiit.effective_mass(puma, q, N_PAPER, np.diag(PAPER_LAMBDA_HIGH)) == pytest.approx(
        exiit.effective_mass(puma, q, N_PAPER, PAPER_LAMBDA_HIGH), rel=1e-14)


@pytest.mark.parametrize("n, message", [((0.0, 0.0, 0.0), "is the zero vector"),
                                        ((1.0, 0.0), "must be 3 finite numbers"),
                                        ((np.nan, 1.0, 0.0), "must be 3 finite numbers")])
def test_bad_direction_is_named(puma, n, message):
    with pytest.raises(ValueError, match=message):
        exiit.effective_mass(puma, configuration_q(1), n)
