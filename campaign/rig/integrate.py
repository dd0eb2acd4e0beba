"""Time integration of one trial: fixed-step RK4 on the servo grid with located events.

Why this scheme (measured, see ``benchmarks/``): the dynamics are smooth between a few
discrete events (contact start/end, stick-slip switches, the hammer catch) and the servo
torque is a zero-order hold that changes only at ticks. Fixed-step RK4 whose steps land on
every servo tick never straddles a torque jump; inside a tick it takes
``substeps_contact`` steps while in contact (chosen from the contact's own time scale) and
``substeps_free`` otherwise. Events are checked at every step end; a triggered event is
located on the step's cubic Hermite interpolant (no extra dynamics calls) and the step is
redone exactly to that instant, so nothing depends on where the first touch or a stop
falls inside a step. Python-side calls dominate the cost, so the scheme minimises
right-hand-side evaluations rather than steps of an adaptive solver.

The swing and the arm at rest before the contact are analytic: integration starts at the
first touch. It stops once the trial's outputs are recorded: after ``min_post_contact``
when the arm is static (all joints stuck and the servo output constant) or slower than
``settle_velocity``, at ``max_post_contact`` at the latest.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .controller import PID
from .plant import FixedBasePlant
from .trial_run import TrialRun

__all__ = ["Trajectory", "integrate_trial"]


@dataclasses.dataclass
class Trajectory:
    """What the integration produced (before sensors): step-end states and events.

    ``t`` (N,), ``x`` (N, size), ``xd`` (N, size): states and derivatives at the recorded
    points (step ends; derivatives from the step leaving each point). ``servo_t`` and
    ``servo_tau``: held torque per tick (the first entry is the pre-contact static value).
    """

    t: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    servo_t: np.ndarray
    servo_tau: np.ndarray
    t_contact: float
    contacts: list  # [(t_start, t_end or None, v0)]
    v_a_pre: float
    v_b_pre: float
    v_a_post: float
    v_b_post: float
    impulse: float
    t_end: float
    t_static: float | None
    settled: bool
    n_steps: int
    n_rhs: int
    n_events: int
    tau_static: np.ndarray
    x0: np.ndarray


def integrate_trial(plant: FixedBasePlant, pid: PID, *, t_contact: float, speed: float, servo_period: float,
                    substeps_contact: int, substeps_free: int, min_post: float, max_post: float,
                    settle_velocity: float, stick_velocity: float, catch_delay: float = np.inf) -> Trajectory:
    """Integrate one trial from the first touch at ``t_contact`` until its outputs are
    recorded (:class:`.trial_run.TrialRun` holds the state and takes the steps).

    The hammer is caught (held still) at the top of its rebound or ``catch_delay`` after it
    leaves the arm, whichever comes first, so it cannot strike twice. A diverging state is
    reported as a :class:`SimulationError` by the per-step finiteness check, not as NumPy
    warnings.

    Raises
    ------
    SimulationError
        On a non-finite state (blow-up) or an event cascade (Zeno behaviour).
    """
    run = TrialRun(plant, pid, t_contact=t_contact, speed=speed, servo_period=servo_period,
                   substeps_contact=substeps_contact, substeps_free=substeps_free, min_post=min_post,
                   max_post=max_post, settle_velocity=settle_velocity, catch_delay=catch_delay)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if run.friction_events:
            run.settle_modes(run.x)
        while not run.finished():
            h, t_tick = run.step_length()
            if h is None:                  # the brake caught the hammer at this instant
                continue
            if h > 1e-15:
                if run.frozen():
                    if run.linear and run.frozen_ticks():
                        continue
                    if run.hold_frozen(t_tick):
                        continue
                elif run.rk4_step(h, t_tick):
                    continue
            run.ticks()
        run.finish()
    post = run.post     # the first contact's values (it has ended: checked by finish)
    return Trajectory(
        t=np.asarray(run.ts), x=np.asarray(run.xs), xd=np.asarray(run.xds),
        servo_t=np.asarray(run.servo_t), servo_tau=np.asarray(run.servo_tau),
        t_contact=t_contact, contacts=[tuple(c) for c in run.contacts],
        v_a_pre=0.0, v_b_pre=speed, v_a_post=post["v_a"], v_b_post=post["v_b"], impulse=post["P"],
        t_end=max(run.t, run.t_min_end), t_static=run.t_static, settled=run.settled, n_steps=run.n_steps,
        n_rhs=run.n_rhs, n_events=run.n_events, tau_static=run.tau_static, x0=run.x0,
    )
