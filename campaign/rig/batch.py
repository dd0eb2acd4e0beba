"""Lock-step batched integration: a job's trials advance together through Pinocchio's batch API.

Every trial runs its own one-trial loop (:func:`.integrate.trial_steps`, the reference);
wherever that loop reaches a step the batch can take -- a fixed-base arm with not every
joint stuck, in or out of contact -- it hands the trial over (:class:`.integrate.Lane`).
All handed-over trials then take their steps together:

* one ``pinocchio.abaInParallel`` call per RK4 stage over the batch (a
  ``pinocchio.ModelPool`` of the shared arm model) and ``rneaInParallel`` for the holding
  torques of stuck joints; the rest of the right-hand side (held servo torque, Coulomb
  and viscous friction, the pendulum) as NumPy over the batch axis;
* per trial, what the batch API cannot evaluate: the contact's gap and Jacobian
  (``plant.gap``, Pinocchio kinematics) and a partly stuck arm's ABA on its reduced model
  (each trial locks its stuck joints at its own angles);
* the event checks (a slipping joint's velocity crossing zero, a stuck joint's holding
  torque reaching its static limit, the contact's start and end, the rebounding hammer's
  top), the servo tick (the counts PID of :class:`.controller.PID`, vectorised) and the
  end-of-recording check as NumPy.

A trial whose step would hold an event (a joint stopping or breaking loose, the contact
starting or ending, the hammer caught, a non-finite state) is not stepped here: it goes
back to its own loop at the state before that step, which locates and applies the event
as the one-trial path does, and rejoins the batch at its next step. A finished trial
leaves the batch; a failing one (:class:`~campaign.core.errors.SimulationError`) leaves it
with its error and the others go on.

Every operation here is the one-trial path's, element for element, in the same order
(``abaInParallel`` evaluates ABA in the world convention, which the one-trial path uses
too; ``rneaInParallel`` equals ``pin.rnea``), so a batched trial's trajectory, channels
and evaluation count equal its one-trial ones bit for bit (``tests/test_batched.py``).
Measured cost: ``benchmarks/README.md`` (section "Batched rig").
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..core.errors import SimulationError
from .integrate import Lane, trial_steps
from .simulate import build, integration_args, record_arrays
from .trial_run import _END_SCALE, EDGE_SUBSTEPS

__all__ = ["integrate_batch", "simulate_batch"]


class _Batch:
    """The steps of the trials sharing one arm model, as arrays over the batch axis (one row
    per trial handed over)."""

    def __init__(self, model, threads: int):
        self.model = model
        self.threads = int(threads)
        self.pool = pin.ModelPool(model, max(1, self.threads))
        self.nv = model.nv
        self.ids: list[int] = []
        self.lanes: list[Lane] = []
        self.accepted = 0      # steps taken here (the benchmark's share of the batch)
        self._arrays = None
        self._pending: list[dict] = []   # rows handed over since the last step, joined at the next

    # -- membership -------------------------------------------------------------------
    def add(self, i: int, ln: Lane) -> None:
        """Take trial ``i`` over at the state its loop handed over."""
        plant, pid = ln.plant, ln.pid
        fs = ln.fs
        res, ref, gc, lo, hi = (np.array(c, dtype=float) for c in zip(*pid._joints, strict=True))
        row = {
            "X": np.array(ln.x, dtype=float), "t": ln.t, "k": ln.k_tick, "T": ln.T,
            "tmin": ln.t_min_end, "tmax": ln.t_max_end, "settle": ln.settle_velocity, "fric": ln.friction_events,
            "tau": np.array(ln.tau, dtype=float), "coul": np.asarray(fs.coulomb, dtype=float),
            "visc": np.asarray(plant.viscous, dtype=float),
            "modes": fs.modes.astype(float), "slip": np.asarray(plant.sticky, dtype=bool) & (fs.modes != 0),
            "stuck": fs.stuck_mask.copy(), "tcp": np.asarray(plant.tc_pos, dtype=float),
            "tcn": np.asarray(plant.tc_neg, dtype=float),
            "res": res, "ref": ref, "gc": gc, "lo": lo, "hi": hi,
            "kP": pid._kP, "kD": pid._kD, "kI": pid._kI, "quant": bool(pid.quantize), "active": pid.active,
            "clipgc": np.minimum(np.maximum(pid.tau_gc, pid._lo), pid.tau_max),
            "eprev": np.array(pid._e_prev, dtype=float), "esum": np.array(pid._e_sum, dtype=float),
            "nsteps": ln.n_steps, "nrhs": ln.n_rhs, "k1c": ln.k1_cached, "ticked": False,
            "caught": ln.caught, "tcatch": ln.t_catch, "reuse": ln.reuse_eval,
            "v0": np.nan if ln.contact_v0 is None else ln.contact_v0, "inc": ln.contact_v0 is not None,
            "t0c": ln.contact_t0, "subc": ln.sub_contact, "subf": ln.sub,
            "ge0": ln.gap_end[0], "ge1": ln.gap_end[1], "ge2": ln.gap_end[2],
            "K1": np.zeros(len(ln.x)), "k1ok": False,
            "r": plant._r, "mgl": plant._mgl, "Ip": plant._Ip,
        }
        self._pending.append(row)
        self.ids.append(i)
        self.lanes.append(ln)

    def _join(self) -> None:
        """Append the rows handed over since the last step to the arrays (one
        concatenation per array for all of them)."""
        rows, self._pending = self._pending, []
        if not rows:
            return
        new = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        a = self._arrays
        self._arrays = new if a is None else {k: np.concatenate([a[k], v.astype(a[k].dtype)]) for k, v in new.items()}
        # the held torque less the Coulomb torque of the slipping joints (the constant part
        # of FixedBasePlant._loads)
        self._arrays["C2"] = self._arrays["tau"] - self._arrays["coul"]

    def release(self, rows) -> list[tuple[int, Lane]]:
        """Write the rows' states back into their lanes and drop them from the batch."""
        self._join()
        a = self._arrays
        out = []
        for r in rows:
            ln = self.lanes[r]
            ln.x = a["X"][r].copy()
            ln.t = float(a["t"][r])
            ln.k_tick = int(a["k"][r])
            if not np.array_equal(a["tau"][r], ln.tau):
                ln.tau = a["tau"][r].copy()
            ln.pid.e_prev = a["eprev"][r]
            ln.pid.e_sum = a["esum"][r]
            ln.n_steps, ln.n_rhs = int(a["nsteps"][r]), int(a["nrhs"][r])
            ln.ticked, ln.k1_cached = bool(a["ticked"][r]), bool(a["k1c"][r])
            ln.gap_end[:] = [float(a["ge0"][r]), float(a["ge1"][r]), float(a["ge2"][r])]
            out.append((self.ids[r], ln))
        keep = np.ones(len(self.ids), dtype=bool)
        keep[list(rows)] = False
        if keep.any():
            self._arrays = {k: v[keep] for k, v in a.items()}
        else:
            self._arrays = None
        self.ids = [i for i, k in zip(self.ids, keep, strict=True) if k]
        self.lanes = [ln for ln, k in zip(self.lanes, keep, strict=True) if k]
        return out

    def __len__(self) -> int:
        return len(self.ids)

    # -- dynamics ---------------------------------------------------------------------
    def _f(self, X, C2, rows=None, with_lam=False):
        """State derivatives and the stuck joints' holding torques of batch rows ``rows``
        (all by default) at states ``X`` with held torques less Coulomb ``C2`` (one row
        each), as FixedBasePlant.evaluate gives them: ``q' = v``, ``theta' = thetadot``,
        ``v' = a``, ``thetadot'`` the pendulum's swing under the contact force (zero once
        caught), ``P' = F``; ``a`` the accelerations of the constrained dynamics under the
        servo, friction and contact torques (batched ABA; with joints stuck, the reduced
        model's ABA per trial), and with ``with_lam`` the stuck joints' holding torques
        (batched RNEA)."""
        c = self._arrays
        if rows is not None:
            c = {k: c[k][rows] for k in ("visc", "stuck", "inc", "v0", "caught", "mgl", "r", "Ip")}
        nv = self.nv
        m = X.shape[0]
        Q = X[:, :nv].T
        V = X[:, nv + 1:2 * nv + 1]
        tau = C2 - c["visc"] * V
        F = np.zeros(m)
        inc = c["inc"]
        if inc.any():
            # the contact force and its Jacobian: the plant's own kinematics, per trial
            Jn = np.zeros((m, nv))
            v0 = c["v0"].tolist()
            for i in np.flatnonzero(inc).tolist():
                plant = self.lanes[i if rows is None else rows[i]].plant
                d, dd, J = plant.gap(X[i])
                F[i] = plant.contact_force(d, dd, v0[i])
                Jn[i] = J
            tau = np.where((F > 0.0)[:, None], tau + Jn * F[:, None], tau)
        stuck = c["stuck"]
        some = stuck.any(axis=1)
        A = np.empty((m, nv)).T          # (nv, m), column-major: Pinocchio writes it in place
        pin.abaInParallel(self.threads, self.pool, Q, V.T, tau.T, A)
        a = A.T
        lam = None
        if some.any():
            # a partly stuck arm: ABA of the free joints on its reduced model (the stuck
            # joints locked at their angles), trial by trial as FixedBasePlant._accel does
            a = a.copy()
            for i in np.flatnonzero(some).tolist():
                fs = self.lanes[i if rows is None else rows[i]].fs
                rm, rd = fs.reduced
                free = fs.free
                ai = np.zeros(nv)
                ai[free] = pin.aba(rm, rd, Q[:, i][free], V[i][free], tau[i][free])
                a[i] = ai
            if with_lam:
                # holding torques (FixedBasePlant.constrained): rnea(q, v, a)_S - tau_S
                R = np.empty((m, nv)).T
                pin.rneaInParallel(self.threads, self.pool, Q, V.T, np.ascontiguousarray(a).T, R)
                lam = np.where(stuck, R.T - tau, 0.0)
        XD = np.empty_like(X)
        XD[:, :nv + 1] = X[:, nv + 1:2 * nv + 2]
        XD[:, nv + 1:2 * nv + 1] = a
        th = X[:, nv]
        # FixedBasePlant._derivative, operation for operation
        XD[:, 2 * nv + 1] = np.where(c["caught"], 0.0, ((-c["mgl"]) * np.sin(th) - (F * c["r"]) * np.cos(th)) / c["Ip"])
        XD[:, 2 * nv + 2] = F
        return XD, lam

    def _violations(self, lam, rows, scale=1.0):
        """Per row of ``rows``: does a stuck joint's holding torque exceed its static limit
        (times ``scale``)? (FrictionState.violations and the consistency check of trial_steps)"""
        a = self._arrays
        tp, tn = a["tcp"][rows], a["tcn"][rows]
        if scale != 1.0:
            tp, tn = tp * scale, tn * scale
        over = np.where(lam < 0, -lam - tp, lam - tn) > 0
        return (over & a["stuck"][rows]).any(axis=1)

    def step(self) -> list[int]:
        """One plain iteration of every trial in the batch (an RK4 step to the next substep
        or servo tick, the stop-event check, the tick); returns the rows to hand back to
        their loops: those whose step held an event (state left before the step) and those
        whose recording may end (state after it)."""
        self._join()
        a = self._arrays
        nv = self.nv
        X = a["X"]
        h, t_new, t_tick, catch_now = self._step_lengths()
        H = h[:, None]
        C2, stuck = a["C2"], a["stuck"]
        some_stuck = stuck.any(axis=1)
        # k1: an evaluation at this state made at the last step's end, where there is one
        # (the same inputs, so the same numbers), else made now
        fresh = np.flatnonzero(~a["k1ok"])
        if fresh.size == len(t_new):
            k1 = self._f(X, C2)[0]
        else:
            k1 = a["K1"].copy()
            if fresh.size:
                k1[fresh] = self._f(X[fresh], C2[fresh], fresh)[0]
        k2 = self._f(X + (0.5 * H) * k1, C2)[0]
        k3 = self._f(X + (0.5 * H) * k2, C2)[0]
        k4 = self._f(X + H * k3, C2)[0]
        Xn = X + (H / 6.0) * (k1 + k4 + 2.0 * (k2 + k3))
        inc = a["inc"]
        flying = ~a["caught"] & ~inc
        event, d1, dd1, K1, k1ok = self._events(Xn, h, catch_now, flying, some_stuck)
        ticked, t_fin, e, s, tau_new, changed, settle = self._servo_tick(Xn, t_new, t_tick, event, K1, k1ok,
                                                                          some_stuck)
        ok = ~event
        # -- commit the rows without events ----------------------------------------------
        upd = ok & ticked
        act_upd = upd & a["active"]
        a["eprev"][act_upd] = e[act_upd]
        a["esum"][act_upd] = s[act_upd]
        ch = ok & changed
        a["tau"][ch] = tau_new[ch]
        a["C2"][ch] = tau_new[ch] - a["coul"][ch]
        X[ok] = Xn[ok]
        self.accepted += int(ok.sum())
        t = a["t"]
        t[ok] = t_fin[ok]
        a["k"][upd] += 1
        a["ticked"] |= upd
        a["nsteps"][ok] += 1
        # counted as the loop counts them: k1 unless its last evaluation was at this state,
        # three stages, the step end's evaluation where holding torques are checked, the
        # consistency evaluation after a new torque; either of the last two serves as the
        # next step's k1
        # the contact's overlap at accepted steps, for the edge refinement
        acc_c = ok & inc
        a["ge2"][acc_c] = np.maximum(a["ge2"][acc_c], d1[acc_c])
        a["ge0"][acc_c], a["ge1"][acc_c] = d1[acc_c], dd1[acc_c]
        at_end = some_stuck | ((flying | inc) & a["reuse"])
        a["nrhs"][ok] += np.where(a["k1c"][ok], 3, 4) + at_end[ok] + settle[ok]
        a["k1c"][ok] = settle[ok] | at_end[ok]
        a["K1"][ok] = K1[ok]
        a["k1ok"][ok] = k1ok[ok]
        self._append_to_lanes(ok, upd, k1, Xn, t_fin)
        # -- the end-of-recording check (TrialRun.finished) ---------------------------------
        static = ~a["fric"] & (np.max(np.abs(X[:, nv + 1:2 * nv + 1]), axis=1) < a["settle"])
        ends = ~inc & ((static & a["caught"]) | ((t >= a["tmin"] - 1e-12) & (static | (t >= a["tmax"] - 1e-12))))
        return np.flatnonzero(event | (ok & ends)).tolist()

    def _step_lengths(self):
        """Per row, the step's length ``h`` and end ``t_new``, the next tick ``t_tick`` and
        whether the hammer's catch is due now (left to the trial's loop): the substeps of
        the contact (finer at its edges) or of the free arm, up to the tick or the catch
        (:meth:`.trial_run.TrialRun.step_length` and ``rk4_step``, operation for operation)."""
        a = self._arrays
        t, k, T = a["t"], a["k"], a["T"]
        t_tick = k * T
        inc = a["inc"]
        edge = inc & ((t < a["t0c"] + T) | ((a["ge1"] < 0) & (a["ge0"] < 0.25 * a["ge2"])))
        sub = np.where(inc, a["subc"], a["subf"])
        sub = np.where(edge, np.maximum(sub, EDGE_SUBSTEPS), sub)
        h = np.minimum(T / sub, t_tick - t)
        to_catch = a["tcatch"] - t
        catch_now = ~a["caught"] & (to_catch <= h) & (to_catch <= 1e-15)
        h = np.where(~a["caught"] & (to_catch <= h), to_catch, h)
        t_new = t + h
        t_new = np.where(np.abs(t_new - t_tick) <= 1e-12, t_tick, t_new)
        return h, t_new, t_tick, catch_now

    def _events(self, Xn, h, catch_now, flying, some_stuck):
        """Per row, does the step to ``Xn`` hold an event this loop does not handle (left to
        the trial's own loop): the catch, a non-finite state, a joint stopping, the hammer
        reaching its top or touching the arm, the contact ending, a stuck joint's holding
        torque reaching its static limit. Returns ``(event, d1, dd1, K1, k1ok)``: the events,
        the contact's overlap and rate at the step end (in contact), and the evaluation made
        there for the holding torques (the next step's k1 where ``k1ok``)."""
        a = self._arrays
        nv = self.nv
        n = len(h)
        Vn = Xn[:, nv + 1:2 * nv + 1]
        inc = a["inc"]
        event = catch_now | ~(h > 1e-15) | ~np.isfinite(Xn.sum(axis=1)) | ~np.isfinite(Xn).all(axis=1)
        event |= (a["slip"] & (a["modes"] * Vn < 0)).any(axis=1)        # a joint stops
        # the rebounding hammer reaches its top (thetadot crosses zero upward)
        event |= flying & (Xn[:, 2 * nv + 1] > 0)
        d1, dd1 = np.zeros(n), np.zeros(n)
        v0 = a["v0"].tolist()
        for r in np.flatnonzero((flying | inc) & ~event).tolist():
            # ... or touches the arm again, or the contact ends: the gap from the plant's own
            # kinematics, the event values TrialRun.event_values computes
            plant = self.lanes[r].plant
            d, dd, _ = plant.gap(Xn[r])
            if inc[r]:
                if -min(d, _END_SCALE * (1.0 + plant._d * dd / v0[r])) > 0:
                    event[r] = True
                d1[r], dd1[r] = d, dd
            elif d > 0:
                event[r] = True
        K1 = np.zeros_like(Xn)           # the next step's k1, where evaluated below
        k1ok = np.zeros(n, dtype=bool)
        sr = np.flatnonzero(some_stuck & ~event)
        if sr.size:
            # a stuck joint's holding torque at the step's end reaches its static limit
            K1[sr], lam = self._f(Xn[sr], a["C2"][sr], sr, with_lam=True)
            k1ok[sr] = True
            event[sr] |= self._violations(lam, sr)
        return event, d1, dd1, K1, k1ok

    def _servo_tick(self, Xn, t_new, t_tick, event, K1, k1ok, some_stuck):
        """The servo tick of the rows whose step ends on one (:meth:`.controller.PID.update`
        on the batch axis): ``(ticked, t_fin, e, s, tau_new, changed, settle)``, the step's
        end time, the PID's new error and sum, the new torque, where it changed and where
        that needs the friction modes checked. Adds to ``event`` (a new torque with a
        slipping joint at rest, or breaking a stuck one loose), ``K1`` and ``k1ok`` (the
        consistency evaluation under the new torque) in place."""
        a = self._arrays
        nv = self.nv
        ticked = (a["k"] * a["T"] - t_new) <= 1e-12
        t_fin = np.where(ticked, t_tick, t_new)
        c = Xn[:, :nv] / a["res"]
        e = a["ref"] - np.where(a["quant"][:, None], np.rint(c), c)
        s = a["esum"] + e
        u = a["kP"][:, None] * e + a["kD"][:, None] * (e - a["eprev"]) + a["kI"][:, None] * s + a["gc"]
        act = a["active"][:, None]
        tau_new = np.where(act, np.minimum(np.maximum(u, a["lo"]), a["hi"]), a["clipgc"])
        changed = ticked & (tau_new != a["tau"]).any(axis=1)
        settle = changed & a["fric"]
        # a new torque with a slipping joint exactly at rest, or a stuck one it breaks loose,
        # needs the loop's mode search
        Vn = Xn[:, nv + 1:2 * nv + 1]
        event |= settle & (a["slip"] & (Vn == 0.0)).any(axis=1)
        k1ok &= ~changed                 # evaluated with the torque held before the tick
        cr = np.flatnonzero(settle & some_stuck & ~event)
        if cr.size:
            K1[cr], lam = self._f(Xn[cr], tau_new[cr] - a["coul"][cr], cr, with_lam=True)
            k1ok[cr] = True
            event[cr] |= self._violations(lam, cr, 1 + 1e-12)
        return ticked, t_fin, e, s, tau_new, changed, settle

    def _append_to_lanes(self, ok, upd, k1, Xn, t_fin) -> None:
        """Append the accepted rows' steps (and servo ticks, ``upd``) to their lanes' buffers."""
        a = self._arrays
        tl = t_fin.tolist()
        for r in np.flatnonzero(ok).tolist():
            ln = self.lanes[r]
            ln.xds.append(k1[r])
            ln.xs.append(Xn[r])
            ln.ts.append(tl[r])
            if upd[r]:
                ln.servo_t.append(tl[r])
                ln.servo_tau.append(a["tau"][r].copy())


def integrate_batch(jobs, *, threads: int = 1, on_done=None) -> list:
    """Integrate many trials in lock-step (module docstring).

    Parameters
    ----------
    jobs : sequence of (plant, pid, dict)
        Per trial, what :func:`.integrate.integrate_trial` takes: the plant, its PID and the
        integration keyword arguments.
    threads : int
        OpenMP threads of each batched Pinocchio call (one by default: the workflow runs
        jobs side by side).
    on_done : callable, optional
        Called as ``on_done(i, result)`` when trial ``i`` has finished or failed.

    Returns
    -------
    list
        Per trial, its :class:`.integrate.Trajectory`, or the
        :class:`~campaign.core.errors.SimulationError` that ended it (the others are unaffected).
    """
    n = len(jobs)
    results: list = [None] * n
    gens = []
    batches: list[_Batch] = []

    def finish(i, value):
        results[i] = value
        if on_done is not None:
            on_done(i, value)

    def resume(i, msg):
        """Run trial ``i``'s loop to its next hand-over (returned) or to its end (None)."""
        try:
            return gens[i].send(msg)
        except StopIteration as done:
            finish(i, done.value)
        except SimulationError as err:
            finish(i, err)
        return None

    def enter(i, ln):
        for b in batches:
            if b.model == ln.plant.model:
                b.add(i, ln)
                return
        b = _Batch(ln.plant.model, threads)
        b.add(i, ln)
        batches.append(b)

    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for i, (plant, pid, kwargs) in enumerate(jobs):
            gens.append(trial_steps(plant, pid, lane=True, **kwargs))
            ln = resume(i, None)
            if ln is not None:
                enter(i, ln)
        while any(len(b) for b in batches):
            for b in batches:
                if not len(b):
                    continue
                rows = b.step()
                if not rows:
                    continue
                for i, ln in b.release(rows):
                    # back in its loop: it offers the same state again at once; decline, so
                    # it takes that step (and any that follow) itself until its next plain one
                    ln = resume(i, True)
                    if ln is not None:
                        ln = resume(i, False)
                    if ln is not None:
                        enter(i, ln)
    return results


def simulate_batch(scenes, *, integration: dict | None = None, threads: int = 1, on_done=None) -> list:
    """Simulate many trials through :func:`integrate_batch`; per scene what
    :func:`.simulate.simulate_arrays` returns (the same arrays), or the
    :class:`~campaign.core.errors.SimulationError` that ended that trial.

    Every scene is built and checked first (:func:`.simulate.build`), so a bad input raises
    its :class:`~campaign.core.errors.InputError` before any trial is integrated.
    ``on_done(i, result)`` is called as each trial is recorded or fails.
    """

    rigs = [build(scene, integration=integration) for scene in scenes]
    jobs = [(rig.plant, rig.pid, integration_args(rig)) for rig in rigs]
    out: list = [None] * len(rigs)

    def recorded(i, traj):
        # record as each trial ends: its trajectory is not kept past its own recording
        if not isinstance(traj, SimulationError):
            try:
                trial = record_arrays(rigs[i], traj)
                trial.attrs["integration_steps"] = int(traj.n_steps)
                trial.attrs["integration_rhs_evaluations"] = int(traj.n_rhs)
                traj = trial
            except SimulationError as err:
                traj = err
        out[i] = traj
        if on_done is not None:
            on_done(i, traj)

    integrate_batch(jobs, threads=threads, on_done=recorded)
    return out
