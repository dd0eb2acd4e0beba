"""Sensors of the simulated VES-II: each channel on its own clock, seeded noise, quantisation.

The integrator leaves states at its step ends (:class:`.integrate.Trajectory`); every
channel is sampled from the piecewise cubic Hermite interpolant of those states (exact
pieces between events, since events are step ends), from the analytic pre-contact state
before the first touch, and from the held final state after the arm has come to rest.

Noise streams are independent children of the trial's ``SeedSequence(seed)``, one per
channel, so a channel's numbers do not change when another channel's rate does.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .integrate import Trajectory
from .plant import FixedBasePlant

__all__ = ["StateSampler", "sample_grid", "quantize", "noise_streams", "base_wrench"]

STREAMS = ("contact_time", "joint_encoder", "pendulum_encoder", "piezo", "ft")


def noise_streams(seed: int) -> dict[str, np.random.Generator]:
    """One independent generator per channel, from the trial seed."""
    children = np.random.SeedSequence(seed).spawn(len(STREAMS))
    return {name: np.random.default_rng(c) for name, c in zip(STREAMS, children)}


def sample_grid(rate: float, t_end: float) -> np.ndarray:
    """Sample times ``k / rate`` for ``k = 0 .. floor(t_end * rate)`` [s]."""
    n = int(np.floor(t_end * rate + 1e-9)) + 1
    return np.arange(n) / rate


def quantize(x, step: float):
    """Round to whole steps (``step = 0`` leaves ``x`` alone)."""
    if step <= 0:
        return np.asarray(x, dtype=float)
    return np.round(np.asarray(x, dtype=float) / step) * step


class StateSampler:
    """Full state (and derivative) at arbitrary times of the recording."""

    def __init__(self, plant: FixedBasePlant, traj: Trajectory):
        self.plant = plant
        self.traj = traj
        self.pend = plant.pend
        self.speed = traj.v_b_pre

    def __call__(self, times):
        """States (N, size) and derivatives (N, size) at ``times`` [s]."""
        plant, tr = self.plant, self.traj
        times = np.asarray(times, dtype=float)
        X = np.empty((times.size, plant.size))
        XD = np.zeros((times.size, plant.size))
        pre = times < tr.t_contact
        # before the touch: arm at rest at q0, pendulum on its analytic swing
        if np.any(pre):
            X[pre] = tr.x0
            th, thd = self.pend.swing(times[pre] - tr.t_contact, self.speed)
            X[pre, plant.i_th] = th
            X[pre, plant.i_thd] = thd
            X[pre, plant.i_P] = 0.0
            XD[pre, plant.i_th] = thd
            XD[pre, plant.i_thd] = -self.pend.mgl * np.sin(th) / self.pend.inertia
        # during the integration: cubic Hermite per step
        mid = (~pre) & (times <= tr.t[-1])
        if np.any(mid):
            tm = times[mid]
            i = np.clip(np.searchsorted(tr.t, tm, side="right") - 1, 0, tr.t.size - 2)
            h = tr.t[i + 1] - tr.t[i]
            s = ((tm - tr.t[i]) / h)[:, None]
            x0, x1, f0, f1 = tr.x[i], tr.x[i + 1], tr.xd[i], tr.xd[i + 1]
            hh = h[:, None]
            s2, s3 = s * s, s * s * s
            X[mid] = (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * hh * f0 + (-2 * s3 + 3 * s2) * x1 \
                + (s3 - s2) * hh * f1
            XD[mid] = ((6 * s2 - 6 * s) * (x0 - x1) / hh + (3 * s2 - 4 * s + 1) * f0 + (3 * s2 - 2 * s) * f1)
        # after the integration stopped (arm at rest, hammer caught): the state is held
        post = times > tr.t[-1]
        if np.any(post):
            X[post] = tr.x[-1]
        return X, XD

    def contact_force(self, times):
        """True contact force [N] at ``times``: the rate of the integrated impulse state
        (exact within contacts, zero outside them)."""
        X, XD = self(times)
        F = XD[:, self.plant.i_P].copy()
        inside = np.zeros(times.size, dtype=bool)
        for (t0, t1, _v0) in self.traj.contacts:
            inside |= (times >= t0) & (times <= (t1 if t1 is not None else np.inf))
        F[~inside] = 0.0
        return np.maximum(F, 0.0)


def base_wrench(plant: FixedBasePlant, q, v, a, F):
    """Wrench of the arm on its mounting, base frame, about the base origin: (force [N],
    moment [N m]). Newton-Euler (RNEA) with the contact force as an external force on the
    link that carries the impact point; the arm's weight is included (the sensor reads it)."""
    model, data = plant.model, plant.data
    jid = model.frames[plant.fid].parentJoint
    placement = model.frames[plant.fid].placement
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    pin.forwardKinematics(model, data, q)
    R = data.oMi[jid].rotation
    f_local = R.T @ (plant.n * F)
    r = placement.translation
    torque = np.array([r[1] * f_local[2] - r[2] * f_local[1], r[2] * f_local[0] - r[0] * f_local[2],
                       r[0] * f_local[1] - r[1] * f_local[0]])
    fext[jid] = pin.Force(f_local, torque)
    pin.rnea(model, data, q, v, a, fext)
    w = data.oMi[1].act(data.f[1])
    return -np.array(w.linear), -np.array(w.angular)
