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

__all__ = ["Lane", "Trajectory", "integrate_trial", "trial_steps"]


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


class Lane:
    """A trial's integration state where a caller may take over its plain steps.

    :func:`trial_steps` with ``lane=True`` yields this object at the top of every step
    iteration of a fixed-base arm (``plant.batchable``) with not every joint stuck. There
    the next iteration is one RK4 step of the arm, the hammer (swinging, in contact or
    caught) and the contact, the event checks (a slipping joint's velocity or a stuck
    joint's holding torque crossing its threshold, the contact's start or end, the
    rebounding hammer's top) and possibly a servo tick, which :mod:`.batch` evaluates for
    many trials at once. The caller either sends ``False`` (the generator takes the step
    itself) or advances ``x, t, k_tick, tau, n_steps, n_rhs`` (appending to the shared
    lists, updating ``pid`` and ``gap_end`` in place), sets ``ticked`` if a servo tick
    passed, ``k1_cached`` if its last evaluation was at the current state (the loop's
    cache would have served the next step's first stage from it), and sends ``True``.
    """

    __slots__ = ("plant", "pid", "ts", "xs", "xds", "servo_t", "servo_tau", "T", "sub", "t_min_end",
                 "t_max_end", "settle_velocity", "friction_events", "x", "t", "k_tick", "tau", "fs",
                 "n_steps", "n_rhs", "ticked", "k1_cached", "caught", "t_catch", "reuse_eval", "sub_contact",
                 "gap_end", "contact_v0", "contact_t0")


def integrate_trial(plant, pid, **kwargs) -> Trajectory:
    """Integrate one trial (see :func:`trial_steps`); a diverging state is reported as a
    :class:`SimulationError` by the per-step finiteness check, not as NumPy warnings."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        steps = trial_steps(plant, pid, **kwargs)
        try:
            next(steps)     # without ``lane`` it never yields: it returns the trajectory
        except StopIteration as done:
            return done.value
        raise AssertionError("trial_steps yielded without lane=True")


def trial_steps(plant: FixedBasePlant, pid: PID, *, t_contact: float, speed: float, servo_period: float,
                substeps_contact: int, substeps_free: int, min_post: float, max_post: float,
                settle_velocity: float, stick_velocity: float, catch_delay: float = np.inf,
                lane: bool = False):
    """Integrate one trial from the first touch at ``t_contact`` until its outputs are
    recorded; a generator whose return value (``StopIteration.value``) is the
    :class:`Trajectory`. With ``lane`` it yields a :class:`Lane` wherever a caller may take
    over plain steps (the batched integrator, :mod:`.batch`); without it, it never yields.

    The hammer is caught (held still) at the top of its rebound or ``catch_delay`` after it
    leaves the arm, whichever comes first, so it cannot strike twice.

    Raises
    ------
    SimulationError
        On a non-finite state (blow-up) or an event cascade (Zeno behaviour).
    """
    run = TrialRun(plant, pid, t_contact=t_contact, speed=speed, servo_period=servo_period,
                   substeps_contact=substeps_contact, substeps_free=substeps_free, min_post=min_post,
                   max_post=max_post, settle_velocity=settle_velocity, catch_delay=catch_delay)
    if run.friction_events:
        run.settle_modes(run.x)
    handoff = None
    if lane and getattr(plant, "batchable", False) and run.T_emu is None:
        handoff = Lane()
        handoff.plant, handoff.pid = plant, pid
        handoff.ts, handoff.xs, handoff.xds = run.ts, run.xs, run.xds
        handoff.servo_t, handoff.servo_tau = run.servo_t, run.servo_tau
        handoff.T, handoff.sub, handoff.sub_contact = servo_period, substeps_free, substeps_contact
        handoff.reuse_eval, handoff.gap_end = run.reuse_eval, run.gap_end
        handoff.t_min_end, handoff.t_max_end = run.t_min_end, run.t_max_end
        handoff.settle_velocity, handoff.friction_events = settle_velocity, run.friction_events
    while not run.finished():
        if handoff is not None and not run.fs.all_stuck:
            run.to_lane(handoff)
            if (yield handoff):        # the caller took the step (see Lane)
                run.from_lane(handoff)
                continue
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
