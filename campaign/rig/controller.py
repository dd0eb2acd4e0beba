"""The digital joint servo of the VES-II's PUMA: a PID per joint in controller counts.

At every servo tick ``t_k = k T`` the controller reads the joint encoders (quantised to
counts), and holds until the next tick (zero-order hold) the torque

    u_k   = P e_k + D (e_k - e_{k-1}) / T + I T sum_{i<=k} e_i   [controller units]
    tau_k = sat( s u_k + tau_gc, +-tau_max )                      [N m]

with ``e`` the position error in encoder counts, the derivative the encoder rate in
counts per second (count difference over one tick) and the integral in count-seconds
(running sum of counts times the period), ``s`` the documented torque per controller unit
(``controller.torque_per_unit``) and ``tau_gc`` the constant gravity-compensation torque
``g(q_cmd)`` the paper applied for Zero and Low gains. With counts ``c = q / r`` (``r`` rad
per count) the equivalent continuous gains are ``Kp = s P / r``, ``Kd = s D / r``,
``Ki = s I / r``. The paper's "counts" do not say how D and I are normalised; this
convention (an assumption, stated in ``config/rig.yaml``) gives High gains the ratio
``Kd / Kp = 8 ms`` of a well-damped position servo.

:func:`check_stability` refuses, before any simulation, a gain set whose discrete closed
loop (ZOH, per joint, linearised about the commanded pose) is unstable at the servo rate.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..model.paper import gain_counts

__all__ = ["PID", "check_stability", "equivalent_gains", "joint_gains"]


def equivalent_gains(P, D, I, *, scale, resolution, period):
    """Continuous-time equivalents (Kp [N m/rad], Kd [N m s/rad], Ki [N m/(rad s)]) per joint."""
    r = np.asarray(resolution, dtype=float)
    return scale * P / r, scale * D / r, scale * I / r


def joint_gains(gain: str, *, values: Mapping[str, Any], robot,
                overrides: Mapping[str, Mapping[str, float]] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The servo of a gain set of the paper's Table 1 in joint units: ``(Kp [N m/rad],
    Kd [N m s/rad], Ki [N m/(rad s)])`` per joint, from its controller counts
    (:func:`campaign.model.paper.gain_counts`, with ``overrides``), the rig values
    ``controller.torque_per_unit`` and ``controller.servo_rate`` and the robot's encoder
    resolution (:func:`equivalent_gains`)."""
    P, D, I = gain_counts(gain, overrides)
    kp, kd, ki = equivalent_gains(P, D, I, scale=float(values["controller.torque_per_unit"]),
                                  resolution=robot.encoder_resolution,
                                  period=1.0 / float(values["controller.servo_rate"]))
    return np.asarray(kp, float), np.asarray(kd, float), np.asarray(ki, float)


def check_stability(inertia, viscous, *, P, D, I, scale, resolution, period, joint_names):
    """Raise InputError if the sampled PID loop of any joint is unstable.

    Each joint is linearised as ``I_j qdd = -b_j qd + tau`` (its diagonal inertia at the
    commanded pose, viscous friction, no Coulomb friction or coupling), discretised exactly
    with a zero-order hold at the servo period, and closed with the counts PID above. The
    spectral radius of the closed loop must be < 1.
    """
    Kp, Kd, Ki = equivalent_gains(P, D, I, scale=scale, resolution=resolution, period=period)
    worst = 0.0
    for j, name in enumerate(joint_names):
        # exact zero-order-hold discretisation of qdd = (-b qd + tau) / I (closed form)
        beta, T = viscous[j] / inertia[j], period
        if beta * T > 1e-8:
            phi = -np.expm1(-beta * T) / beta          # (1 - exp(-beta T)) / beta
            Ad = np.array([[1.0, phi], [0.0, 1.0 - beta * phi]])
            Bd = np.array([[(T - phi) / beta], [phi]]) / inertia[j]
        else:
            Ad = np.array([[1.0, T], [0.0, 1.0]])
            Bd = np.array([[0.5 * T * T], [T]]) / inertia[j]
        # state z = [q, qd, q_prev, integral]; error e = -q (reference 0), counts folded into
        # the gains: tau = Kp e + Kd (e - e_prev) / T + Ki T sum e   (e in rad)
        kp, kd, ki = Kp[j], Kd[j] / period, Ki[j] * period
        # integral update s_k = s_{k-1} + e_k, with e_k = -q_k
        # tau_k = -(kp + kd + ki) q_k + kd q_{k-1} + ki s_{k-1}
        K = np.array([[-(kp + kd + ki), 0.0, kd, ki]])
        Acl = np.zeros((4, 4))
        Acl[:2, :2] = Ad
        Acl[:2, :] += Bd @ K
        Acl[2, 0] = 1.0               # q_prev <- q
        Acl[3, 0], Acl[3, 3] = -1.0, 1.0  # s <- s - q
        rho = float(np.max(np.abs(np.linalg.eigvals(Acl))))
        worst = max(worst, rho)
        marginal = ki == 0 and kp == 0 and kd == 0
        if not marginal and rho >= 1.0 + 1e-12:
            raise InputError(
                f"PID gains P={P}, D={D}, I={I} are unstable at the servo rate {1.0 / period:g} Hz on joint "
                f"{name} (closed-loop spectral radius {rho:.4f} >= 1; Kp={Kp[j]:.4g} N m/rad, "
                f"Kd={Kd[j]:.4g} N m s/rad, Ki={Ki[j]:.4g} N m/(rad s), inertia {inertia[j]:.4g} kg m^2)"
            )
    return worst


@dataclasses.dataclass
class PID:
    """Per-joint counts PID with zero-order hold, saturation and constant gravity compensation.

    Parameters
    ----------
    P, D, I : float
        Gains in the paper's controller counts (Table 1).
    scale : float
        Torque per controller unit [N m].
    resolution : ndarray
        Encoder resolution [rad per count].
    tau_max : ndarray
        Saturation [N m].
    tau_gc : ndarray
        Constant gravity-compensation torque [N m] (zeros when not applied).
    q_ref : ndarray
        Commanded joint angles [rad].
    period : float
        Servo period T [s].
    quantize : bool
        Read the encoders in whole counts (a real servo does; off in the ideal scene).
    """

    P: float
    D: float
    I: float
    scale: float
    resolution: np.ndarray
    tau_max: np.ndarray
    tau_gc: np.ndarray
    q_ref: np.ndarray
    period: float
    quantize: bool = True

    def __post_init__(self):
        self._ref_counts = self.q_ref / self.resolution
        self.e_prev = np.zeros_like(self.q_ref)
        self.e_sum = np.zeros_like(self.q_ref)
        self.active = bool(self.P or self.D or self.I)
        # per-tick constants: torque per count, per count/s of rate, per count-second
        self._kP = self.scale * self.P
        self._kD = self.scale * self.D / self.period
        self._kI = self.scale * self.I * self.period
        self._ref = np.rint(self._ref_counts) if self.quantize else self._ref_counts
        self._lo = -np.asarray(self.tau_max, dtype=float)
        # the per-joint constants as Python floats for update() (see there)
        self._joints = list(zip(np.asarray(self.resolution, dtype=float).tolist(), self._ref.tolist(),
                                np.asarray(self.tau_gc, dtype=float).tolist(), self._lo.tolist(),
                                np.asarray(self.tau_max, dtype=float).tolist(), strict=True))
        # an inactive servo holds the clipped gravity compensation at every tick
        self._static = np.minimum(np.maximum(self.tau_gc, self._lo), self.tau_max).tolist()

    @property
    def e_prev(self) -> np.ndarray:
        """Position error of the last tick [counts]."""
        return np.array(self._e_prev)

    @e_prev.setter
    def e_prev(self, value) -> None:
        self._e_prev = np.asarray(value, dtype=float).tolist()

    @property
    def e_sum(self) -> np.ndarray:
        """Sum of the position errors of all ticks so far [counts] (the integral over T)."""
        return np.array(self._e_sum)

    @e_sum.setter
    def e_sum(self, value) -> None:
        self._e_sum = np.asarray(value, dtype=float).tolist()

    def hold_static(self, tau_needed: np.ndarray) -> None:
        """Start at rest on the reference with the integrator wound up to ``tau_needed``
        (what the arm needs beyond ``tau_gc`` to hold still), as after a long settle."""
        if self.I > 0 and self.scale > 0:
            self.e_sum = (tau_needed - self.tau_gc) / (self.scale * self.I * self.period)

    def counts(self, q: np.ndarray) -> np.ndarray:
        c = q / self.resolution
        return np.round(c) if self.quantize else c

    def held(self, q: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The next ``n`` ticks of :meth:`update` with the arm still at ``q``, without changing
        the controller: ``(tau (n, na), e_sum after each tick (n, na), e (na,))``. The same
        operations as :meth:`update` in the same order (the integral a running sum), so
        :meth:`set_state` with a prefix of them leaves the controller where that many
        :meth:`update` calls would."""
        res = np.asarray(self.resolution, dtype=float)
        c = np.asarray(q, dtype=float) / res
        e = self._ref - (np.rint(c) if self.quantize else c)
        e_sum = np.cumsum(np.vstack([np.asarray(self._e_sum, dtype=float), np.broadcast_to(e, (n, e.size))]), axis=0)[1:]
        if not self.active:      # update() leaves the state alone
            tau = np.broadcast_to(np.minimum(np.maximum(self.tau_gc, self._lo), self.tau_max), (n, e.size)).copy()
            return tau, np.broadcast_to(np.asarray(self._e_sum, dtype=float), (n, e.size)), np.asarray(self._e_prev)
        de = np.broadcast_to(e, (n, e.size)).copy()
        de[0] = e - np.asarray(self._e_prev, dtype=float)
        de[1:] = 0.0
        u = self._kP * e + self._kD * de + self._kI * e_sum + np.asarray(self.tau_gc, dtype=float)
        return np.minimum(np.maximum(u, self._lo), np.asarray(self.tau_max, dtype=float)), e_sum, e

    def set_state(self, e_prev, e_sum) -> None:
        """Set the last error and the integral sum [counts] (after :meth:`held`)."""
        self.e_prev, self.e_sum = e_prev, e_sum

    def update(self, q: np.ndarray) -> np.ndarray:
        """One servo tick: read ``q`` [rad], return the torque held until the next tick [N m]
        (:meth:`step` as an array)."""
        return np.array(self.step(q.tolist()))

    def step(self, q: list) -> list:
        """:meth:`update` on Python floats (the joint angles as a list, the torque as one).

        Called at every servo tick of every trial on 3-6 joints, where a NumPy call costs
        more than its arithmetic: the law runs on Python floats, operation for operation
        what the vector form ``kP e + kD (e - e_prev) + kI sum(e) + tau_gc``, clipped to the
        peak torques, gives (``round`` rounds half to even, as ``np.rint``)."""
        if not self.active:
            return list(self._static)
        kP, kD, kI, quantize = self._kP, self._kD, self._kI, self.quantize
        e_prev, e_sum = self._e_prev, self._e_sum
        out = []
        for j, (qj, (res, ref, gc, lo, hi)) in enumerate(zip(q, self._joints, strict=True)):
            c = qj / res
            e = ref - (float(round(c)) if quantize else c)
            s = e_sum[j] + e
            u = kP * e + kD * (e - e_prev[j]) + kI * s + gc
            e_sum[j] = s
            e_prev[j] = e
            out.append(min(max(u, lo), hi))
        return out
