"""The joint-dynamics tip-velocity model of the encoder method (arm_model="joint").

Scored against the simulator truth on rig trials at 1 kHz joint sampling; bounds are the
requirement (m* within 1 % at 1 kHz), not numbers copied from a run.
"""

from __future__ import annotations

import numpy as np
import pytest

from campaign.core.errors import InputError
from campaign.identify import IdentifyOptions, identify_trial

from synthetic_impact import truth_m_e, truth_m_impulse


@pytest.fixture(scope="module")
def slow_high_gain_1khz():
    """Configuration 2, High gains, 1.0 m/s at 1 kHz, both repeats: the smallest tip motion
    of the sweep (the tip gains ~15 mm/s, 1 % is 0.15 mm/s), where the tip-space model
    missed 1 % (+1.53 / -1.02 %)."""
    from campaign.rig.trial import simulate
    from campaign.scene.description import make_scene
    out = []
    for repeat in (0, 1):
        tree = simulate(make_scene(base="fixed", config=2, gain="high", speed=1.0, repeat=repeat,
                                   params={"sensors.joint_encoder_rate": 1000.0}))
        out.append((tree["measured"].to_dataset(), tree["truth"].to_dataset(), dict(tree.attrs)))
    return out


def test_joint_model_meets_1pct_on_the_slowest_high_gain_trials(puma, slow_high_gain_1khz):
    """The default (encoders at 1 kHz, joint-dynamics model): m* within 1 %, e within 0.5 %."""
    for measured, truth, attrs in slow_high_gain_1khz:
        r = identify_trial(measured, robot=puma, meta=attrs)
        assert not r.excluded, r.reason
        assert r.arm_velocity == "encoders"
        m_true, e_true = truth_m_e(measured, truth)
        assert abs(r.m_eff / m_true - 1) < 0.01, (attrs["repeat"], r.m_eff, m_true)
        assert abs(r.e / e_true - 1) < 0.005


def test_impulse_estimator_meets_1pct_against_its_own_truth(puma, slow_high_gain_1khz):
    """``m_eff_estimator="impulse"`` on the same rig trials (arm gravity, servo, friction,
    a ~70 ms contact): m* within 1 % of eq 11's impulsive-limit m* from the truth
    (:func:`synthetic_impact.truth_m_impulse`), the contact impulse from the pendulum within
    0.1 % of the true one, e the same as eq 10's. Eq 10's own target differs from it by more
    than the 1 % here (the test would not tell them apart otherwise)."""
    for measured, truth, attrs in slow_high_gain_1khz:
        r = identify_trial(measured, robot=puma, meta=attrs, options=IdentifyOptions(m_eff_estimator="impulse"))
        r10 = identify_trial(measured, robot=puma, meta=attrs)
        assert not r.excluded, r.reason
        assert (r.m_eff_estimator, r10.m_eff_estimator) == ("impulse", "eq10")
        m_true = truth_m_impulse(measured, truth, puma)
        assert abs(truth_m_e(measured, truth)[0] / m_true - 1) > 0.01
        assert abs(r.m_eff / m_true - 1) < 0.01, (attrs["repeat"], r.m_eff, m_true)
        assert abs(r.impulse_momentum / float(truth["impulse"]) - 1) < 1e-3
        assert r.e == r10.e


def test_joint_model_is_unbiased_with_noise_free_encoders(puma, slow_high_gain_1khz):
    """The model itself, without the encoders' noise and quantisation (the true joint
    angles sampled at 1 kHz): v'_a - v_a within 0.5 % (the 1 % budget is model + noise),
    and the viscous scale it finds is a physical one (positive, below its bound)."""
    from campaign.identify import trial
    from campaign.identify.joint_dynamics import joint_dynamics_fit
    captured = {}

    def spy(*args, info=None, **kw):
        d = {}
        out = joint_dynamics_fit(*args, info=d, **kw)
        captured.update(d)
        return out

    for measured, truth, attrs in slow_high_gain_1khz:
        m = measured.copy()
        tj = m["t_joint"].values
        tt = truth["t_truth"].values
        m["q_enc"] = (("t_joint", "joint"),
                      np.column_stack([np.interp(tj, tt, truth["q"].values[:, k]) for k in range(m.sizes["joint"])]))
        trial.joint_dynamics_fit = spy          # the name the driver calls
        try:
            r = identify_trial(m, robot=puma, meta=attrs)
        finally:
            trial.joint_dynamics_fit = joint_dynamics_fit
        dva = float(truth["v_a_post"]) - float(truth["v_a_pre"])
        assert abs((r.v_a_post - r.v_a) / dva - 1) < 0.005, (attrs["repeat"], r.v_a_post - r.v_a, dva)
        assert 0.0 < captured["viscous_scale"] < IdentifyOptions().joint_viscous_max
        assert captured["sd_delta"] > 0


def test_joint_model_beats_the_tip_space_model_on_these_trials(puma, slow_high_gain_1khz):
    """Worst m* error over the two trials: the joint model's is below the tip-space
    ``lti`` model's (the reason the default changed)."""
    worst = {}
    for model in ("joint", "lti"):
        errs = []
        for measured, truth, attrs in slow_high_gain_1khz:
            r = identify_trial(measured, robot=puma, meta=attrs, options=IdentifyOptions(arm_model=model))
            errs.append(abs(r.m_eff / truth_m_e(measured, truth)[0] - 1))
        worst[model] = max(errs)
    assert worst["joint"] < worst["lti"], worst


def test_joint_model_falls_back_to_lti_without_the_servo_channel(puma, slow_high_gain_1khz):
    """No ``tau_cmd``: the tip-space model is used (same result as asking for it)."""
    measured, _, attrs = slow_high_gain_1khz[0]
    bare = measured.drop_vars(["tau_cmd"])
    r = identify_trial(bare, robot=puma, meta=attrs)
    lti = identify_trial(measured, robot=puma, meta=attrs, options=IdentifyOptions(arm_model="lti"))
    assert not r.excluded, r.reason
    assert r.m_eff == pytest.approx(lti.m_eff, rel=1e-12)


@pytest.mark.parametrize("kw", [{"joint_coulomb": "viscous"}, {"joint_contact_steps": 0},
                                {"joint_model_post_min": 0.0}, {"arm_model": "joints"}])
def test_joint_model_options_are_checked(kw):
    with pytest.raises(InputError):
        IdentifyOptions(**kw)
