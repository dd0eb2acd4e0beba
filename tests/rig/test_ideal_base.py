"""Ideal coupling: the beam's wrench on the free-flyer base (Pinocchio), static load removed."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest

from campaign.core.errors import InputError
from campaign.model.paper import configuration_q
from campaign.model.robot import load_robot
from campaign.model.robot.floating import attach_to_floating_base
from campaign.rig.beam import Beam
from campaign.rig.ideal_base import IdealBase, static_arm_wrench
from campaign.scene.description import make_scene

G = np.array([0.0, 0.0, -9.81])


@pytest.fixture(scope="module")
def beam() -> Beam:
    # sized to the stiff mast's ~4.4 Hz first mode (0.5 s records hold a few periods)
    return Beam.from_scene(make_scene(base="flexible", params={"flexible.structure": "stiff_mast"}))


@pytest.fixture(scope="module")
def puma():
    return load_robot()


def _locked(frobot, q_arm, gravity=(0.0, 0.0, 0.0)):
    """The free-flyer with every arm joint locked at ``q_arm``: one rigid body (base + arm)."""
    q0 = frobot.q_full(q_arm)
    arm_joints = [frobot.model.getJointId(n) for n in frobot.robot.joint_names]
    model = pin.buildReducedModel(frobot.model, arm_joints, q0)
    model.gravity.linear = np.asarray(gravity, dtype=float)
    return model


def _rk4(model, ib: IdealBase, q, v, dt, n, record):
    data = model.createData()
    tau = np.zeros(model.nv)

    def acc(qq, vv):
        fext = pin.StdVec_Force()
        fext.append(pin.Force.Zero())
        fext.append(ib.wrench(qq, vv))
        return pin.aba(model, data, qq, vv, tau, fext)

    out = []
    for _ in range(n):
        a1 = acc(q, v)
        q2, v2 = pin.integrate(model, q, v * dt / 2), v + a1 * dt / 2
        a2 = acc(q2, v2)
        q3, v3 = pin.integrate(model, q, v2 * dt / 2), v + a2 * dt / 2
        a3 = acc(q3, v3)
        q4, v4 = pin.integrate(model, q, v3 * dt), v + a3 * dt
        a4 = acc(q4, v4)
        q = pin.integrate(model, q, (v + 2 * v2 + 2 * v3 + v4) * dt / 6)
        v = v + (a1 + 2 * a2 + 2 * a3 + a4) * dt / 6
        out.append(record(q, v))
    return np.array(out)


def test_locked_arm_oscillates_at_the_beams_first_mode_with_that_tip_body(beam, puma):
    """Arm locked in configuration 2 on the ideally coupled base: the small free oscillation of
    the Pinocchio free-flyer under IdealBase matches the beam's first mode with the arm's
    composite inertia on the tip (tip model and exact continuous beam) within 1 %."""
    undamped = dataclasses.replace(beam, damping_ratio=0.0)
    frobot = attach_to_floating_base(puma, undamped.base_body())
    model = _locked(frobot, configuration_q(2))
    arm = model.inertias[1] - undamped.spatial_inertia          # composite of the locked arm, tip frame
    assert arm.mass == pytest.approx(sum(i.mass for i in puma.model.inertias), rel=1e-12)
    freq, phi = undamped.modes(tip=arm)
    f_model = freq[0]
    # initial condition: 1 mm along the first mode shape
    shape = phi[:, 0] / np.max(np.abs(phi[:2, 0])) * 1e-3
    q0 = np.concatenate([shape[:3], pin.Quaternion(pin.exp3(shape[3:])).coeffs()])
    ib = IdealBase(undamped)
    axis = int(np.argmax(np.abs(shape[:2])))
    dt, T = 5e-4, 0.5
    x = _rk4(model, ib, q0, np.zeros(6), dt, int(T / dt), lambda q, v: ib.displacement(q)[axis])
    t = dt * (np.arange(len(x)) + 1)
    crossings = [t[j] - x[j] * dt / (x[j + 1] - x[j]) for j in range(len(x) - 1) if x[j] * x[j + 1] < 0]
    assert len(crossings) >= 4
    f_sim = 0.5 / np.mean(np.diff(crossings))
    assert f_sim == pytest.approx(f_model, rel=0.01)
    assert f_sim == pytest.approx(f_model, rel=1e-3)
    # the continuous beam with that tip body (platform + arm, planar, on the axis)
    f_exact = min(undamped.exact_first_frequency(arm.mass, arm.inertia[k, k], arm.lever[2]) for k in (0, 1))
    assert f_sim == pytest.approx(f_exact, rel=0.01)


def test_static_load_is_held_under_gravity(beam, puma):
    """Gravity on, arm holding its pose: the base stays where it is (microgravity emulation)."""
    frobot = attach_to_floating_base(puma, beam.base_body())
    q_arm = configuration_q(1)
    q = frobot.q_full(q_arm)
    model = frobot.model.copy()
    model.gravity.linear = G
    data = model.createData()
    v = np.zeros(model.nv)
    tau_hold = pin.rnea(model, data, q, v, v)                      # joint torques that hold the arm
    tau_hold[:6] = 0.0
    w_static = static_arm_wrench(puma, q_arm, G, mount=frobot.base.mount)
    ib = IdealBase(beam, w_static=w_static, gravity=G)
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    fext[1] = ib.wrench(q[:7], v[:6])
    a = pin.aba(model, data, q, v, tau_hold, fext)
    assert np.max(np.abs(a)) < 1e-9
    # w_static is the arm's wrench on the base that RNEA finds (root wrench minus base weight)
    tau = pin.rnea(model, data, q, v, v)
    body = beam.spatial_inertia
    weight = np.concatenate([body.mass * G, np.cross(body.lever, body.mass * G)])
    np.testing.assert_allclose(w_static, -tau[:6] - weight, rtol=1e-10, atol=1e-9)


def test_small_displacement_and_velocity_give_minus_K_x_and_minus_B_v(beam):
    ib = IdealBase(beam)
    dx = np.array([1e-4, -2e-4, 5e-6, 3e-5, -1e-5, 2e-5])
    q = np.concatenate([dx[:3], pin.Quaternion(pin.exp3(dx[3:])).coeffs()])
    w = ib.wrench_array(q, np.zeros(6))
    f = -beam.stiffness @ dx
    np.testing.assert_allclose(w, f, rtol=1e-3, atol=1e-3 * np.max(np.abs(f)))
    v = np.array([1e-3, 2e-3, -1e-3, 1e-2, 5e-3, -2e-3])
    w = ib.wrench_array(np.array([0, 0, 0, 0, 0, 0, 1.0]), v)
    np.testing.assert_allclose(w, -beam.damping @ v, rtol=1e-12)
    force = ib.wrench(q, v)
    assert isinstance(force, pin.Force)
    assert ib.potential(q) == pytest.approx(0.5 * dx @ beam.stiffness @ dx, rel=1e-3)


def test_undamped_beam_conserves_energy_at_large_rotation(beam, puma):
    """The wrench is the exact virtual-work image of -K x: no energy drift even at 0.05 rad
    beyond the integrator's (applying -K x as a base-frame wrench drifts by 2e-3 here)."""
    stiff = dataclasses.replace(beam, damping_ratio=0.0)
    frobot = attach_to_floating_base(puma, stiff.base_body())
    model = _locked(frobot, configuration_q(1))
    data = model.createData()
    ib = IdealBase(stiff)
    x0 = np.array([0.02, -0.01, 0.0, 0.05, 0.03, -0.05])
    q0 = np.concatenate([x0[:3], pin.Quaternion(pin.exp3(x0[3:])).coeffs()])

    def energy(q, v):
        return pin.computeKineticEnergy(model, data, q, v) + ib.potential(q)

    e0 = energy(q0, np.zeros(6))
    e = _rk4(model, ib, q0, np.zeros(6), 1e-4, 600, energy)
    assert np.max(np.abs(e / e0 - 1)) < 1e-5


def test_bad_input(beam, puma):
    with pytest.raises(InputError, match="static wrench"):
        IdealBase(beam, w_static=[1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="gravity"):
        IdealBase(beam, gravity=[0.0, float("nan"), -9.81])
    with pytest.raises(InputError, match="Beam"):
        IdealBase("beam")
    w = static_arm_wrench(puma, configuration_q(2), G)
    assert w[2] == pytest.approx(-9.81 * sum(i.mass for i in puma.model.inertias))
    assert math.isclose(w[5], 0.0, abs_tol=1e-12)                  # weight has no moment about z
