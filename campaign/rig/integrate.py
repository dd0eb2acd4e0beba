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
import itertools
import math

import numpy as np

from ..core.errors import SimulationError
from .controller import PID
from .linear_phase import last_tick, run_frozen
from .plant import FixedBasePlant

__all__ = ["Lane", "Trajectory", "integrate_trial", "trial_steps"]

#: more events than this inside one servo tick is chattering (Zeno), not physics
_MAX_EVENTS_PER_TICK = 50
#: RK4 steps per servo tick at least, at a contact's edges (see the step loop)
EDGE_SUBSTEPS = 4
#: length scale [m] that puts the damping factor on the overlap's footing in the contact-end event
_END_SCALE = 1e-3


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


def _hermite(x0, f0, x1, f1, h, s):
    """Cubic Hermite state at fraction s in [0, 1] of a step of length h."""
    s2, s3 = s * s, s * s * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    return h00 * x0 + h10 * h * f0 + h01 * x1 + h11 * h * f1


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
    nv = plant.nv
    iv, ithd, iP = plant.i_v, plant.i_thd, plant.i_P
    iv0 = iv.start
    r = plant.pend.radius
    sticky = plant.sticky            # dofs with Coulomb friction (base dofs never stick)
    friction_events = bool(np.any(sticky))
    # with every dof stuck the arm cannot move (a prescribed platform moves it as a rigid body)
    can_freeze = friction_events and bool(np.all(sticky))
    arm_q = plant.arm_q
    T_emu = plant.emulator_period    # VES emulator ticks (None: no emulator)
    # a frozen arm's ticks in closed form: an emulator on the servo's grid whose scene asks for it
    linear = T_emu is not None and T_emu == servo_period and getattr(plant, "linear_phases", False)
    zero_xd = np.zeros(plant.size)

    # -- initial state at the first touch: arm at rest on q0, head at the bottom ------------
    x = np.zeros(plant.size)
    x[:nv] = plant.q0
    x[ithd] = speed / r
    x0 = x.copy()
    tau = plant.servo(pid.update(plant.q0[arm_q]))   # the static servo output held at the touch
    tau_static = tau.copy()
    fs = plant.friction_state(np.where(sticky, 0, 1), x[:nv])
    contact_v0 = speed                  # first touch: delta = 0, ddelta = v_b - v_a = v_b
    caught = False
    rebound_seen = False
    t_catch = None
    contacts = [[t_contact, None, speed]]
    post = {}

    T = servo_period
    k_tick = math.floor(t_contact / T + 1e-9) + 1   # next servo tick index
    servo_t = [t_contact]
    servo_tau = [tau.copy()]

    t = t_contact
    k_emu = (math.floor(t_contact / T_emu + 1e-9) + 1) if T_emu is not None else 0
    ts, xs, xds = [t], [x], []
    n_steps = n_rhs = n_events = tick_events = 0
    t_static = None
    settled = False
    t_min_end = t_contact + min_post
    t_max_end = t_contact + max_post

    rhs = plant.rhs
    # when the servo output cannot change at a tick (no PID) or an emulator samples the F/T
    # there, a step end's full evaluation is used anyway (next step's k1, the F/T sample):
    # the event checks take the contact gap from it instead of a separate kinematics call
    reuse_eval = T_emu is not None or not pid.active
    gap_end = [0.0, 0.0, 0.0]   # overlap and its rate at the last accepted step in contact, peak overlap
    last = None     # the last plant.evaluate: its inputs (by identity) and outputs

    def ev(xx, tt, f=None):
        """``plant.evaluate`` at (xx, tt) with the current torque, contact and friction modes
        (or modes ``f``); a repeat with the same inputs costs nothing. The step-end
        evaluation serves the events, the emulator's F/T sample and the next step's k1."""
        nonlocal last, n_rhs
        f = fs if f is None else f
        c = last
        if (c is not None and c[0] is xx and c[1] is tau and c[2] is f and c[3] == contact_v0
                and c[4] == caught and c[5] == tt):
            if c[6] is not None:
                return c[6]
            # evaluated and counted by the caller the steps were handed to (Lane), not kept
            out = plant.evaluate(xx, tau, f, contact_v0, caught, tt)
        else:
            out = plant.evaluate(xx, tau, f, contact_v0, caught, tt)
            n_rhs += 1
        last = (xx, tau, f, contact_v0, caught, tt, out)
        return out

    def rk4(xx, h, k1=None, t_end=None):
        """One RK4 step from (t, xx) to ``t_end`` (``t + h`` unless given: a step ending on a
        tick ends at the tick's own time); returns the new state and the derivative at xx."""
        nonlocal n_rhs
        if k1 is None:
            k1 = ev(xx, t)[0]
        th = t + 0.5 * h
        k2 = rhs(xx + (0.5 * h) * k1, tau, fs, contact_v0, caught, th)
        k3 = rhs(xx + (0.5 * h) * k2, tau, fs, contact_v0, caught, th)
        k4 = rhs(xx + h * k3, tau, fs, contact_v0, caught, t + h if t_end is None else t_end)
        n_rhs += 3
        return xx + (h / 6.0) * (k1 + k4 + 2.0 * (k2 + k3)), k1

    def event_values(xx, tt):
        """Event functions at state xx and time tt (each fires where its value crosses 0
        upward), and the contact gap ``(delta, ddelta)`` there when it was needed."""
        vals = {}
        gap = None
        # the holding torques need the dynamics; the contact gap only the kinematics
        need_lam = friction_events and not fs.none_stuck and not (
            # with every joint stuck, no contact and a constant servo torque on a fixed base
            # the holding torques cannot change
            fs.all_stuck and contact_v0 is None and not pid.active and T_emu is None)
        if need_lam or (reuse_eval and (contact_v0 is not None or not caught)):
            _, lam, gap = ev(xx, tt)
        elif contact_v0 is not None or not caught:
            plant._t = tt
            gap = plant.gap(xx)[:2]
        if contact_v0 is not None:
            # the contact ends where the force vanishes: the overlap closes (delta = 0), or the
            # bodies separate faster than the damped wrap can push (1 + d ddelta/v0 = 0) first
            d, dd = gap
            vals["contact_end"] = -min(d, _END_SCALE * (1.0 + plant._d * dd / contact_v0))
        elif not caught:
            vals["contact_start"] = gap[0]
            if rebound_seen or contacts[-1][1] is not None:
                vals["catch"] = xx[ithd]          # rebounding hammer (thd < 0) reaches its top
        if friction_events:
            if need_lam:
                for jj, val in zip(fs.stuck.tolist(), fs.violations(lam)):
                    vals[f"break{jj}"] = val
            for j, m, ij in fs.slipping:
                vals[f"stop{j}"] = -m * float(xx[ij])
        return vals, gap

    def consistent(xx, m):
        """Is friction mode assignment ``m`` consistent at state ``xx``? Stuck joints need a
        holding torque within their static limit; slipping joints at rest must accelerate
        in their slip direction."""
        cand = fs if m is fs.modes or np.array_equal(m, fs.modes) else plant.friction_state(m, xx[:nv])
        xd, lam, _ = ev(xx, t, cand)
        a = xd[iv]
        # |lam| > limit (1 + 1e-12), i.e. |lam| - limit > 1e-12 limit
        for x_l, (tp, tn) in zip(lam.tolist(), cand.stuck_limits):
            if (-x_l - tp * (1 + 1e-12)) > 0 if x_l < 0 else (x_l - tn * (1 + 1e-12)) > 0:
                return None
        for j, mj, ij in cand.slipping:
            if xx[ij] == 0.0 and a[j] * mj < 0:   # at rest, accelerating against its slip direction
                return None
        return cand

    def settle_modes(xx):
        """Make the friction modes consistent at ``xx`` (after a stop, a break-away or a new
        servo torque). Joint-space Coulomb friction with a positive definite ``H`` is a
        P-matrix complementarity problem with a unique solution; among the joints at rest
        we try the current assignment first, then every stick/slip+/slip- assignment,
        sticking preferred."""
        nonlocal fs
        if consistent(xx, fs.modes) is not None:
            return
        rest = np.flatnonzero(((fs.modes == 0) | (xx[iv] == 0.0)) & sticky)
        for combo in itertools.product((0, 1, -1), repeat=len(rest)):
            m = fs.modes.copy()
            m[rest] = combo
            cand = consistent(xx, m)
            if cand is not None:
                fs = cand
                return
        raise SimulationError(f"no consistent stick-slip state at t = {t:.6g} s (joints at rest: {rest.tolist()})")

    if friction_events:
        settle_modes(x)

    handoff = None
    if lane and getattr(plant, "batchable", False) and T_emu is None:
        handoff = Lane()
        handoff.plant, handoff.pid = plant, pid
        handoff.ts, handoff.xs, handoff.xds, handoff.servo_t, handoff.servo_tau = ts, xs, xds, servo_t, servo_tau
        handoff.T, handoff.sub, handoff.sub_contact = T, substeps_free, substeps_contact
        handoff.reuse_eval, handoff.gap_end = reuse_eval, gap_end
        handoff.t_min_end, handoff.t_max_end = t_min_end, t_max_end
        handoff.settle_velocity, handoff.friction_events = settle_velocity, friction_events

    while True:
        # -- stop? ---------------------------------------------------------------------------
        if contact_v0 is None:
            # all joints stuck and a servo output that cannot change any more, or (without
            # Coulomb friction) every joint slower than the settle velocity
            static = T_emu is None and (
                (friction_events and fs.all_stuck
                 and (not pid.active or pid.I == 0 or not np.any(pid.e_prev)))
                or (not friction_events and float(np.max(np.abs(x[iv]))) < settle_velocity))
            if static and caught:
                # nothing moves any more: the sensors hold this state to the end of the recording
                t_static, settled = t, True
                break
            if t >= t_min_end - 1e-12 and (static or t >= t_max_end - 1e-12):
                settled = static
                break
        if handoff is not None and not fs.all_stuck:
            # a step the caller may take (see Lane)
            c = last
            handoff.x, handoff.t, handoff.k_tick, handoff.tau, handoff.fs = x, t, k_tick, tau, fs
            handoff.n_steps, handoff.n_rhs, handoff.ticked = n_steps, n_rhs, False
            handoff.caught, handoff.t_catch = caught, (math.inf if t_catch is None else t_catch)
            handoff.contact_v0, handoff.contact_t0 = contact_v0, contacts[-1][0]
            handoff.k1_cached = (c is not None and c[0] is x and c[1] is tau and c[2] is fs
                                 and c[3] == contact_v0 and c[4] == caught and c[5] == t)
            if (yield handoff):
                x, t, k_tick, tau = handoff.x, handoff.t, handoff.k_tick, handoff.tau
                n_steps, n_rhs = handoff.n_steps, handoff.n_rhs
                if handoff.ticked:
                    tick_events = 0
                # the caller's last evaluation at this state (counted there) does not
                # cross over: ev() makes it again without counting it twice
                last = (x, tau, fs, contact_v0, caught, t, None) if handoff.k1_cached else None
                continue

        # -- one step to the next boundary (a servo tick or a substep) -------------------------
        sub = substeps_contact if contact_v0 is not None else substeps_free
        if contact_v0 is not None and (t < contacts[-1][0] + T or (gap_end[1] < 0 and gap_end[0] < 0.25 * gap_end[2])):
            # the contact's edges: the force rises from and falls to zero as delta^p (p < 1 for
            # the soft wrap), so the state's derivatives are singular there and RK4 and the
            # cubic Hermite between steps lose their order; finer steps over the first servo
            # tick and over the last quarter of the overlap keep the recorded force (and the
            # contact edges identified from it) independent of the step size. A contact
            # already resolved finer (the ideal scene's ~1 ms one) is left as it is.
            sub = max(sub, EDGE_SUBSTEPS)
        t_tick = k_tick * T
        if T_emu is not None:
            t_tick = min(t_tick, k_emu * T_emu)
        h = min(T / sub, t_tick - t)
        if t_catch is not None and not caught and t_catch - t <= h:
            if t_catch - t <= 1e-15:
                # the device's brake catches the hammer now
                caught = True
                x = x.copy()
                x[ithd] = 0.0
                xs[-1] = x
                continue
            h = t_catch - t
        if (linear and h > 1e-15 and can_freeze and fs.all_stuck and caught and contact_v0 is None
                and k_tick == k_emu and abs(t - (k_emu - 1) * T_emu) <= 1e-12):
            # -- frozen arm on a linear emulator, on a tick: the ticks up to the end of the
            # recording (or a break-away) in closed form (see .linear_phase)
            m, taus = run_frozen(plant, pid, x, tau, fs, k_emu, last_tick(t_max_end, T_emu), T_emu)
            if m:
                tk = ((k_emu + np.arange(m)) * T_emu).tolist()
                ts.extend(tk)
                xs.extend([x] * m)
                xds.extend([zero_xd] * m)
                servo_t.extend(tk)
                servo_tau.extend(taus)
                t, k_emu, k_tick = tk[-1], k_emu + m, k_tick + m
                tau = taus[-1]
                tick_events = 0
                continue
        if h > 1e-15 and can_freeze and fs.all_stuck and caught and contact_v0 is None:
            # -- frozen arm: every joint stuck, hammer caught, no contact. Nothing in x moves,
            # so no integration: hold x to the boundary. Only a prescribed platform can change
            # the holding torques inside the interval; a break-away is located in time.
            h = t_tick - t
            fired_at = None
            if T_emu is not None:
                lam1 = plant.holding(x, tau, fs, None, t + h)[0]
                if max(fs.violations(lam1)) > 0:
                    def gfun(s):
                        return max(fs.violations(plant.holding(x, tau, fs, None, t + s * h)[0]))
                    g0 = gfun(0.0)
                    from scipy.optimize import (
                        brentq,  # lazily: scipy.optimize costs ~0.5 s to import
                    )
                    fired_at = brentq(gfun, 0.0, 1.0, xtol=1e-14) if g0 < 0 else 0.0
            if fired_at is None:
                xds.append(zero_xd)
                t = t + h
                ts.append(t)
                xs.append(x)
            else:
                n_events += 1
                h_ev = min(h, fired_at * h + 1e-10)
                if h_ev > 1e-15:
                    xds.append(zero_xd)
                    t = t + h_ev
                    ts.append(t)
                    xs.append(x)
                plant._t = t
                settle_modes(x)
                continue
        elif h > 1e-15:
            t_new = t + h
            if abs(t_new - t_tick) <= 1e-12:
                t_new = t_tick     # the tick's own time, so its evaluations are shared
            x_new, k1 = rk4(x, h, t_end=t_new)
            n_steps += 1
            if not math.isfinite(x_new.sum()):
                raise SimulationError(f"the integration blew up at t = {t + h:.6g} s (non-finite state)")
            g1, gap1 = event_values(x_new, t_new)
            candidates = [k for k, v1 in g1.items() if v1 > 0]
            fired = []
            if candidates:
                g0 = event_values(x, t)[0]
                # a stop needs a strict crossing: a joint released at rest (v = 0) whose
                # acceleration was marginal may start the wrong way; that is fixed below,
                # locating it would refire at the same instant (Zeno)
                fired = [k for k in candidates
                         if g0.get(k, -1.0) < 0 or (g0.get(k, -1.0) == 0 and not k.startswith("stop"))]
            if not fired:
                xds.append(k1)
                x, t = x_new, t_new
                ts.append(t)
                xs.append(x)
                if contact_v0 is not None:     # for the contact-edge refinement
                    gap_end[0], gap_end[1], gap_end[2] = gap1[0], gap1[1], max(gap_end[2], gap1[0])
                # a joint released at rest that started against its slip direction slips the
                # way it moves
                wrong = [j for j, mj, ij in fs.slipping if mj * x[ij] < 0]
                if wrong:
                    m = fs.modes.copy()
                    m[wrong] = np.sign(x[iv][wrong]).astype(int)
                    fs = plant.friction_state(m, x[:nv])
            else:
                n_events += 1
                tick_events += 1
                if tick_events > _MAX_EVENTS_PER_TICK:
                    raise SimulationError(
                        f"more than {_MAX_EVENTS_PER_TICK} events within one servo tick at t = {t:.6g} s "
                        "(chattering contact or stick-slip: reduce the contact stiffness or the servo gains)")
                f1 = ev(x_new, t_new)[0]
                best_s, best_k = 2.0, None
                for key in fired:
                    def gfun(s, key=key):
                        if s <= 0.0:
                            return g0.get(key, -1.0)
                        if s >= 1.0:
                            return g1[key]
                        return event_values(_hermite(x, k1, x_new, f1, h, s), t + s * h)[0].get(key, -1.0)
                    from scipy.optimize import (
                        brentq,  # lazily: scipy.optimize costs ~0.5 s to import
                    )
                    s_k = brentq(gfun, 0.0, 1.0, xtol=1e-14) if gfun(0.0) <= 0 else 0.0
                    if s_k < best_s:
                        best_s, best_k = s_k, key
                h_ev = best_s * h
                if best_k.startswith("break"):
                    # act just past the root, where the static limit is exceeded strictly
                    # (at the root itself sticking is still consistent to rounding)
                    h_ev = min(h, h_ev + 1e-10)
                if h_ev > 1e-15:
                    x, _ = rk4(x, h_ev, k1)
                    xds.append(k1)
                    t = t + h_ev
                    ts.append(t)
                else:
                    x = x.copy()
                plant._t = t
                # -- apply the event at (t, x) (x is a fresh array: xs[-1] is set below) -------
                if best_k == "contact_end":
                    contacts[-1][1] = t
                    if not post:   # the first contact is the impact the trial is about
                        post = {"v_a": plant.tip_speed(x), "v_b": r * math.cos(x[nv]) * x[ithd], "P": float(x[iP])}
                    contact_v0 = None
                    rebound_seen = x[ithd] < 0
                    if t_catch is None:
                        t_catch = t + catch_delay
                elif best_k == "contact_start":
                    gap_end[:] = [0.0, 0.0, 0.0]
                    d, dd, Jn = plant.gap(x)
                    contact_v0 = max(dd, 1e-9)
                    contacts.append([t, None, contact_v0])
                elif best_k == "catch":
                    caught = True
                    x[ithd] = 0.0
                elif best_k.startswith("stop"):
                    j = int(best_k[4:])
                    x[iv0 + j] = 0.0      # the joint comes to rest: stick, or reverse
                    settle_modes(x)
                else:  # break-away: at the located instant the holding torque sits on the
                    # static limit, so release the joint in the direction it pushes (the
                    # unchanged stick assignment is still "consistent" to rounding there)
                    j = int(best_k[5:])
                    lam = plant.holding(x, tau, fs, contact_v0, t)[0]
                    m = fs.modes.copy()
                    m[j] = 1 if lam[fs.stuck.tolist().index(j)] < 0 else -1
                    cand = consistent(x, m)
                    if cand is not None:
                        fs = cand
                    else:
                        settle_modes(x)
                if h_ev > 1e-15:
                    xs.append(x)
                else:
                    xs[-1] = x
                continue
        # -- servo tick ----------------------------------------------------------------------
        if T_emu is not None and k_emu * T_emu - t <= 1e-12:
            t = k_emu * T_emu
            ts[-1] = t
            frozen = can_freeze and fs.all_stuck and caught and contact_v0 is None
            plant.on_emulator_tick(t, x, zero_xd if frozen else ev(x, t)[0])
            k_emu += 1
        if k_tick * T - t <= 1e-12:
            t = k_tick * T
            ts[-1] = t
            tau_new = plant.servo(pid.update(x[arm_q]))
            changed = tau_new.tolist() != tau.tolist()   # (lists: a NumPy reduction costs 2 us)
            if changed:      # keep the same object otherwise: evaluations at this state stay valid
                tau = tau_new
            servo_t.append(t)
            servo_tau.append(tau)
            k_tick += 1
            tick_events = 0
            if friction_events and changed:
                plant._t = t
                settle_modes(x)   # a new torque may break a stuck joint loose at once

    xds.append(ev(x, t)[0])
    if contacts[-1][1] is None:
        raise SimulationError("the contact had not ended by the end of the trial (hammer pressed against the arm)")
    t_end = max(t, t_min_end)
    # the first contact's values; before its end nothing is known (checked above)
    return Trajectory(
        t=np.asarray(ts), x=np.asarray(xs), xd=np.asarray(xds),
        servo_t=np.asarray(servo_t), servo_tau=np.asarray(servo_tau),
        t_contact=t_contact, contacts=[tuple(c) for c in contacts],
        v_a_pre=0.0, v_b_pre=speed, v_a_post=post["v_a"],
        v_b_post=post["v_b"], impulse=post["P"],
        t_end=t_end, t_static=t_static, settled=settled, n_steps=n_steps, n_rhs=n_rhs, n_events=n_events,
        tau_static=tau_static, x0=x0,
    )
