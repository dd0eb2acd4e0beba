"""The VES-II emulation loop: exact structure step, latency, platform bandwidth, static load."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from campaign.core.errors import InputError
from campaign.model.paper import configuration_q
from campaign.model.robot import load_robot
from campaign.model.robot.floating import attach_to_floating_base
from campaign.rig.beam import Beam
from campaign.rig.ves import (
    RECORD_WIDTH,
    STEP_WIDTH,
    PlatformServo,
    VesLoop,
    foh,
    platform_motion,
    zoh,
)
from campaign.scene.description import make_scene

RATE = 1000.0
#: these checks of the emulator's arithmetic are sized to the stiff mast's ~4.4 Hz first mode
#: (pulse lengths, record spans); the space-class structure's loop is checked below too
STIFF = {"flexible.structure": "stiff_mast"}


@pytest.fixture(scope="module")
def beam() -> Beam:
    return Beam.from_scene(make_scene(base="flexible", params=STIFF))


@pytest.fixture(scope="module")
def raised_beam() -> Beam:
    """A beam whose sensor sits 0.3 m above the tip, so the moment transfer is exercised."""
    return Beam(2.5e8, 20.0, 200.0, mount_height=0.3)


def _pulse(n: int, k_on: int, k_off: int, w) -> np.ndarray:
    out = np.zeros((n, 6))
    out[k_on:k_off] = w
    return out


# -- the structure step ------------------------------------------------------------------

def test_exact_step_matches_a_fine_rk45_solution_under_a_step_wrench(raised_beam):
    """Held wrench: the emulator's expm step vs RK45 of M x'' + B x' + K x = w (tip frame)."""
    b = raised_beam
    w_sensor = np.array([120.0, -60.0, 300.0, 8.0, -5.0, 3.0])     # force + moment at the sensor
    r = np.array([0.0, 0.0, b.mount_height])
    w_tip = np.concatenate([w_sensor[:3], w_sensor[3:] + np.cross(r, w_sensor[:3])])
    loop = VesLoop(b, RATE, 0.0, 30.0)
    loop.reset()
    n = 200
    rec = loop.run(np.tile(w_sensor, (n, 1)))
    Minv = np.linalg.inv(b.mass_matrix)
    A = np.block([[np.zeros((6, 6)), np.eye(6)], [-Minv @ b.stiffness, -Minv @ b.damping]])
    c = np.concatenate([np.zeros(6), Minv @ w_tip])

    def rhs(_, y):   # M x'' + B x' + K x = w
        return A @ y + c

    t_eval = (np.arange(n) + 1) / RATE
    sol = solve_ivp(rhs, (0.0, t_eval[-1]), np.zeros(12), method="RK45", t_eval=t_eval,
                    rtol=1e-12, atol=1e-16)
    assert sol.success
    scale = np.max(np.abs(sol.y[:6]), axis=1)
    err = np.max(np.abs(rec[:, 0:6] - sol.y[:6].T), axis=0) / scale
    assert np.all(err < 1e-8), err
    vscale = np.max(np.abs(sol.y[6:]), axis=1)
    assert np.all(np.max(np.abs(rec[:, 6:12] - sol.y[6:].T), axis=0) / vscale < 1e-8)
    # the step's fixed point is the static deflection K^-1 w, at rest
    s_inf = np.linalg.solve(np.eye(12) - loop.structure_Phi, loop.structure_Gamma @ w_sensor)
    np.testing.assert_allclose(s_inf[:6], b.deflection(w_tip), rtol=1e-9)
    assert np.max(np.abs(s_inf[6:])) < 1e-12


def test_free_response_decays_with_the_modal_damping_ratio(beam):
    """Log decrement of the first mode after a short pulse gives zeta within 2 %."""
    loop = VesLoop(beam, RATE, 0.0, 30.0)
    loop.reset()
    n = 2500
    rec = loop.run(_pulse(n, 0, 5, [2000.0, 0, 0, 0, 0, 0]))
    freq, phi = beam.modes()
    # modal coordinate of the x-bending first mode (modal damping decouples the modes)
    i1 = int(np.argmax([abs(phi[0, 0]), abs(phi[0, 1])]))
    eta = rec[:, 0:6] @ (beam.mass_matrix @ phi[:, i1])
    eta = eta[10:]
    peaks = []
    for k in range(1, len(eta) - 1):
        if eta[k] > eta[k - 1] and eta[k] >= eta[k + 1] and eta[k] > 0:
            a, b_, c = eta[k - 1], eta[k], eta[k + 1]
            peaks.append(b_ - 0.125 * (a - c) ** 2 / (a - 2 * b_ + c))   # parabolic peak value
    peaks = np.array(peaks)
    assert len(peaks) >= 8
    delta = np.log(peaks[0] / peaks[-1]) / (len(peaks) - 1)
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    assert zeta == pytest.approx(beam.damping_ratio, rel=0.02)


def test_static_load_is_removed(beam):
    """Microgravity emulation: the load measured at rest moves nothing."""
    w_static = np.array([3.0, -1.0, -230.0, 12.0, -40.0, 0.5])
    loop = VesLoop(beam, RATE, 0.002, 30.0)
    loop.reset(w_static)
    rec = loop.run(np.tile(w_static, (200, 1)))
    assert np.max(np.abs(rec)) < 1e-15
    # the same loop under an extra 10 N moves exactly like a loop reset with zero load
    ref = VesLoop(beam, RATE, 0.002, 30.0)
    ref.reset()
    extra = _pulse(200, 3, 40, [10.0, 0, 0, 0, 0, 0])
    r_ref = ref.run(extra)
    np.testing.assert_allclose(loop.run(w_static + extra), r_ref, rtol=0, atol=1e-12 * np.max(np.abs(r_ref)))


# -- latency and platform ------------------------------------------------------------------

@pytest.mark.parametrize("ticks", [1, 2, 7])
def test_latency_delays_by_exactly_n_ticks(beam, ticks):
    n = 400
    wrench = _pulse(n, 2, 30, [50.0, -20.0, 0, 0, 4.0, 0])
    base = VesLoop(beam, RATE, 0.0, 30.0)
    base.reset()
    r0 = base.run(wrench)
    late = VesLoop(beam, RATE, ticks / RATE, 30.0)
    late.reset()
    r1 = late.run(wrench)
    assert late.latency_ticks == ticks
    np.testing.assert_array_equal(r1[:, 0:12], r0[:, 0:12])        # the structure is not delayed
    # set-point and platform motion are the undelayed ones, N ticks later; zero before
    scale = np.max(np.abs(r0[:, 12:36]), axis=0)
    np.testing.assert_allclose(r1[ticks:, 12:36], r0[:-ticks, 12:36], rtol=0, atol=1e-12 * np.max(scale))
    assert np.all(r1[:ticks, 12:36] == 0.0)


def test_zero_latency_and_very_high_bandwidth_follow_the_structure(beam):
    loop = VesLoop(beam, RATE, 0.0, 1.0e5)
    loop.reset()
    n = 600
    rec = loop.run(_pulse(n, 0, 20, [80.0, 30.0, -50.0, 2.0, -3.0, 1.0]))
    x, xd, p, pd = rec[:, 0:6], rec[:, 6:12], rec[:, 12:18], rec[:, 18:24]
    np.testing.assert_array_equal(rec[:, 30:36], x)           # set-point = structure pose
    # the platform tracks the set-point ramp with the Butterworth's lag sqrt(2)/w_b (2.3 us)
    lag = math.sqrt(2.0) / (2 * math.pi * 1.0e5)
    slope = np.max(np.abs(np.diff(x, axis=0, prepend=0.0)), axis=0) * RATE
    assert np.all(np.max(np.abs(p - x), axis=0) <= 1.05 * lag * slope)
    assert np.max(np.abs(p[:, :2] - x[:, :2]) / np.max(np.abs(x[:, :2]), axis=0)) < 1e-4
    # its rate is the ramp's slope, the tick average of the structure's rate
    vscale = np.max(np.abs(xd), axis=0)
    assert np.all(np.max(np.abs(pd[1:] - np.diff(x, axis=0) * RATE), axis=0) < 1e-3 * vscale)
    # ... within a few % of the structure's rate for the first mode (bending, x and y)
    assert np.all(np.max(np.abs(pd[:, :2] - xd[:, :2]), axis=0) < 0.05 * vscale[:2])


@pytest.mark.parametrize("bandwidth", [10.0, 30.0, 60.0])
def test_platform_is_minus_3_db_at_its_bandwidth(bandwidth):
    servo = PlatformServo(bandwidth, RATE)
    n = 4000
    t = np.arange(n) / RATE
    cmd = np.zeros((n, 6))
    cmd[:, 0] = np.sin(2 * math.pi * bandwidth * t)
    cmd[:, 4] = 0.01 * np.sin(2 * math.pi * bandwidth * t)
    pos = servo.simulate(cmd)
    tail = slice(n // 2, n)
    basis = np.column_stack([np.sin(2 * math.pi * bandwidth * t[tail]), np.cos(2 * math.pi * bandwidth * t[tail])])
    for axis, amp in ((0, 1.0), (4, 0.01)):
        coef, *_ = np.linalg.lstsq(basis, pos[tail, axis], rcond=None)
        gain = np.hypot(*coef) / amp
        assert gain == pytest.approx(1 / math.sqrt(2), rel=0.02)
        assert 20 * math.log10(gain) == pytest.approx(-3.0, abs=0.2)
    assert servo.frequency_response(bandwidth) == pytest.approx(1 / math.sqrt(2), rel=1e-12)


def test_loop_platform_is_the_servo_driven_by_the_delayed_structure(beam):
    loop = VesLoop(beam, RATE, 0.003, 25.0)
    loop.reset()
    rec = loop.run(_pulse(300, 1, 15, [40.0, 0, 10.0, 0, 3.0, 1.0]))
    cmd = np.vstack([np.zeros((4, 6)), rec[:-3, 0:6]])     # x_{k+1-N}, N = 3, from rest
    servo = PlatformServo(25.0, RATE)
    np.testing.assert_allclose(servo.simulate(cmd)[1:], rec[:, 12:18], rtol=1e-9, atol=1e-18)


def test_platform_inside_a_tick(beam):
    loop = VesLoop(beam, RATE, 0.002, 30.0)
    loop.reset()
    w = _pulse(40, 0, 20, [60.0, 0, 0, 0, 5.0, 0])
    prev = None
    for k in range(40):
        st = loop.step(w[k])
        inside = {f: loop.platform_at(f) for f in (0.0, 0.25, 0.5, 0.75, 1.0)}
        step = np.array([st.pose, st.twist, st.accel])
        atol = 1e-10 * np.max(np.abs(step), axis=1, keepdims=True)
        assert np.all(np.abs(inside[1.0] - step) <= atol)
        if prev is not None:
            assert np.all(np.abs(inside[0.0] - prev) <= atol)   # continuous, acceleration included
        prev = inside[1.0].copy()
    # the closed form agrees with the matrix exponential of the servo
    servo = loop.servo
    Phi, G0, G1 = foh(servo.A, servo.B, servo.h, 0.37 * servo.h)
    C = servo.coefficients(0.37 * servo.h)
    np.testing.assert_allclose(C[0], [G1[0, 0], G0[0, 0], Phi[0, 0], Phi[0, 6]], rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(C[1], [G1[6, 0], G0[6, 0], Phi[6, 0], Phi[6, 6]], rtol=1e-10, atol=1e-10)
    with pytest.raises(InputError, match="fraction"):
        loop.platform_at(1.5)


def test_step_output_layout_and_out_argument(beam):
    loop = VesLoop(beam, RATE, 0.002, 30.0)
    loop.reset()
    hist = np.empty((5, STEP_WIDTH))
    states = [loop.step([10.0, 0, 0, 0, 0, 0], out=hist[k]) for k in range(5)]
    assert loop.tick == 5 and loop.time == pytest.approx(0.005)
    for k, st in enumerate(states):
        np.testing.assert_array_equal(st.structure_pose, hist[k, 0:6])
        np.testing.assert_array_equal(st.pose, hist[k, 12:18])
        np.testing.assert_array_equal(st.command, hist[k, 30:36])
        assert np.shares_memory(st.accel, hist)
    assert RECORD_WIDTH == 36


# -- closed loop through a rigid arm ---------------------------------------------------------

@pytest.fixture(scope="module")
def arm_inertia(beam):
    """Composite inertia of the PUMA 560 locked in configuration 2, at the tip frame."""
    frobot = attach_to_floating_base(load_robot(), beam.base_body())
    q = frobot.q_full(configuration_q(2))
    M = pin.crba(frobot.model, frobot.model.createData(), q)[:6, :6]
    return M - beam.mass_matrix


def test_default_loop_with_a_rigid_arm_is_stable_and_keeps_the_first_mode(beam, arm_inertia):
    scene = make_scene(base="flexible", params=STIFF)
    loop = VesLoop(beam, scene.p("ves.rate"), scene.p("ves.latency"), scene.p("ves.bandwidth"))
    freq, zeta = loop.closed_loop_poles(arm_inertia)
    assert np.all(zeta > 0)                                          # stable
    f_ideal = beam.first_mode_frequency(tip=arm_inertia)
    assert freq[0] == pytest.approx(f_ideal, rel=0.01)
    # the loop's delay shows as added damping of the first mode, m_a tau w / 2M-sized
    assert beam.damping_ratio < zeta[0] < 4 * beam.damping_ratio


def test_emulated_peak_displacement_after_an_impact_within_5_percent_of_ideal(beam, arm_inertia):
    """Rigid arm in configuration 2 hit by a 50 N, 20 ms half-sine at its tip along -x:
    default loop vs the exactly coupled linear system (M_s + M_a) x'' + B x' + K x = J^T F."""
    scene = make_scene(base="flexible", params=STIFF)
    frobot = attach_to_floating_base(load_robot(), beam.base_body())
    data = frobot.model.createData()
    pin.framesForwardKinematics(frobot.model, data, frobot.q_full(configuration_q(2)))
    r = np.array(data.oMf[frobot.impact_frame_id].translation)
    n = np.array([-1.0, 0.0, 0.0])
    w_dir = np.concatenate([n, np.cross(r, n)])         # wrench of a unit force along n, tip frame

    def force(t):
        return 50.0 * math.sin(math.pi * t / 0.02) if t < 0.02 else 0.0

    T = 0.5
    # ideal coupling: exact steps of 0.1 ms (force held at mid-step)
    M = beam.mass_matrix + arm_inertia
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((6, 6)), np.eye(6)], [-Minv @ beam.stiffness, -Minv @ beam.damping]])
    h = 1e-4
    Phi, Gam = zoh(A, np.vstack([np.zeros((6, 6)), Minv]), h)
    s = np.zeros(12)
    peak_ideal = 0.0
    for k in range(int(T / h)):
        s = Phi @ s + Gam @ (w_dir * force((k + 0.5) * h))
        peak_ideal = max(peak_ideal, abs(s[0]))
    # the loop: the F/T sample at t_k sees the impact wrench minus the arm's inertial reaction
    loop = VesLoop(beam, scene.p("ves.rate"), scene.p("ves.latency"), scene.p("ves.bandwidth"))
    loop.reset()
    a = np.zeros(6)
    peak_loop = 0.0
    for k in range(int(T * loop.rate)):
        st = loop.step(w_dir * force(k * loop.h) - arm_inertia @ a)
        a = st.accel.copy()
        peak_loop = max(peak_loop, abs(st.pose[0]))
    assert 1e-5 < peak_ideal < 1e-3                      # sub-millimetre: small-angle model
    assert peak_loop == pytest.approx(peak_ideal, rel=0.05)
    assert peak_loop < peak_ideal                        # the loop's delay damps


def test_too_much_bandwidth_with_latency_destabilises_the_loop(beam, arm_inertia):
    """The arm's inertial reaction comes back delayed: once the platform passes the
    torsion mode (~190 Hz) the loop goes unstable (why the default bandwidth is 30 Hz)."""
    freq, zeta = VesLoop(beam, RATE, 0.002, 100.0).closed_loop_poles(arm_inertia)
    assert np.min(zeta) < 0
    assert freq[np.argmin(zeta)] > 100.0


def test_closed_loop_matrix_reproduces_the_stepped_loop(beam, arm_inertia):
    loop = VesLoop(beam, RATE, 0.002, 30.0)
    loop.reset()
    A = loop.closed_loop_matrix(arm_inertia)
    a = np.zeros(6)
    z = np.zeros(A.shape[0])
    kick = np.array([100.0, 0, 0, 0, 0, 0])
    for k in range(60):
        w = -arm_inertia @ a + (kick if k == 0 else 0.0)
        st = loop.step(w)
        a = st.accel.copy()
        if k == 0:
            z = np.concatenate([loop._in[:24], np.zeros(12), st.structure_pose, a])
        else:
            z = A @ z
    np.testing.assert_allclose(z[:24], loop._in[:24], rtol=1e-9, atol=1e-18)
    np.testing.assert_allclose(z[-6:], a, rtol=1e-9, atol=1e-15)


# -- kinematics helper -------------------------------------------------------------------------

def test_platform_motion_to_pinocchio():
    pose = np.array([1e-3, -2e-3, 5e-4, 2e-3, -1e-3, 3e-3])
    twist = np.array([0.01, 0.02, -0.01, 0.05, 0.01, -0.02])
    accel = np.array([0.3, -0.1, 0.2, 1.0, -2.0, 0.5])
    M, v, a = platform_motion(pose, twist, accel)
    np.testing.assert_allclose(pin.log3(M.rotation), pose[3:], rtol=1e-12)
    np.testing.assert_allclose(M.translation, pose[:3])
    np.testing.assert_allclose(M.rotation @ v.linear, twist[:3], rtol=1e-12)
    # base-frame angular velocity: R(t)^T R(t + dt) = exp(omega dt)
    dt = 1e-7
    omega_fd = pin.log3(M.rotation.T @ pin.exp3(pose[3:] + twist[3:] * dt)) / dt
    np.testing.assert_allclose(v.angular, omega_fd, rtol=1e-5)
    # spatial acceleration + omega x v = the origin's classical acceleration, base axes
    np.testing.assert_allclose(a.linear + np.cross(v.angular, v.linear), M.rotation.T @ accel[:3], rtol=1e-12)


# -- bad input ------------------------------------------------------------------------------

def test_latency_longer_than_the_trial(beam):
    with pytest.raises(InputError, match=r"latency 2 s .*not shorter than the trial \(1\.5 s\)"):
        VesLoop(beam, RATE, 2.0, 30.0, duration=1.5)
    VesLoop(beam, RATE, 0.002, 30.0, duration=1.5)


def test_rate_below_ten_times_the_first_mode(beam):
    f1 = beam.first_mode_frequency()
    with pytest.raises(InputError, match=r"rate .*first-mode frequency") as err:
        VesLoop(beam, 5.0 * f1, 0.0, 30.0)
    assert f"{f1:.4g} Hz" in str(err.value) and "ves.rate" in str(err.value)
    VesLoop(beam, 10.0 * f1 * 1.001, 0.0, 30.0)


@pytest.mark.parametrize("bandwidth", [0.0, -30.0, float("nan"), float("inf"), "fast"])
def test_bad_bandwidth(beam, bandwidth):
    with pytest.raises(InputError, match=r"bandwidth \(ves\.bandwidth\)"):
        VesLoop(beam, RATE, 0.002, bandwidth)


@pytest.mark.parametrize("kwargs, needle", [
    (dict(rate=0.0), r"rate \(ves\.rate\)"),
    (dict(rate=-1000.0), r"rate \(ves\.rate\)"),
    (dict(latency=-0.001), r"latency \(ves\.latency\)"),
    (dict(latency=float("nan")), r"latency \(ves\.latency\)"),
])
def test_bad_rate_and_latency(beam, kwargs, needle):
    args = dict(rate=RATE, latency=0.002, bandwidth=30.0) | kwargs
    with pytest.raises(InputError, match=needle):
        VesLoop(beam, **args)


def test_bad_static_wrench(beam):
    loop = VesLoop(beam, RATE, 0.002, 30.0)
    with pytest.raises(InputError, match="static wrench"):
        loop.reset([1.0, 2.0])


@pytest.mark.parametrize("structure", ["stiff_mast", "space_class"])
def test_every_named_structure_gives_a_stable_default_loop_keeping_its_first_mode(structure):
    scene = make_scene(base="flexible", config=2, params={"flexible.structure": structure})
    beam = Beam.from_scene(scene)
    frobot = attach_to_floating_base(load_robot(), beam.base_body())
    M = pin.crba(frobot.model, frobot.model.createData(), frobot.q_full(configuration_q(2)))[:6, :6]
    arm = M - beam.mass_matrix
    loop = VesLoop(beam, scene.p("ves.rate"), scene.p("ves.latency"), scene.p("ves.bandwidth"))
    freq, zeta = loop.closed_loop_poles(arm)
    assert np.all(zeta > 0)
    assert freq[0] == pytest.approx(beam.first_mode_frequency(tip=arm), rel=0.01)
