"""The frozen arm's emulator ticks in closed form (campaign.rig.linear_phase)."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pinocchio as pin
import pytest

from campaign.core.errors import InputError
from campaign.rig import build, simulate_arrays
from campaign.rig.controller import PID
from campaign.rig.integrate import integrate_trial
from campaign.rig.linear_phase import FrozenArm, neglected_wrench
from campaign.rig.trial import integration_args
from campaign.scene.description import make_scene


def _scene(linear, **more):
    return make_scene(base="flexible", config=2, gain="low", speed=2.5,
                      params={"flexible.structure": "space_class", "flexible.linear_phases": linear, **more})


@pytest.fixture(scope="module")
def both():
    """Configuration 2 Low on the space-class structure (its arm freezes 0.34 s after the
    touch and stays frozen: 85 % of the record), per tick and in closed form."""
    out = {}
    for linear in (False, True):
        rig = build(_scene(linear))
        traj = integrate_trial(rig.plant, rig.pid, **integration_args(rig))
        out[linear] = (rig, traj)
    return out


def test_closed_form_follows_the_per_tick_loop_over_the_frozen_phase(both):
    """Same ticks, same servo torques, the emulator's states within 1e-5 of their range and
    the sampled F/T force within 1e-4 of its swing (measured: 2e-6 and 1.1e-5): the closed
    form drops only second-order terms of the platform's motion (the twist's Coriolis and
    centrifugal wrench, rotation times acceleration, rotation squared times gravity; next
    test), about 1e-3 N here against a swing of about 100 N over the trial."""
    (rig0, tr0), (rig1, tr1) = both[False], both[True]
    t0, w0, rec0 = rig0.plant.ticks()
    t1, w1, rec1 = rig1.plant.ticks()
    np.testing.assert_array_equal(t0, t1)
    np.testing.assert_array_equal(tr0.t, tr1.t)
    np.testing.assert_array_equal(tr0.servo_tau, tr1.servo_tau)   # PID.held is update() op for op
    np.testing.assert_array_equal(tr0.x, tr1.x)                   # the arm is still in both
    # per 3-vector (translations, rotations of the structure, platform pose, set-point, twist),
    # relative to its largest component
    err = [np.max(np.abs(rec1[:, c:c + 3] - rec0[:, c:c + 3])) / np.max(np.abs(rec0[:, c:c + 3]))
           for c in range(0, rec0.shape[1], 3)]
    assert max(err) < 1e-5
    dw = np.max(np.abs(w1 - w0)[:, :3]) / np.ptp(w0[:, :3], axis=0).max()
    assert dw < 1e-4
    print(f"states {max(err):.2e}, F/T force {dw:.2e}")
    assert max(err) > 0             # it is a different computation, not the same one


def test_neglected_terms_are_second_order_and_small(both):
    rig, traj = both[True]
    plant = rig.plant
    frozen = next(iter(plant._frozen.values()))
    # the emulator's states at the ticks of the frozen phase (a fresh propagation from rest
    # plus a platform kick would not be the trial's): rebuild them from the record
    t, w, rec = plant.ticks()
    # the exact wrench against the affine one along the trial's own states
    n = frozen.n
    X = np.zeros((len(t), n))
    X[:, -1] = 1.0
    X[:, 12:18], X[:, 18:24] = rec[:, 6:12], rec[:, 18:24]      # platform pose and twist
    steps = np.array([h[2] for h in plant.history])
    X[:, 24:30] = steps[:, 24:30]                               # platform acceleration
    err, swing = neglected_wrench(frozen, X, every=25)
    assert swing > 1.0                                          # the arm is shaken by newtons
    assert err < 1e-4 * swing
    # second order: the same states at a tenth of the amplitude leave a hundredth of it
    small = X.copy()
    small[:, :-1] *= 0.1
    err_small, swing_small = neglected_wrench(frozen, small, every=25)
    assert swing_small == pytest.approx(0.1 * swing, rel=1e-6)
    assert err_small < 0.02 * err


def test_rest_is_a_fixed_point_and_the_first_mode_decays_as_the_loop_predicts(both):
    """The static load is removed (microgravity emulation), so rest stays rest; released from
    a bent structure, the energy of the structure decays period after period at the rate of
    the loop's first closed-loop pole computed independently from the arm's composite inertia
    (VesLoop.closed_loop_poles, Pinocchio's CCRBA) instead of the F/T model differences."""
    rig, _ = both[True]
    plant = rig.plant
    q = rig.plant.q0_arm
    frozen = FrozenArm(plant, q)
    rest = np.zeros(frozen.n)
    rest[-1] = 1.0
    assert np.max(np.abs(frozen.A_ @ rest - rest)) < 1e-9
    data = plant.robot.model.createData()
    pin.ccrba(plant.robot.model, data, q, np.zeros(plant.na))
    arm = plant.beam.base_body().mount.act(data.oYcrb[0])
    f, zeta = plant.loop.closed_loop_poles(np.asarray(arm.matrix()))
    # the closed form's own poles: closed through the inertia alone, the first bending pair at
    # the same frequency and damping; the gravity the tilted sensor sees softens it by ~0.1 %
    def first_pole(A):
        z = np.linalg.eigvals(A)
        z = z[(np.abs(z) > 1e-12) & (z.imag > 1e-12)]
        s = np.log(z) * plant.loop.rate
        k = int(np.argmin(np.abs(s)))
        return abs(s[k]) / (2 * math.pi), -s[k].real / abs(s[k])

    f_in, z_in = first_pole(FrozenArm(plant, q, pose_terms=False).A_)
    assert f_in == pytest.approx(f[0], rel=1e-6)
    assert z_in == pytest.approx(zeta[0], rel=1e-4)
    f_g, _ = first_pole(frozen.A_)
    assert 0 < 1 - f_g / f[0] < 3e-3
    # energy decay: bend the structure, release it, and read the peak displacement and
    # the structure's energy period after period once the higher modes have died out
    xi = rest.copy()
    xi[0] = 0.01
    K, M = plant.beam.stiffness, plant.beam.mass_matrix
    period = plant.loop.rate / f_g
    X = frozen.propagate(xi, int(9 * period))["X"]
    E = 0.5 * np.einsum("ki,ij,kj->k", X[:, 0:6], K, X[:, 0:6]) + 0.5 * np.einsum("ki,ij,kj->k", X[:, 6:12], M, X[:, 6:12])
    cuts = [int(round(i * period)) for i in range(3, 10)]
    amp = [np.abs(X[a:b, 0]).max() for a, b in pairwise(cuts)]
    energy = [E[a:b].max() for a, b in pairwise(cuts)]
    assert all(b < a for a, b in pairwise(energy))
    per_period = (amp[-1] / amp[0]) ** (1 / (len(amp) - 1))
    assert per_period == pytest.approx(math.exp(-2 * math.pi * zeta[0] / math.sqrt(1 - zeta[0] ** 2)), rel=0.01)


def test_pid_held_is_update_op_for_op():
    for P, D, I in ((5000.0, 40.0, 0.0), (500000.0, 4000.0, 1500.0), (0.0, 0.0, 0.0)):
        kw = dict(P=P, D=D, I=I, scale=1e-3, resolution=np.array([1e-4, 7.3e-5, 1.2e-4]),
                  tau_max=np.array([97.6, 186.4, 89.4]), tau_gc=np.array([0.0, 30.0, -5.0]),
                  q_ref=np.array([0.0, 0.3, -1.2]), period=1e-3)
        a, b = PID(**kw), PID(**kw)
        a.hold_static(np.array([1.0, 40.0, -3.0]))
        b.hold_static(np.array([1.0, 40.0, -3.0]))
        a.update(np.array([0.001, 0.29, -1.19]))
        b.update(np.array([0.001, 0.29, -1.19]))
        q = np.array([0.0123, 0.2871, -1.2044])
        tau, e_sum, e = a.held(q, 50)
        ref = np.array([b.update(q) for _ in range(50)])
        np.testing.assert_array_equal(tau, ref)
        a.set_state(e, e_sum[-1])
        np.testing.assert_array_equal(a.e_sum, b.e_sum)
        np.testing.assert_array_equal(a.e_prev, b.e_prev)


def test_the_stiff_mast_keeps_the_per_tick_path_and_the_space_class_uses_the_closed_form():
    stiff = make_scene(base="flexible", params={"flexible.structure": "stiff_mast"})
    space = make_scene(base="flexible", params={"flexible.structure": "space_class"})
    assert stiff.p("flexible.linear_phases") is False
    assert space.p("flexible.linear_phases") is True
    assert build(stiff).plant.linear_phases is False


def test_linear_phases_must_be_a_boolean():
    with pytest.raises(InputError, match="flexible.linear_phases"):
        build(_scene("yes"))


def test_measured_channels_agree_with_the_per_tick_path():
    a = simulate_arrays(_scene(False))
    b = simulate_arrays(_scene(True))
    ma, mb = a.groups["measured"], b.groups["measured"]
    for name in ("base_position", "ft_force", "q_enc", "f_piezo", "tau_cmd"):
        x, y = np.asarray(ma[name].values), np.asarray(mb[name].values)
        assert x.shape == y.shape
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-5 * max(1e-12, float(np.max(np.abs(x)))))
