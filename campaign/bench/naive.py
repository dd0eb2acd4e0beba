"""The naive baseline: a straightforward fixed-step RK4 of the same scene."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError, SimulationError
from ..core.vocabulary import FIXED
from ..rig.integrate import Trajectory
from ..rig.plant import FrictionState
from ..rig.trial import build, record


# ---------------------------------------------------------------------------------------
# the naive baseline: a straightforward fixed-step RK4
# ---------------------------------------------------------------------------------------
def naive_rk4(scene, *, step: float = 1e-4, duration: float | None = None):
    """A straightforward fixed-step RK4 of a fixed-base trial, the baseline the rig's timing targets are set against.

    What "straightforward" means here (everything the rig's integrator avoids):

    - one step size ``step`` (0.1 ms) from ``t = 0`` to ``duration`` (default: the trial's
      pre-contact window + ``trial.min_post_contact``, 0.5 s for the default scene): the
      swing before the touch is integrated, not taken from its analytic solution, and the
      trial does not stop when the arm has settled;
    - Python-side Pinocchio calls through the same right-hand side as the rig
      (:meth:`FixedBasePlant.rhs`: ``pin.aba`` plus the contact kinematics at every stage);
    - no event location: the contact force is evaluated wherever the penetration is
      positive; the contact edges, post-impact velocities and the hammer catch are taken
      at the first step end past them;
    - Coulomb friction with the sign of each joint's velocity at the step start (no stick
      phase; a joint at rest chatters around zero velocity instead of sticking);
    - the servo updates at the step ends that fall on its ticks.

    Returns
    -------
    (rig, Trajectory)
        The assembled rig (:func:`campaign.rig.build`) and a
        :class:`campaign.rig.integrate.Trajectory` that ``campaign.rig.trial.record``
        turns into the trial's channels (integration starts at ``t_contact = 0``).
    """

    if scene.base != FIXED:
        raise InputError("the naive RK4 baseline is defined for fixed-base scenes only")
    rig = build(scene)
    min_post = float(getattr(rig, "min_post", scene.p("trial.min_post_contact")))
    if duration is None:
        duration = rig.t_contact + min_post
    values = _naive_steps(rig, speed=float(scene.speed), catch_delay=float(scene.p("pendulum.catch_delay")),
                          step=step, n_steps=int(round(duration / step)))
    fields = {f.name for f in dataclasses.fields(Trajectory)}
    missing = fields - set(values)
    if missing:  # the rig's Trajectory grew: fill what a fixed base does not need
        values.update({k: None for k in missing})
    return rig, Trajectory(**{k: v for k, v in values.items() if k in fields})


def _naive_steps(rig, *, speed: float, catch_delay: float, step: float, n_steps: int) -> dict:
    """The naive baseline's ``n_steps`` RK4 steps of ``step`` from ``t = 0`` (the swing
    included), as :func:`naive_rk4` describes them; returns the :class:`Trajectory`'s values."""
    plant, pid = rig.plant, rig.pid
    nv = plant.nv
    iv, ith, ithd, iP = plant.i_v, plant.i_th, plant.i_thd, plant.i_P
    arm_q = getattr(plant, "arm_q", slice(0, nv))
    per_tick = rig.servo_period / step
    sticky = np.asarray(plant.sticky, dtype=bool)
    r = plant.pend.radius

    x = np.zeros(plant.size)
    x[:nv] = plant.q0
    th, thd = plant.pend.swing(np.array([-rig.t_contact]), speed)
    x[ith], x[ithd] = float(th[0]), float(thd[0])
    x0 = x.copy()
    all_free = np.ones(nv, dtype=int)
    tau = plant.servo(pid.update(x[arm_q]))
    tau_static = tau.copy()
    servo_t, servo_tau = [0.0], [tau.copy()]
    rhs = plant.rhs
    caught = False
    n_rhs = 0
    ts = np.empty(n_steps + 1)
    xs = np.empty((n_steps + 1, plant.size))
    xds = np.empty((n_steps + 1, plant.size))
    ts[0], xs[0] = 0.0, x
    contact_on = False
    contacts: list[list] = []
    post: dict[str, float] = {}
    pre_vb = speed
    t_catch = math.inf
    next_tick = 1
    for i in range(n_steps):
        t = i * step
        # Coulomb friction by the sign of each joint's velocity (none at rest), no stick phase
        fs = FrictionState(all_free, plant.coulomb(np.where(sticky, np.sign(x[iv]), 1.0).astype(int)), iv.start)

        def f(xx, tt, tau=tau, fs=fs, caught=caught):   # this step's torque, friction and catch
            return rhs(xx, tau, fs, speed, caught, tt)

        k1 = f(x, t)
        k2 = f(x + 0.5 * step * k1, t + 0.5 * step)
        k3 = f(x + 0.5 * step * k2, t + 0.5 * step)
        k4 = f(x + step * k3, t + step)
        n_rhs += 4
        xds[i] = k1
        x = x + (step / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        t = (i + 1) * step
        if not np.all(np.isfinite(x)):
            raise SimulationError(f"the naive RK4 blew up at t = {t:.6g} s")
        # contact bookkeeping at the step end (no event location)
        delta, ddelta, Jn = plant.gap(x)
        if delta > 0 and not contact_on:
            contact_on = True
            contacts.append([t, None, speed])
        elif delta <= 0 and contact_on:
            contact_on = False
            contacts[-1][1] = t
            if not post:
                post = {"v_a": float(Jn @ x[iv]), "v_b": r * math.cos(x[ith]) * x[ithd], "P": float(x[iP])}
                t_catch = t + catch_delay
        if not contacts:
            pre_vb = r * math.cos(x[ith]) * x[ithd]
        if post and not caught and (t >= t_catch or (x[ithd] >= 0 > xs[i][ithd])):
            caught = True
            x[ithd] = 0.0
        ts[i + 1], xs[i + 1] = t, x
        # servo tick at this step end?
        if (i + 1) >= next_tick * per_tick - 1e-9:
            tau = plant.servo(pid.update(x[arm_q]))
            servo_t.append(t)
            servo_tau.append(tau.copy())
            next_tick += 1
    xds[n_steps] = rhs(x, tau, FrictionState(all_free, plant.coulomb(np.where(sticky, np.sign(x[iv]), 1.0).astype(int)),
                                             iv.start), speed, caught, ts[n_steps])
    n_rhs += 1
    if not contacts or contacts[0][1] is None:
        raise SimulationError("naive RK4: the contact had not ended by the end of the trial")
    return dict(
        t=ts, x=xs, xd=xds, servo_t=np.asarray(servo_t), servo_tau=np.asarray(servo_tau), t_contact=0.0,
        contacts=[tuple(c) for c in contacts], v_a_pre=0.0, v_b_pre=pre_vb, v_a_post=post["v_a"],
        v_b_post=post["v_b"], impulse=post["P"], t_end=float(ts[-1]), t_static=None, settled=False,
        n_steps=n_steps, n_rhs=n_rhs, n_events=0, tau_static=tau_static, x0=x0,
    )


def naive_trial(scene, *, step: float = 1e-4, duration: float | None = None):
    """The naive baseline's trial as a DataTree (same sensors and layout as :func:`simulate`)."""

    rig, traj = naive_rk4(scene, step=step, duration=duration)
    tree = record(rig, traj)
    tree.attrs["integration_steps"] = int(traj.n_steps)
    tree.attrs["integration_rhs_evaluations"] = int(traj.n_rhs)
    return tree
