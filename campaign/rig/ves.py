"""The VES-II emulation loop: F/T wrench -> structure model -> delayed, band-limited platform.

One emulator tick per :meth:`VesLoop.step`: the measured wrench (static load removed) is
held over the tick and drives the structure model ``M_s x'' + B x' + K x = w`` advanced
exactly (one precomputed matrix exponential); the computed pose reaches the platform
``latency`` later (whole ticks) through a second-order Butterworth position servo of
bandwidth ``f_b`` following a first-order-hold set-point. All of it is linear and
time-invariant, so a tick is one matrix-vector product. ``w_meas`` is the wrench of the arm
on the platform about the sensor origin (the mount); poses are the tip frame's
``(position, rotation vector)`` from its initial pose, small-angle.
:meth:`VesLoop.closed_loop_poles` checks a setting's stability against a rigid arm.

The loop's equations, its discretisation and what the delay does to the coupled modes:
user guide, *The rig*, section "The VES-II emulation loop" (``docs/rig.rst``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pinocchio as pin
import scipy.linalg as sla

from ..core.errors import InputError
from .beam import Beam, tip_inertia_matrix

__all__ = ["VesLoop", "PlatformServo", "PlatformState", "platform_motion", "zoh", "foh",
           "MIN_TICKS_PER_PERIOD", "RECORD_WIDTH", "RECORD_COLUMNS", "STEP_WIDTH"]

#: The emulator must sample the structure's first mode at least this often per period.
#: Nyquist (2) is the bare minimum for the wrench; a held wrench needs ~10 samples per
#: period before its half-tick delay (18 deg at 10) stops dominating the emulation error.
MIN_TICKS_PER_PERIOD = 10.0

#: Columns of one tick's record (the first ``RECORD_WIDTH`` entries of a step's output):
#: structure pose and twist, platform pose, twist and acceleration, platform command.
RECORD_COLUMNS = ("structure_pose", "structure_twist", "pose", "twist", "accel", "command")
RECORD_WIDTH = 6 * len(RECORD_COLUMNS)
#: Full width of a step's output: the record, then what :meth:`VesLoop.platform_at` needs
#: (set-point at the start of the tick, platform state at the start of the tick).
STEP_WIDTH = RECORD_WIDTH + 18

# output layout of a step: the record, then [set-point at t_k (6), platform state at t_k (12)]
_X, _XD, _P, _PD, _A, _C, _U0 = (slice(6 * i, 6 * i + 6) for i in range(7))
_PPREV = slice(42, 54)


class PlatformState(NamedTuple):
    """The emulated base after one tick (views into the step's output array).

    Attributes
    ----------
    pose, twist, accel : ndarray, shape (6,)
        The platform's actual (servoed) motion: position [m] and rotation vector [rad]
        from the initial pose, their rates [m/s, rad/s] and accelerations [m/s^2,
        rad/s^2]. This is what the arm feels.
    command : ndarray, shape (6,)
        Platform set-point at the end of the tick (the delayed structure pose) [m, rad].
    structure_pose, structure_twist : ndarray, shape (6,)
        The emulated structure's tip pose [m, rad] and rate [m/s, rad/s] (the emulated
        base motion of the trial).
    """

    pose: np.ndarray
    twist: np.ndarray
    accel: np.ndarray
    command: np.ndarray
    structure_pose: np.ndarray
    structure_twist: np.ndarray


def _state_view(out: np.ndarray) -> PlatformState:
    return PlatformState(out[_P], out[_PD], out[_A], out[_C], out[_X], out[_XD])


def zoh(A: np.ndarray, B: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of ``x' = A x + B u`` over ``h`` [s].

    Returns ``(Phi, Gamma)`` with ``x(h) = Phi x(0) + Gamma u`` for a constant ``u``, from
    ``expm([[A, B], [0, 0]] h)`` (Van Loan, IEEE TAC 23, 1978).
    """
    n, m = B.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = A, B
    E = sla.expm(big * h)
    return E[:n, :n], E[:n, n:]


def foh(A: np.ndarray, B: np.ndarray, h: float, tau: float | None = None):
    """Exact discretisation of ``x' = A x + B u`` for an input ramping linearly from ``u0``
    at ``t = 0`` to ``u1`` at ``t = h``, evaluated at ``tau`` (default ``h``).

    Returns ``(Phi, Gamma0, Gamma1)`` with ``x(tau) = Phi x(0) + Gamma0 u0 + Gamma1 u1``,
    from ``expm([[A, B, 0], [0, 0, I/h], [0, 0, 0]] tau)`` applied to ``(x0, u0, u1 - u0)``.
    """
    tau = h if tau is None else tau
    n, m = B.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n], big[:n, n:n + m] = A, B
    big[n:n + m, n + m:] = np.eye(m) / h
    E = sla.expm(big * tau)
    return E[:n, :n], E[:n, n:n + m] - E[:n, n + m:], E[:n, n + m:]


def _check_positive(name: str, value, units: str, key: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"VES {name} ({key}) must be a number > 0 {units}, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"VES {name} ({key}) must be a finite number > 0 {units}, got {value!r}")
    return v


class PlatformServo:
    """The Stewart platform as a per-axis second-order Butterworth position servo.

    ``p'' = w_b^2 (c - p) - sqrt(2) w_b p'`` on each of the six pose coordinates, with the
    set-point ``c`` ramping linearly between ticks; ``|H(j w_b)| = 1/sqrt(2)``.

    Parameters
    ----------
    bandwidth : float
        -3 dB frequency ``f_b`` [Hz], > 0 (``ves.bandwidth``).
    rate : float
        Set-point rate [Hz] (the emulator rate).

    Attributes
    ----------
    A, B : ndarray
        Continuous state matrices of the state ``(p, p')`` (12) and input ``c`` (6).
    Phi, Gamma0, Gamma1 : ndarray
        One tick: ``(p, p')_{k+1} = Phi (p, p')_k + Gamma0 c_k + Gamma1 c_{k+1}``.
    """

    def __init__(self, bandwidth: float, rate: float):
        self.bandwidth = _check_positive("bandwidth", bandwidth, "Hz", "ves.bandwidth")
        self.rate = _check_positive("rate", rate, "Hz", "ves.rate")
        self.h = 1.0 / self.rate
        wb = 2.0 * math.pi * self.bandwidth
        self.omega = wb
        I, Z = np.eye(6), np.zeros((6, 6))
        self.A = np.block([[Z, I], [-wb**2 * I, -math.sqrt(2.0) * wb * I]])
        self.B = np.vstack([Z, wb**2 * I])
        self.Phi, self.Gamma0, self.Gamma1 = foh(self.A, self.B, self.h)

    def accel_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Cs, Dc)`` with the acceleration ``p'' = Cs (p, p') + Dc c`` (6x12, 6x6)."""
        wb = self.omega
        Cs = np.hstack([-wb**2 * np.eye(6), -math.sqrt(2.0) * wb * np.eye(6)])
        return Cs, wb**2 * np.eye(6)

    def coefficients(self, tau: float) -> np.ndarray:
        """Closed-form servo response ``tau`` [s] into a tick, for every axis alike.

        With the set-point ramping from ``u0`` to ``u1`` over the tick (slope ``b = (u1 -
        u0)/h``), the error from the ramp's steady tracking ``x_p = u0 + b t - 2 zeta b /
        w_b`` is a free damped oscillation (``zeta = 1/sqrt(2)``, ``w_d = w_b zeta``)::

            e(t)  = exp(-zeta w_b t) (e0 cos w_d t + (e0' + zeta w_b e0) / w_d sin w_d t)
            e'(t) = exp(-zeta w_b t) (e0' cos w_d t - (w_b^2 e0 + zeta w_b e0') / w_d sin w_d t)

        and ``p'' = w_b^2 (u - p) - 2 zeta w_b p'``. No matrix exponential: cheap at any
        ``tau``, for the arm integrator's sub-steps and located events.

        Returns
        -------
        ndarray, shape (3, 4)
            Rows: pose, rate, acceleration; columns act on ``(u1, u0, p(0), p'(0))``.
        """
        wb, h = self.omega, self.h
        z = 1.0 / math.sqrt(2.0)
        sig, wd = z * wb, z * wb
        t = float(tau)
        E = math.exp(-sig * t)
        C, S = math.cos(wd * t), math.sin(wd * t)
        out = np.empty((3, 4))
        for j, (u1, u0, p0, v0) in enumerate(((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0),
                                              (0.0, 0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0))):
            b = (u1 - u0) / h
            e0 = p0 - u0 + 2.0 * z * b / wb
            ed0 = v0 - b
            e = E * (e0 * C + (ed0 + sig * e0) / wd * S)
            ed = E * (ed0 * C - (wb * wb * e0 + sig * ed0) / wd * S)
            p = u0 + b * t - 2.0 * z * b / wb + e
            v = b + ed
            u = u0 + b * t
            out[0, j], out[1, j], out[2, j] = p, v, wb * wb * (u - p) - 2.0 * z * wb * v
        return out

    def frequency_response(self, f) -> np.ndarray:
        """Continuous ``|H(j 2 pi f)|`` of the servo (no hold) [1]."""
        r = np.asarray(f, dtype=float) / self.bandwidth
        return 1.0 / np.sqrt(1.0 + r**4)

    def simulate(self, commands) -> np.ndarray:
        """Platform poses at the ticks for a set-point sequence ``commands`` (n, 6), from rest
        at ``commands[0]`` (a reference implementation for tests; the loop is faster)."""
        c = np.asarray(commands, dtype=float)
        s = np.concatenate([c[0], np.zeros(6)])
        out = np.empty_like(c)
        out[0] = s[:6]
        for k in range(len(c) - 1):
            s = self.Phi @ s + self.Gamma0 @ c[k] + self.Gamma1 @ c[k + 1]
            out[k + 1] = s[:6]
        return out


class VesLoop:
    """The VES-II emulator: one tick per :meth:`step`, a structure model under the measured
    wrench, a latency and a band-limited platform (user guide, *The rig*, "The VES-II
    emulation loop").

    Parameters
    ----------
    beam : Beam
        The emulated structure (``K``, ``B``, ``M_s``, mount height).
    rate : float
        Emulator rate ``1/h`` [Hz] (``ves.rate``); at least :data:`MIN_TICKS_PER_PERIOD`
        times the structure's first-mode frequency.
    latency : float
        Sensor-to-platform delay [s] (``ves.latency``), >= 0, rounded to whole ticks.
    bandwidth : float
        Platform -3 dB bandwidth [Hz] (``ves.bandwidth``), > 0.
    duration : float, optional
        Length of the trial [s]; when given, a latency that is not shorter is refused.

    Raises
    ------
    InputError
        Non-positive or non-finite rate or bandwidth, negative latency, a rate below
        ``MIN_TICKS_PER_PERIOD`` x the first mode, a latency not shorter than the trial.

    Examples
    --------
    >>> loop = VesLoop(Beam(2.5e8, 20.0, 200.0), rate=1000.0, latency=0.002, bandwidth=30.0)
    >>> state = loop.reset(w_static=[0, 0, -230.0, 0, 0, 0])
    >>> state = loop.step([1.0, 0, -230.0, 0, 0, 0])   # w_meas at tick 0
    >>> state.pose.shape
    (6,)
    """

    def __init__(self, beam: Beam, rate: float, latency: float, bandwidth: float, *,
                 duration: float | None = None):
        if not isinstance(beam, Beam):
            raise InputError(f"VES loop needs a Beam, got {type(beam).__name__}")
        self.beam = beam
        self.rate = _check_positive("rate", rate, "Hz", "ves.rate")
        try:
            lat = float(latency)
        except (TypeError, ValueError):
            raise InputError(f"VES latency (ves.latency) must be a number >= 0 s, got {latency!r}") from None
        if not (math.isfinite(lat) and lat >= 0):
            raise InputError(f"VES latency (ves.latency) must be a finite number >= 0 s, got {latency!r}")
        if duration is not None:
            dur = float(duration)
            if not (math.isfinite(dur) and dur > 0):
                raise InputError(f"trial duration must be a finite number > 0 s, got {duration!r}")
            if lat >= dur:
                raise InputError(f"VES latency {lat:g} s (ves.latency) is not shorter than the trial "
                                 f"({dur:g} s): the platform would never move")
        self.latency = lat
        self.servo = PlatformServo(bandwidth, self.rate)
        self.bandwidth = self.servo.bandwidth
        f1 = beam.first_mode_frequency()
        if self.rate < MIN_TICKS_PER_PERIOD * f1:
            raise InputError(
                f"VES rate {self.rate:g} Hz (ves.rate) is below {MIN_TICKS_PER_PERIOD:g} x the structure's "
                f"first-mode frequency {f1:.4g} Hz: the emulator cannot follow the structure; "
                f"use at least {MIN_TICKS_PER_PERIOD * f1:.4g} Hz")
        self.h = 1.0 / self.rate
        self.latency_ticks = int(round(lat * self.rate))
        self._build()
        self.reset()

    # -- precomputation --------------------------------------------------------------------
    def _build(self) -> None:
        b = self.beam
        M, K, B = b.mass_matrix, b.stiffness, b.damping
        Minv = np.linalg.inv(M)
        I, Z = np.eye(6), np.zeros((6, 6))
        A = np.block([[Z, I], [-Minv @ K, -Minv @ B]])
        Bu = np.vstack([Z, Minv])
        # wrench at the sensor (mount, h above the tip) -> wrench at the tip: m_tip = m + r x f
        T = np.eye(6)
        r = np.array([0.0, 0.0, b.mount_height])
        T[3:, :3] = pin.skew(r)
        self.structure_A, self.structure_Bu, self.wrench_to_tip = A, Bu, T
        Phi_s, Gam_s = zoh(A, Bu, self.h)
        Gam_s = Gam_s @ T
        self.structure_Phi, self.structure_Gamma = Phi_s, Gam_s
        sv = self.servo
        Cs, Dc = sv.accel_rows()

        # input vector layout: [s (12), p (12), w (6), u0 (6), u1 (6), 1]
        n_in = 43
        iS, iP, iW, iU0, iU1, iONE = slice(0, 12), slice(12, 24), slice(24, 30), slice(30, 36), slice(36, 42), 42
        # rows that express u0 and u1 in terms of the input vector
        U0 = np.zeros((6, n_in))
        U1 = np.zeros((6, n_in))
        if self.latency_ticks == 0:
            U0[:, 0:6] = I                       # x_k
            U1[:, iS] = Phi_s[:6]                # x_{k+1}, known at tick k
            U1[:, iW] = Gam_s[:6]
            # the -w_static column is filled by reset()
        else:
            U0[:, iU0] = I
            U1[:, iU1] = I
        G = np.zeros((STEP_WIDTH, n_in))
        G[_X.start:_XD.stop, iS] = Phi_s
        G[_X.start:_XD.stop, iW] = Gam_s
        Pn = np.zeros((12, n_in))                # platform state at the end of the tick
        Pn[:, iP] = sv.Phi
        Pn += sv.Gamma0 @ U0 + sv.Gamma1 @ U1
        G[_P.start:_PD.stop] = Pn
        G[_A] = Cs @ Pn + Dc @ U1
        G[_C] = U1
        G[_U0] = U0
        G[_PPREV, iP] = np.eye(12)
        self._G = G
        self._Gw = G[:, iW].copy()               # columns that multiply w (for -w_static)
        self._in = np.zeros(n_in)
        self._in[iONE] = 1.0
        self._within: dict[float, np.ndarray] = {}

    # -- running ---------------------------------------------------------------------------
    def reset(self, w_static=None) -> PlatformState:
        """Start a trial: structure and platform at rest at the initial pose.

        Parameters
        ----------
        w_static : array_like, shape (6,), optional
            The static wrench the F/T sensor reads before the impact (arm at rest under
            gravity), same convention as ``w_meas``; it is removed from every later
            measurement (microgravity emulation). Zero by default.

        Returns
        -------
        PlatformState
            The initial state (all zeros).
        """
        ws = np.zeros(6) if w_static is None else np.asarray(w_static, dtype=float)
        if ws.shape != (6,) or not np.all(np.isfinite(ws)):
            raise InputError(f"static wrench must be 6 finite values (force N, moment N m), got {w_static!r}")
        self.w_static = ws.copy()
        self._G[:, 42] = -self._Gw @ ws
        self._in[:42] = 0.0
        n = self.latency_ticks + 1
        self._ring = np.zeros((n, 6))
        self._j0 = 0                  # slot of x_{k-N}; x_{k+1-N} is in the next slot
        self.tick = 0
        self._last = np.zeros(STEP_WIDTH)
        return _state_view(self._last)

    @property
    def time(self) -> float:
        """Time of the loop's current state, ``tick * h`` [s]."""
        return self.tick * self.h

    def step(self, w_meas, out: np.ndarray | None = None) -> PlatformState:
        """Advance one emulator tick from ``t_k`` to ``t_{k+1}``.

        Parameters
        ----------
        w_meas : array_like, shape (6,)
            Wrench of the arm on the platform sampled at ``t_k`` (force [N], moment about
            the sensor origin [N m], platform axes), static load included.
        out : ndarray, shape (STEP_WIDTH,), optional
            C-contiguous float64 array to write the step's output into (e.g. a row of a
            preallocated history, whose first :data:`RECORD_WIDTH` columns are
            :data:`RECORD_COLUMNS`); a new array otherwise.

        Returns
        -------
        PlatformState
            Views into ``out``: the platform at ``t_{k+1}`` (acceleration approached from
            inside the tick), its set-point, and the structure's pose and rate.
        """
        out = self.advance(w_meas, out)
        return PlatformState(out[12:18], out[18:24], out[24:30], out[30:36], out[0:6], out[6:12])

    def advance(self, w_meas, out: np.ndarray | None = None) -> np.ndarray:
        """:meth:`step` without wrapping the output: the step's output array (``STEP_WIDTH``;
        the first :data:`RECORD_WIDTH` entries are :data:`RECORD_COLUMNS`). The VES loop's
        per-tick call (building the named views costs as much as the matrix product)."""
        buf = self._in
        buf[24:30] = w_meas
        N = self.latency_ticks
        if N:
            ring, j0 = self._ring, self._j0
            j1 = j0 + 1 if j0 < N else 0
            buf[30:36] = ring[j0]
            buf[36:42] = ring[j1]
        if out is None:
            out = np.empty(STEP_WIDTH)
        np.dot(self._G, buf, out=out)
        buf[0:24] = out[0:24]
        if N:
            ring[j0] = out[0:6]
            self._j0 = j1
        self.tick += 1
        self._last = out
        return out

    def run(self, wrenches) -> np.ndarray:
        """Step through a wrench sequence (n, 6) and return the records (n, RECORD_WIDTH)."""
        w = np.asarray(wrenches, dtype=float)
        hist = np.empty((len(w), STEP_WIDTH))
        for k in range(len(w)):
            self.step(w[k], out=hist[k])
        return hist[:, :RECORD_WIDTH]

    def closed_loop_matrix(self, arm_inertia) -> np.ndarray:
        """One-tick transition matrix of the loop closed through a rigid arm on the platform.

        A rigid arm of spatial inertia ``M_a`` at the tip frame (e.g. a locked arm's
        composite inertia) presses on the platform with ``-M_a a_p`` (gravity and the
        static load cancel); the F/T sensor samples that at each tick. This is the worst
        case of the real loop (a backdrivable arm shows less inertia to the base) and the
        tool to check that loop settings are stable and to read the emulation's effect on
        the structure's modes (:meth:`closed_loop_poles`).

        Parameters
        ----------
        arm_inertia : pinocchio.Inertia or (6, 6) array
            ``M_a``, tip frame.

        Returns
        -------
        ndarray, shape (n, n)
            Transition of ``(s, p, set-points in flight, a_p)``.
        """

        Ma = tip_inertia_matrix(arm_inertia)
        to_sensor = np.linalg.inv(self.wrench_to_tip)
        N = self.latency_ticks
        nr = 6 * (N + 1) if N else 0
        n = 24 + nr + 6
        ia = slice(24 + nr, n)
        Sel = np.zeros((43, n))           # stacked input vector as a function of the state
        Sel[0:24, 0:24] = np.eye(24)
        Sel[24:30, ia] = -to_sensor @ Ma
        if N:
            Sel[30:36, 24:30] = np.eye(6)     # oldest set-point in flight
            Sel[36:42, 30:36] = np.eye(6)
        O = self._G[:, :43].copy()
        O[:, 42] = 0.0                    # homogeneous: the static load cancels
        O = O @ Sel
        A = np.zeros((n, n))
        A[0:24] = O[0:24]
        if N:
            A[24:24 + 6 * N, 30:24 + nr] = np.eye(6 * N)   # shift the set-points in flight
            A[24 + 6 * N:24 + nr] = O[0:6]
        A[ia] = O[24:30]
        return A

    def closed_loop_poles(self, arm_inertia) -> tuple[np.ndarray, np.ndarray]:
        """Oscillatory poles of :meth:`closed_loop_matrix` as continuous-time equivalents.

        Returns
        -------
        freq : ndarray
            Natural frequencies ``|ln z| rate / 2 pi`` [Hz], ascending.
        zeta : ndarray
            Damping ratios ``-Re(ln z) / |ln z|`` [1]; negative means the loop is unstable.
        """
        z = np.linalg.eigvals(self.closed_loop_matrix(arm_inertia))
        z = z[(np.abs(z) > 1e-12) & (z.imag > 1e-12)]
        s = np.log(z) * self.rate
        freq = np.abs(s) / (2.0 * math.pi)
        zeta = -s.real / np.abs(s)
        order = np.argsort(freq)
        return freq[order], zeta[order]

    def platform_at(self, fraction: float) -> np.ndarray:
        """The platform inside the last tick, at ``t_k + fraction h`` (0 <= fraction <= 1).

        Exact for the servo model (same ramp set-point, closed form of
        :meth:`PlatformServo.coefficients`), for the arm integrator's sub-steps and located
        events; ``fraction = 1`` reproduces the step's output. Coefficients of recent
        fractions are cached.

        Returns
        -------
        ndarray, shape (3, 6)
            Rows: pose [m, rad], twist [m/s, rad/s], acceleration [m/s^2, rad/s^2].
        """
        C = self._within.get(fraction)
        if C is None:
            f = float(fraction)
            if not (0.0 <= f <= 1.0):
                raise InputError(f"fraction of the emulator tick must be in [0, 1], got {fraction!r}")
            C = self.servo.coefficients(f * self.h)
            if len(self._within) > 64:
                self._within.clear()
            self._within[fraction] = C
        # out[30:54] = [u1, u0, p(t_k), p'(t_k)], one 6-vector per row
        return C @ self._last[30:54].reshape(4, 6)


def platform_motion(pose, twist, accel) -> tuple[pin.SE3, pin.Motion, pin.Motion]:
    """Pinocchio placement and base-frame twist and acceleration of a small-angle state.

    Parameters
    ----------
    pose, twist, accel : array_like, shape (6,)
        ``(position, rotation vector)`` from the initial pose and its first and second time
        derivatives (a :class:`PlatformState`'s fields).

    Returns
    -------
    placement : pinocchio.SE3
        ``(exp3(theta), position)`` relative to the initial base pose.
    velocity, acceleration : pinocchio.Motion
        Spatial velocity and (classical-free) spatial acceleration in the moving base frame,
        as Pinocchio's free-flyer expects: ``v = R^T p'``, ``omega = J_r(theta) theta'``,
        ``a = R^T p'' - omega x v``, ``omega' = J_r(theta) theta''`` (the ``dJ_r/dt
        theta'`` term is second order in the small rotation and dropped).
    """
    pose, twist, accel = (np.asarray(a, dtype=float) for a in (pose, twist, accel))
    R = pin.exp3(pose[3:])
    Jr = pin.Jexp3(pose[3:])
    v = R.T @ twist[:3]
    w = Jr @ twist[3:]
    a = R.T @ accel[:3] - np.cross(w, v)
    wd = Jr @ accel[3:]
    return pin.SE3(R, pose[:3].copy()), pin.Motion(v, w), pin.Motion(a, wd)
