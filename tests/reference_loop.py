"""The trial loop as it was before the lean one (:mod:`campaign.rig.trial_run`): the
reference that ``tests/rig/test_lean_loop.py`` compares the lean loop with, to roundoff.

It steps the state as a NumPy array through the plant's own array methods
(:meth:`campaign.rig.plant.FixedBasePlant.rhs`, ``evaluate``, ``holding``, ``gap``), with
dictionaries of named event values at every step: the same physics, the same event
location, a different implementation. Kept here, outside the package, for that
comparison only.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from campaign.core.errors import SimulationError
from campaign.rig.integrate import Trajectory
from campaign.rig.linear_phase import last_tick, run_frozen

__all__ = ["TrialRun", "integrate_reference"]

#: more events than this inside one servo tick is chattering (Zeno), not physics
_MAX_EVENTS_PER_TICK = 50
#: RK4 steps per servo tick at least, at a contact's edges (see :meth:`TrialRun.step_length`)
EDGE_SUBSTEPS = 4
#: length scale [m] that puts the damping factor on the overlap's footing in the contact-end event
_END_SCALE = 1e-3


def _hermite(x0, f0, x1, f1, h, s):
    """Cubic Hermite state at fraction s in [0, 1] of a step of length h."""
    s2, s3 = s * s, s * s * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    return h00 * x0 + h10 * h * f0 + h01 * x1 + h11 * h * f1


class TrialRun:
    """The state and buffers of one trial's integration and its steps (the loop over them:
    :func:`integrate_reference`).

    The state: ``x`` at time ``t``, the held servo torque ``tau``, the friction modes
    ``fs``, the contact (``contact_v0``: its approach speed, None out of contact), the
    hammer (``caught``, ``t_catch``), the next servo and emulator tick indices ``k_tick``,
    ``k_emu``. The buffers (``ts``, ``xs``, ``xds``, ``servo_t``, ``servo_tau``) grow by one
    entry per accepted step or tick. The counts
    ``n_steps``, ``n_rhs``, ``n_events`` and the first contact's ``post`` values go into the
    :class:`campaign.rig.integrate.Trajectory`. The arguments are those of
    :func:`campaign.rig.integrate.integrate_trial`.
    """

    __slots__ = ("plant", "pid", "nv", "iv", "ithd", "iP", "iv0", "r", "sticky", "friction_events", "can_freeze",
                 "arm_q", "T_emu", "linear", "zero_xd", "x0", "tau_static", "T", "substeps_contact", "substeps_free",
                 "settle_velocity", "catch_delay", "t_min_end", "t_max_end", "rhs", "reuse_eval", "x", "t", "tau",
                 "fs", "contact_v0", "caught", "rebound_seen", "t_catch", "contacts", "post", "k_tick", "k_emu",
                 "ts", "xs", "xds", "servo_t", "servo_tau", "n_steps", "n_rhs", "n_events", "tick_events",
                 "t_static", "settled", "gap_end", "last")

    def __init__(self, plant, pid, *, t_contact, speed, servo_period, substeps_contact, substeps_free, min_post,
                 max_post, settle_velocity, catch_delay):
        self.plant, self.pid = plant, pid
        self.nv = nv = plant.nv
        self.iv, self.ithd, self.iP = plant.i_v, plant.i_thd, plant.i_P
        self.iv0 = self.iv.start
        self.r = plant.pend.radius
        self.sticky = sticky = plant.sticky      # dofs with Coulomb friction (base dofs never stick)
        self.friction_events = bool(np.any(sticky))
        # with every dof stuck the arm cannot move (a prescribed platform moves it as a rigid body)
        self.can_freeze = self.friction_events and bool(np.all(sticky))
        self.arm_q = plant.arm_q
        self.T_emu = T_emu = plant.emulator_period    # VES emulator ticks (None: no emulator)
        # a frozen arm's ticks in closed form: an emulator on the servo's grid whose scene asks for it
        self.linear = T_emu is not None and T_emu == servo_period and getattr(plant, "linear_phases", False)
        self.zero_xd = np.zeros(plant.size)
        self.T, self.catch_delay = servo_period, catch_delay
        self.substeps_contact, self.substeps_free = substeps_contact, substeps_free
        self.settle_velocity = settle_velocity
        self.t_min_end, self.t_max_end = t_contact + min_post, t_contact + max_post
        self.rhs = plant.rhs
        # when the servo output cannot change at a tick (no PID) or an emulator samples the F/T
        # there, a step end's full evaluation is used anyway (next step's k1, the F/T sample):
        # the event checks take the contact gap from it instead of a separate kinematics call
        self.reuse_eval = T_emu is not None or not pid.active

        # -- the state at the first touch: arm at rest on q0, head at the bottom ------------
        x = np.zeros(plant.size)
        x[:nv] = plant.q0
        x[self.ithd] = speed / self.r
        self.x, self.x0 = x, x.copy()
        self.tau = tau = plant.servo(pid.update(plant.q0[self.arm_q]))   # the static servo output held at the touch
        self.tau_static = tau.copy()
        self.fs = plant.friction_state(np.where(sticky, 0, 1), x[:nv])
        self.contact_v0 = speed            # first touch: delta = 0, ddelta = v_b - v_a = v_b
        self.caught = self.rebound_seen = False
        self.t_catch = None
        self.contacts = [[t_contact, None, speed]]
        self.post = {}
        self.k_tick = math.floor(t_contact / servo_period + 1e-9) + 1   # next servo tick index
        self.k_emu = (math.floor(t_contact / T_emu + 1e-9) + 1) if T_emu is not None else 0
        self.t = t_contact
        self.ts, self.xs, self.xds = [t_contact], [x], []
        self.servo_t, self.servo_tau = [t_contact], [tau.copy()]
        self.n_steps = self.n_rhs = self.n_events = self.tick_events = 0
        self.t_static, self.settled = None, False
        self.gap_end = [0.0, 0.0, 0.0]   # overlap and its rate at the last accepted step in contact, peak overlap
        self.last = None     # the last plant.evaluate: its inputs (by identity) and outputs

    # -- the dynamics and the event functions ---------------------------------------------
    def evaluate(self, xx, tt, f=None):
        """``plant.evaluate`` at (xx, tt) with the current torque, contact and friction modes
        (or modes ``f``); a repeat with the same inputs costs nothing. The step-end
        evaluation serves the events, the emulator's F/T sample and the next step's k1."""
        if f is None:
            f = self.fs
        c = self.last
        tau, contact_v0, caught = self.tau, self.contact_v0, self.caught
        if (c is not None and c[0] is xx and c[1] is tau and c[2] is f and c[3] == contact_v0
                and c[4] == caught and c[5] == tt):
            return c[6]
        out = self.plant.evaluate(xx, tau, f, contact_v0, caught, tt)
        self.n_rhs += 1
        self.last = (xx, tau, f, contact_v0, caught, tt, out)
        return out

    def rk4(self, xx, h, k1=None, t_end=None):
        """One RK4 step from (t, xx) to ``t_end`` (``t + h`` unless given: a step ending on a
        tick ends at the tick's own time); returns the new state and the derivative at xx."""
        t = self.t
        if k1 is None:
            k1 = self.evaluate(xx, t)[0]
        rhs, tau, fs, contact_v0, caught = self.rhs, self.tau, self.fs, self.contact_v0, self.caught
        th = t + 0.5 * h
        k2 = rhs(xx + (0.5 * h) * k1, tau, fs, contact_v0, caught, th)
        k3 = rhs(xx + (0.5 * h) * k2, tau, fs, contact_v0, caught, th)
        k4 = rhs(xx + h * k3, tau, fs, contact_v0, caught, t + h if t_end is None else t_end)
        self.n_rhs += 3
        return xx + (h / 6.0) * (k1 + k4 + 2.0 * (k2 + k3)), k1

    def event_values(self, xx, tt):
        """Event functions at state xx and time tt (each fires where its value crosses 0
        upward), and the contact gap ``(delta, ddelta)`` there when it was needed."""
        fs, contact_v0, caught = self.fs, self.contact_v0, self.caught
        vals = {}
        gap = None
        # the holding torques need the dynamics; the contact gap only the kinematics
        need_lam = self.friction_events and not fs.none_stuck and not (
            # with every joint stuck, no contact and a constant servo torque on a fixed base
            # the holding torques cannot change
            fs.all_stuck and contact_v0 is None and not self.pid.active and self.T_emu is None)
        if need_lam or (self.reuse_eval and (contact_v0 is not None or not caught)):
            _, lam, gap = self.evaluate(xx, tt)
        elif contact_v0 is not None or not caught:
            self.plant._t = tt
            gap = self.plant.gap(xx)[:2]
        if contact_v0 is not None:
            # the contact ends where the force vanishes: the overlap closes (delta = 0), or the
            # bodies separate faster than the damped wrap can push (1 + d ddelta/v0 = 0) first
            d, dd = gap
            vals["contact_end"] = -min(d, _END_SCALE * (1.0 + self.plant._d * dd / contact_v0))
        elif not caught:
            vals["contact_start"] = gap[0]
            if self.rebound_seen or self.contacts[-1][1] is not None:
                vals["catch"] = xx[self.ithd]          # rebounding hammer (thd < 0) reaches its top
        if self.friction_events:
            if need_lam:
                for jj, val in zip(fs.stuck.tolist(), fs.violations(lam), strict=True):
                    vals[f"break{jj}"] = val
            for j, m, ij in fs.slipping:
                vals[f"stop{j}"] = -m * float(xx[ij])
        return vals, gap

    # -- the stick-slip modes ----------------------------------------------------------------
    def consistent(self, xx, m):
        """Is friction mode assignment ``m`` consistent at state ``xx``? Stuck joints need a
        holding torque within their static limit; slipping joints at rest must accelerate
        in their slip direction."""
        fs = self.fs
        cand = fs if m is fs.modes or np.array_equal(m, fs.modes) else self.plant.friction_state(m, xx[:self.nv])
        xd, lam, _ = self.evaluate(xx, self.t, cand)
        a = xd[self.iv]
        # |lam| > limit (1 + 1e-12), i.e. |lam| - limit > 1e-12 limit
        for x_l, (tp, tn) in zip(lam.tolist(), cand.stuck_limits, strict=True):
            if (-x_l - tp * (1 + 1e-12)) > 0 if x_l < 0 else (x_l - tn * (1 + 1e-12)) > 0:
                return None
        for j, mj, ij in cand.slipping:
            if xx[ij] == 0.0 and a[j] * mj < 0:   # at rest, accelerating against its slip direction
                return None
        return cand

    def settle_modes(self, xx):
        """Make the friction modes consistent at ``xx`` (after a stop, a break-away or a new
        servo torque). Joint-space Coulomb friction with a positive definite ``H`` is a
        P-matrix complementarity problem with a unique solution; among the joints at rest
        we try the current assignment first, then every stick/slip+/slip- assignment,
        sticking preferred."""
        fs = self.fs
        if self.consistent(xx, fs.modes) is not None:
            return
        rest = np.flatnonzero(((fs.modes == 0) | (xx[self.iv] == 0.0)) & self.sticky)
        for combo in itertools.product((0, 1, -1), repeat=len(rest)):
            m = fs.modes.copy()
            m[rest] = combo
            cand = self.consistent(xx, m)
            if cand is not None:
                self.fs = cand
                return
        raise SimulationError(f"no consistent stick-slip state at t = {self.t:.6g} s (joints at rest: {rest.tolist()})")

    # -- the loop's steps ----------------------------------------------------------------------
    def finished(self) -> bool:
        """The end-of-trial test (out of contact): nothing moves any more and the hammer is
        caught, or the recording is long enough and the arm static or the longest recording
        reached. Sets ``settled`` and ``t_static``."""
        if self.contact_v0 is not None:
            return False
        fs, pid, t = self.fs, self.pid, self.t
        # all joints stuck and a servo output that cannot change any more, or (without
        # Coulomb friction) every joint slower than the settle velocity
        static = self.T_emu is None and (
            (self.friction_events and fs.all_stuck
             and (not pid.active or pid.I == 0 or not np.any(pid.e_prev)))
            or (not self.friction_events and float(np.max(np.abs(self.x[self.iv]))) < self.settle_velocity))
        if static and self.caught:
            # nothing moves any more: the sensors hold this state to the end of the recording
            self.t_static, self.settled = t, True
            return True
        if t >= self.t_min_end - 1e-12 and (static or t >= self.t_max_end - 1e-12):
            self.settled = static
            return True
        return False

    def step_length(self):
        """``(h, t_tick)``: the next step's length, to the next boundary ``t_tick`` (a servo
        or emulator tick) or a substep, or to the hammer's catch. ``h`` is None when the
        brake catches the hammer now (applied here)."""
        t, T = self.t, self.T
        if self.contact_v0 is None:
            sub = self.substeps_free
        else:
            sub = self.substeps_contact
            gap_end = self.gap_end
            if t < self.contacts[-1][0] + T or (gap_end[1] < 0 and gap_end[0] < 0.25 * gap_end[2]):
                # the contact's edges: the force rises from and falls to zero as delta^p (p < 1
                # for the soft wrap), so the state's derivatives are singular there and RK4 and
                # the cubic Hermite between steps lose their order; finer steps over the first
                # servo tick and over the last quarter of the overlap keep the recorded force
                # (and the contact edges identified from it) independent of the step size. A
                # contact already resolved finer (the ideal scene's ~1 ms one) is left as it is.
                sub = max(sub, EDGE_SUBSTEPS)
        t_tick = self.k_tick * T
        if self.T_emu is not None:
            t_tick = min(t_tick, self.k_emu * self.T_emu)
        h = min(T / sub, t_tick - t)
        t_catch = self.t_catch
        if t_catch is not None and not self.caught and t_catch - t <= h:
            if t_catch - t <= 1e-15:
                # the device's brake catches the hammer now
                self.caught = True
                x = self.x.copy()
                x[self.ithd] = 0.0
                self.x = self.xs[-1] = x
                return None, t_tick
            h = t_catch - t
        return h, t_tick

    def frozen(self) -> bool:
        """Frozen arm: every joint stuck, hammer caught, no contact (nothing in x moves)."""
        return self.can_freeze and self.fs.all_stuck and self.caught and self.contact_v0 is None

    def frozen_ticks(self) -> bool:
        """A frozen arm on a linear emulator, on a tick: the ticks up to the end of the
        recording (or a break-away) in closed form (see .linear_phase); False if none."""
        k_emu, T_emu = self.k_emu, self.T_emu
        if not (self.k_tick == k_emu and abs(self.t - (k_emu - 1) * T_emu) <= 1e-12):
            return False
        m, taus = run_frozen(self.plant, self.pid, self.x, self.tau, self.fs, k_emu,
                             last_tick(self.t_max_end, T_emu), T_emu)
        if not m:
            return False
        tk = ((k_emu + np.arange(m)) * T_emu).tolist()
        self.ts.extend(tk)
        self.xs.extend([self.x] * m)
        self.xds.extend([self.zero_xd] * m)
        self.servo_t.extend(tk)
        self.servo_tau.extend(taus)
        self.t, self.k_emu, self.k_tick = tk[-1], k_emu + m, self.k_tick + m
        self.tau = taus[-1]
        self.tick_events = 0
        return True

    def hold_frozen(self, t_tick) -> bool:
        """A frozen arm: no integration, x held to the boundary ``t_tick``. Only a prescribed
        platform can change the holding torques inside the interval; a break-away is located
        in time and the modes settled there (returns True: the step is not finished)."""
        x, t, tau, fs, plant = self.x, self.t, self.tau, self.fs, self.plant
        h = t_tick - t
        fired_at = None
        if self.T_emu is not None:
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
            self.xds.append(self.zero_xd)
            self.t = t = t + h
            self.ts.append(t)
            self.xs.append(x)
            return False
        self.n_events += 1
        h_ev = min(h, fired_at * h + 1e-10)
        if h_ev > 1e-15:
            self.xds.append(self.zero_xd)
            self.t = t = t + h_ev
            self.ts.append(t)
            self.xs.append(x)
        plant._t = t
        self.settle_modes(x)
        return True

    def rk4_step(self, h, t_tick) -> bool:
        """One RK4 step of length ``h``; returns True if an event fired inside it (then the
        step ends at the event instead, :meth:`event_step`)."""
        x, t = self.x, self.t
        t_new = t + h
        if abs(t_new - t_tick) <= 1e-12:
            t_new = t_tick     # the tick's own time, so its evaluations are shared
        x_new, k1 = self.rk4(x, h, None, t_new)
        self.n_steps += 1
        if not math.isfinite(x_new.sum()):
            raise SimulationError(f"the integration blew up at t = {t + h:.6g} s (non-finite state)")
        g1, gap1 = self.event_values(x_new, t_new)
        candidates = [k for k, v1 in g1.items() if v1 > 0]
        if candidates:
            g0 = self.event_values(x, t)[0]
            # a stop needs a strict crossing: a joint released at rest (v = 0) whose
            # acceleration was marginal may start the wrong way; that is fixed below,
            # locating it would refire at the same instant (Zeno)
            fired = [k for k in candidates
                     if g0.get(k, -1.0) < 0 or (g0.get(k, -1.0) == 0 and not k.startswith("stop"))]
            if fired:
                self.event_step(fired, g0, g1, x_new, t_new, k1, h)
                return True
        # accepted
        self.xds.append(k1)
        self.x = x = x_new
        self.t = t_new
        self.ts.append(t_new)
        self.xs.append(x)
        if self.contact_v0 is not None:     # for the contact-edge refinement
            gap_end = self.gap_end
            gap_end[0], gap_end[1], gap_end[2] = gap1[0], gap1[1], max(gap_end[2], gap1[0])
        # a joint released at rest that started against its slip direction slips the way it moves
        fs = self.fs
        if fs.slipping:
            wrong = [j for j, mj, ij in fs.slipping if mj * x[ij] < 0]
            if wrong:
                m = fs.modes.copy()
                m[wrong] = np.sign(x[self.iv][wrong]).astype(int)
                self.fs = self.plant.friction_state(m, x[:self.nv])
        return False

    def event_step(self, fired, g0, g1, x_new, t_new, k1, h) -> None:
        """The step (from x with derivative k1 over h, to x_new at t_new) in which the events
        ``fired`` (values g0 before, g1 after) crossed: the first is located on the step's
        cubic Hermite, the step redone exactly to it and the event applied there."""
        self.n_events += 1
        self.tick_events += 1
        if self.tick_events > _MAX_EVENTS_PER_TICK:
            raise SimulationError(
                f"more than {_MAX_EVENTS_PER_TICK} events within one servo tick at t = {self.t:.6g} s "
                "(chattering contact or stick-slip: reduce the contact stiffness or the servo gains)")
        x, t = self.x, self.t
        f1 = self.evaluate(x_new, t_new)[0]
        best_s, best_k = 2.0, None
        for key in fired:
            def gfun(s, key=key):
                if s <= 0.0:
                    return g0.get(key, -1.0)
                if s >= 1.0:
                    return g1[key]
                return self.event_values(_hermite(x, k1, x_new, f1, h, s), t + s * h)[0].get(key, -1.0)
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
            x, _ = self.rk4(x, h_ev, k1)
            self.xds.append(k1)
            self.t = t = t + h_ev
            self.ts.append(t)
        else:
            x = x.copy()
        self.x = x
        self.plant._t = t
        self.apply_event(best_k)
        if h_ev > 1e-15:
            self.xs.append(x)
        else:
            self.xs[-1] = x

    def apply_event(self, key: str) -> None:
        """Apply event ``key`` at (t, x) (x is a fresh array, changed in place)."""
        x, t, plant, ithd = self.x, self.t, self.plant, self.ithd
        if key == "contact_end":
            self.contacts[-1][1] = t
            if not self.post:   # the first contact is the impact the trial is about
                self.post = {"v_a": plant.tip_speed(x), "v_b": self.r * math.cos(x[self.nv]) * x[ithd],
                             "P": float(x[self.iP])}
            self.contact_v0 = None
            self.rebound_seen = x[ithd] < 0
            if self.t_catch is None:
                self.t_catch = t + self.catch_delay
        elif key == "contact_start":
            self.gap_end[:] = [0.0, 0.0, 0.0]
            _, dd, _ = plant.gap(x)
            self.contact_v0 = max(dd, 1e-9)
            self.contacts.append([t, None, self.contact_v0])
        elif key == "catch":
            self.caught = True
            x[ithd] = 0.0
        elif key.startswith("stop"):
            j = int(key[4:])
            x[self.iv0 + j] = 0.0      # the joint comes to rest: stick, or reverse
            self.settle_modes(x)
        else:  # break-away: at the located instant the holding torque sits on the
            # static limit, so release the joint in the direction it pushes (the
            # unchanged stick assignment is still "consistent" to rounding there)
            fs = self.fs
            j = int(key[5:])
            lam = plant.holding(x, self.tau, fs, self.contact_v0, t)[0]
            m = fs.modes.copy()
            m[j] = 1 if lam[fs.stuck.tolist().index(j)] < 0 else -1
            cand = self.consistent(x, m)
            if cand is not None:
                self.fs = cand
            else:
                self.settle_modes(x)

    def ticks(self) -> None:
        """The emulator's and the servo's ticks due at t: the emulator samples the F/T
        sensor, the servo's new output is held (and may break a stuck joint loose)."""
        t, T_emu = self.t, self.T_emu
        if T_emu is not None and self.k_emu * T_emu - t <= 1e-12:
            self.t = t = self.k_emu * T_emu
            self.ts[-1] = t
            x = self.x
            self.plant.on_emulator_tick(t, x, self.zero_xd if self.frozen() else self.evaluate(x, t)[0])
            self.k_emu += 1
        k_tick, T = self.k_tick, self.T
        if k_tick * T - t <= 1e-12:
            self.t = t = k_tick * T
            self.ts[-1] = t
            x, tau = self.x, self.tau
            tau_new = self.plant.servo(self.pid.update(x[self.arm_q]))
            changed = tau_new.tolist() != tau.tolist()   # (lists: a NumPy reduction costs 2 us)
            if changed:      # keep the same object otherwise: evaluations at this state stay valid
                self.tau = tau = tau_new
            self.servo_t.append(t)
            self.servo_tau.append(tau)
            self.k_tick = k_tick + 1
            self.tick_events = 0
            if self.friction_events and changed:
                self.plant._t = t
                self.settle_modes(x)   # a new torque may break a stuck joint loose at once

    def finish(self) -> None:
        """Close the buffers: the derivative at the last state. The first contact must have
        ended (its values go into the trajectory)."""
        self.xds.append(self.evaluate(self.x, self.t)[0])
        if self.contacts[-1][1] is None:
            raise SimulationError("the contact had not ended by the end of the trial (hammer pressed against the arm)")


def integrate_reference(plant, pid, *, t_contact, speed, servo_period, substeps_contact, substeps_free, min_post,
                        max_post, settle_velocity, stick_velocity, catch_delay=np.inf) -> Trajectory:
    """:func:`campaign.rig.integrate.integrate_trial` through this reference loop."""
    run = TrialRun(plant, pid, t_contact=t_contact, speed=speed, servo_period=servo_period,
                   substeps_contact=substeps_contact, substeps_free=substeps_free, min_post=min_post,
                   max_post=max_post, settle_velocity=settle_velocity, catch_delay=catch_delay)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if run.friction_events:
            run.settle_modes(run.x)
        while not run.finished():
            h, t_tick = run.step_length()
            if h is None:
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
    post = run.post
    return Trajectory(
        t=np.asarray(run.ts), x=np.asarray(run.xs), xd=np.asarray(run.xds),
        servo_t=np.asarray(run.servo_t), servo_tau=np.asarray(run.servo_tau),
        t_contact=t_contact, contacts=[tuple(c) for c in run.contacts],
        v_a_pre=0.0, v_b_pre=speed, v_a_post=post["v_a"], v_b_post=post["v_b"], impulse=post["P"],
        t_end=max(run.t, run.t_min_end), t_static=run.t_static, settled=run.settled, n_steps=run.n_steps,
        n_rhs=run.n_rhs, n_events=run.n_events, tau_static=run.tau_static, x0=run.x0,
    )
