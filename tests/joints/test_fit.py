"""Lambda fit (campaign.joints.lambda_fit.LambdaFit): recovery, confidence intervals, identifiability."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from campaign.core.errors import InputError
from campaign.identify import IdentifyOptions, identify_trial
from campaign.joints.lambda_fit import (
    IdentifiabilityWarning,
    LambdaFit,
    design_arrays,
    sensitivity_matrix,
)
from campaign.model.exiit import effective_mass_batch
from campaign.model.paper import configuration_q, impact_direction, load_paper

from synthetic_impact import cached_trial, truth_m_e, truth_m_impulse

LAM = np.array(load_paper()["table3"]["zero_low"])  # paper Table 3 [kg m^2]


@pytest.fixture(scope="module")
def Q3():
    return np.array([configuration_q(c) for c in (1, 2, 3)])


def test_paper_design_sensitivity(puma, Q3):
    """With the paper's configurations and n = -x, lambda_3 dominates d ln m*/d ln lambda
    by more than an order of magnitude and the matrix is badly conditioned."""
    H, Jn = design_arrays(puma, Q3, impact_direction())
    S = sensitivity_matrix(H, Jn, LAM)
    assert S[:, 2].min() > 10 * max(S[:, 0].max(), S[:, 1].max())
    assert np.linalg.cond(S) > 100
    # against a finite difference of eq 11
    h = 1e-6
    for j in range(3):
        lp = LAM.copy()
        lp[j] *= 1 + h
        fd = (np.log(effective_mass_batch(puma, Q3, lam=lp)) - np.log(effective_mass_batch(puma, Q3, lam=LAM))) / np.log1p(h)
        np.testing.assert_allclose(S[:, j], fd, rtol=1e-4, atol=1e-9)


def test_recovery_and_honest_warnings_on_the_paper_design(puma, Q3):
    """Noisy eq-11 masses at the paper's three configurations: lambda_3 within 5 %, every
    CI covers the truth, lambda_1 and lambda_2 flagged as not identifiable."""
    rng = np.random.default_rng(1)
    Q = np.repeat(Q3, 10, axis=0)
    m = effective_mass_batch(puma, Q, lam=LAM) * np.exp(rng.normal(0, 0.01, Q.shape[0]))
    with pytest.warns(IdentifiabilityWarning):
        f = LambdaFit(puma, n_bootstrap=100, random_state=0).fit(Q, m)
    assert f.lambda_[2] == pytest.approx(LAM[2], rel=0.05)
    assert np.all((f.lambda_ci_[0] <= LAM) & (LAM <= f.lambda_ci_[1])), f.lambda_ci_
    assert list(f.identifiable_) == [False, False, True]
    assert f.condition_number_ > 100
    assert f.n_trials_ == 30 and f.sensitivity_.shape == (3, 3) and f.residuals_.shape == (30,)
    assert any("lambda_1" in w for w in f.warnings_) and any("lambda_2" in w for w in f.warnings_)
    np.testing.assert_allclose(f.predict(Q3), effective_mass_batch(puma, Q3, lam=LAM), rtol=0.02)


def test_well_posed_design_recovers_every_component(puma):
    """Configurations that rotate the arm about joint 1 and bend joints 2-3 make every
    component identifiable: all within 3 %, no warning."""
    rng = np.random.default_rng(2)
    Q = np.column_stack([rng.uniform(-1.2, 1.2, 40), rng.uniform(2.0, 3.0, 40), rng.uniform(-0.9, 0.7, 40)])
    m = effective_mass_batch(puma, Q, lam=LAM) * np.exp(rng.normal(0, 0.003, 40))
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        f = LambdaFit(puma, n_bootstrap=40, random_state=0).fit(Q, m)
    np.testing.assert_allclose(f.lambda_, LAM, rtol=0.03)
    assert f.identifiable_.all()


def test_full_structure_is_symmetric_psd(puma):
    rng = np.random.default_rng(3)
    Q = np.column_stack([rng.uniform(-1.2, 1.2, 40), rng.uniform(2.0, 3.0, 40), rng.uniform(-0.9, 0.7, 40)])
    true = np.array([[20.0, 1.0, 0.0], [1.0, 5.0, 0.3], [0.0, 0.3, 0.8]])
    m = effective_mass_batch(puma, Q, lam=true)
    f = LambdaFit(puma, structure="full", n_bootstrap=0, warn=False).fit(Q, m)
    assert f.lambda_.shape == (3, 3)
    np.testing.assert_allclose(f.lambda_, f.lambda_.T)
    assert np.linalg.eigvalsh(f.lambda_).min() >= -1e-9
    np.testing.assert_allclose(f.predict(Q), m, rtol=1e-3)


#: (joint-encoder rate, m* estimator) of the full lambda-recovery requirement: the paper's
#: 50 Hz (identification by the tip-space ``lti`` model) with either estimator, and 1 kHz
#: (the joint-space model built with the nominal arm inertia, which lacks the lambda the
#: trials carry) with the impulse estimator. Not 1 kHz with eq 10 (measured): eq
#: 10's m*, which identification reproduces (tests below), sits +0.4 .. +1.1 % above eq 11
#: on these trials' 40 ms contacts -- the pendulum's gravity impulse during the contact
#: (+0.34 .. +0.54 %) and the arm's Jacobian change over it (J(q_e) against J(q_s), up to
#: +0.75 %, growing with speed) -- and at 1 kHz the bootstrap CIs are narrow enough
#: (lambda_3 about +-1 %) to exclude the truth; the missing lambda in the joint model is not
#: the cause (test_joint_model_is_not_biased_by_the_lambda_its_nominal_model_lacks). The
#: impulse estimator (campaign.identify, m_eff_estimator="impulse") removes both; with eq
#: 10 at 1 kHz the tests below ask what holds: lambda_3 within 5 % and CIs that cover the
#: lambda of eq 10's own target
RECOVERY_CASES = ((50.0, "eq10"), (50.0, "impulse"), (1000.0, "impulse"))


def _lambda_trials(joint_rate, **kw):
    """The lambda-recovery design: configurations 1-3 x 1.2/1.8/2.4 m/s x 2 repeats, the
    paper's lambda as extra armature, no friction or servo (``decay="none"``)."""
    seed = 300
    for config in (1, 2, 3):
        for speed in (1.2, 1.8, 2.4):
            for repeat in range(2):
                seed += 1
                yield config, cached_trial(config=config, speed=speed, decay="none", lam=tuple(LAM), seed=seed,
                                           repeat=repeat, joint_rate=joint_rate, **kw)


@pytest.fixture(scope="module")
def identified_lambda_trials(puma):
    """``(rate, estimator) -> [(config, trial, identification)]``, default options but for
    ``m_eff_estimator``, identified once per pair for the tests below (18 trials: ~1 s
    each at 1 kHz, where the joint model serves)."""
    cache = {}

    def get(rate, estimator="eq10"):
        if (rate, estimator) not in cache:
            opt = IdentifyOptions(m_eff_estimator=estimator)
            cache[rate, estimator] = [(config, tr, identify_trial(tr.measured, robot=puma, options=opt))
                                      for config, tr in _lambda_trials(rate)]
        return cache[rate, estimator]

    return get


def _fit_identified(puma, rows):
    Q, m = [], []
    for _, _, r in rows:
        assert not r.excluded, r.reason
        Q.append(r.q_cmd)
        m.append(r.m_eff)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        return LambdaFit(puma, n_bootstrap=60, random_state=0).fit(np.array(Q), np.array(m))


@pytest.mark.parametrize(("joint_rate", "estimator"), RECOVERY_CASES)
def test_lambda_recovery_from_identified_synthetic_trials(puma, Q3, identified_lambda_trials, joint_rate, estimator):
    """End to end: trials simulated with a known lambda as extra armature (no friction or
    servo), identified from their measured channels (default options, the given
    ``m_eff_estimator``), fitted: lambda_3 within 5 %, CIs cover all three true values,
    eq 11 with the fitted lambda predicts every cell's mean identified m* within 5 %.
    (:data:`RECOVERY_CASES`: why 1 kHz with eq 10 is not asked this.)"""
    rows = identified_lambda_trials(joint_rate, estimator)
    assert all(r.m_eff_estimator == estimator for _, _, r in rows)
    cells = {}
    for config, _, r in rows:
        cells.setdefault(config, []).append(r.m_eff)
    f = _fit_identified(puma, rows)
    assert f.lambda_[2] == pytest.approx(LAM[2], rel=0.05)
    assert np.all((f.lambda_ci_[0] <= LAM) & (LAM <= f.lambda_ci_[1])), (f.lambda_, f.lambda_ci_)
    pred = f.predict(Q3)
    for k, config in enumerate((1, 2, 3)):
        assert pred[k] == pytest.approx(np.mean(cells[config]), rel=0.05)


def test_eq10_at_1khz_recovers_lambda3_and_is_unbiased_against_its_own_target(puma, identified_lambda_trials):
    """1 kHz with the default eq 10: lambda_3 within 5 %, and the CIs cover all three
    components of the lambda fitted to the *true* eq-10 m* of the same trials (their true
    edge velocities): identification adds no bias of its own; what separates eq 10's lambda
    from the truth is its target, which sits above eq 11 on every one of these finite
    contacts (:data:`RECOVERY_CASES`)."""
    rows = identified_lambda_trials(1000.0)
    f = _fit_identified(puma, rows)
    assert f.lambda_[2] == pytest.approx(LAM[2], rel=0.05)
    Q, m10 = [], []
    for _, tr, r in rows:
        m_true = truth_m_e(tr.measured, tr.tree["truth"].to_dataset())[0]
        assert m_true > tr.truth["m_eff_eq11"]
        Q.append(r.q_cmd)
        m10.append(m_true)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        target = LambdaFit(puma, n_bootstrap=0).fit(np.array(Q), np.array(m10)).lambda_
    assert np.all((f.lambda_ci_[0] <= target) & (target <= f.lambda_ci_[1])), (target, f.lambda_ci_)


def test_identified_m_eff_of_the_lambda_trials_at_1khz_is_eq10_within_1pct(identified_lambda_trials):
    """What identification is asked for at 1 kHz (m* within 1 %), on the
    lambda-recovery trials: every trial's m* within 1 % of eq 10 on its true edge
    velocities, e within 0.5 % -- so the 1 kHz recovery's miss with eq 10 is eq 10 against
    eq 11, not the identification."""
    for _, tr, r in identified_lambda_trials(1000.0):
        assert not r.excluded, r.reason
        assert r.arm_velocity == "encoders"
        m_true, e_true = truth_m_e(tr.measured, tr.tree["truth"].to_dataset())
        assert abs(r.m_eff / m_true - 1) < 0.01, (tr.truth["contact_start"], r.m_eff, m_true)
        assert abs(r.e / e_true - 1) < 0.005


def test_impulse_estimator_at_1khz_meets_its_own_truth(puma, identified_lambda_trials):
    """The impulse estimator on the 1 kHz lambda-recovery trials, per trial: m* within 1 %
    of its own target (:func:`synthetic_impact.truth_m_impulse`, which on these impulsive
    trials is eq 11 itself), the contact impulse it takes from the pendulum within 0.1 % of
    the true one (the gravity impulse it removes is 0.34-0.54 % of it), and the edge
    velocities and e the same as eq 10's, bit for bit."""
    for (_, tr, r), (_, _, r10) in zip(identified_lambda_trials(1000.0, "impulse"),
                                       identified_lambda_trials(1000.0), strict=True):
        assert not r.excluded, r.reason
        truth = tr.tree["truth"].to_dataset()
        m_true = truth_m_impulse(tr.measured, truth, puma)
        assert m_true == pytest.approx(tr.truth["m_eff_eq11"], rel=1e-4)
        assert abs(r.m_eff / m_true - 1) < 0.01, (tr.truth["contact_start"], r.m_eff, m_true)
        assert abs(r.impulse_momentum / tr.truth["impulse"] - 1) < 1e-3, (r.impulse_momentum, tr.truth["impulse"])
        assert (r.v_a, r.v_a_post, r.v_b, r.v_b_post, r.e) == (r10.v_a, r10.v_a_post, r10.v_b, r10.v_b_post, r10.e)


def test_joint_model_is_not_biased_by_the_lambda_its_nominal_model_lacks(puma, monkeypatch):
    """The 1 kHz default (joint-space model with the nominal arm inertia) on noise-free
    encoders: the same trials (seed, contact phase) with and without lambda as extra
    armature give the same relative error in v'_a - v_a within 0.1 % (a tenth of the 1 %
    target): the generalised impulses are fitted per joint, so an inertia the model lacks
    does not enter the tip velocity over the 1 kHz window."""
    from campaign.identify import trial
    from campaign.identify.joint_dynamics import joint_dynamics_fit

    calls = []

    def spy(*args, **kw):
        calls.append(1)
        return joint_dynamics_fit(*args, **kw)

    monkeypatch.setattr(trial, "joint_dynamics_fit", spy)     # the name the driver calls
    for config, seed in ((1, 303), (2, 309), (3, 315)):
        err = []
        for lam in (tuple(LAM), (0.0, 0.0, 0.0)):
            tr = cached_trial(config=config, speed=1.8, decay="none", lam=lam, seed=seed, joint_rate=1000.0,
                              encoder_noise_counts=0.0, quantize=False)
            r = identify_trial(tr.measured, robot=puma)
            assert not r.excluded, r.reason
            err.append((r.v_a_post - r.v_a) / (tr.truth["v_a_post"] - tr.truth["v_a_pre"]) - 1)
        assert abs(err[0] - err[1]) < 1e-3, (config, err)
    assert len(calls) == 6          # the joint model did the work, not a fallback


def test_bad_input_is_named(puma, Q3):
    with pytest.raises(InputError, match="m_eff"):
        LambdaFit(puma, n_bootstrap=0).fit(Q3, [1.0, -2.0, 3.0])
    with pytest.raises(InputError, match="shape"):
        LambdaFit(puma, n_bootstrap=0).fit(Q3[:, :2], [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="structure"):
        LambdaFit(puma, structure="banded").fit(Q3, [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="not fitted"):
        LambdaFit(puma).predict(Q3)


def test_sklearn_protocol(puma):
    f = LambdaFit(puma, n_bootstrap=5)
    assert f.get_params()["n_bootstrap"] == 5
    assert f.set_params(n_bootstrap=7) is f and f.n_bootstrap == 7
    with pytest.raises(InputError):
        f.set_params(alpha=1)
