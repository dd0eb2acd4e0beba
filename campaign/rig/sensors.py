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

from ..core.vocabulary import FIXED
from ..model.robot import load_robot
from .integrate import Trajectory
from .plant import FixedBasePlant, base_wrench

__all__ = ["StateSampler", "sample_grid", "quantize", "measured_quanta", "noise_streams", "base_wrench", "mount_wrenches", "truth_terms"]

STREAMS = ("contact_time", "joint_encoder", "pendulum_encoder", "piezo", "ft")


def noise_streams(seed: int) -> dict[str, np.random.Generator]:
    """One independent generator per channel, from the trial seed."""
    children = np.random.SeedSequence(seed).spawn(len(STREAMS))
    return {name: np.random.default_rng(c) for name, c in zip(STREAMS, children, strict=True)}


def sample_grid(rate: float, t_end: float) -> np.ndarray:
    """Sample times ``k / rate`` for ``k = 0 .. floor(t_end * rate)`` [s]."""
    n = int(np.floor(t_end * rate + 1e-9)) + 1
    return np.arange(n) / rate


def quantize(x, step: float):
    """Round to whole steps (``step = 0`` leaves ``x`` alone)."""
    if step <= 0:
        return np.asarray(x, dtype=float)
    return np.round(np.asarray(x, dtype=float) / step) * step


def measured_quanta(scene) -> dict[str, float | np.ndarray]:
    """The step of each quantised channel of a scene's ``/measured`` group, as the rig rounds
    them: ``q_enc`` (each joint's encoder resolution [rad]), ``theta_pend`` (the pendulum
    encoder's [rad]), ``f_piezo`` (the ADC step [N]); empty when the scene does not quantise."""
    p = scene.p
    if not bool(p("sensors.quantize")):
        return {}
    return {"q_enc": np.asarray(load_robot(p("robot")).encoder_resolution, dtype=float),
            "theta_pend": 2 * np.pi / float(p("sensors.pendulum_encoder_counts")),
            "f_piezo": float(p("sensors.piezo_resolution"))}


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
        (exact within contacts, zero outside them).

        Only the impulse column is interpolated, and only at samples inside a contact (the
        same cubic Hermite derivative as :meth:`__call__`, so the values are identical):
        outside the integration the impulse rate is zero."""
        tr = self.traj
        times = np.asarray(times, dtype=float)
        F = np.zeros(times.size)
        inside = np.zeros(times.size, dtype=bool)
        for (t0, t1, _v0) in tr.contacts:
            inside |= (times >= t0) & (times <= (t1 if t1 is not None else np.inf))
        inside &= (times >= tr.t_contact) & (times <= tr.t[-1])
        if np.any(inside):
            iP = self.plant.i_P
            tm = times[inside]
            i = np.clip(np.searchsorted(tr.t, tm, side="right") - 1, 0, tr.t.size - 2)
            h = tr.t[i + 1] - tr.t[i]
            s = (tm - tr.t[i]) / h
            s2 = s * s
            F[inside] = ((6 * s2 - 6 * s) * (tr.x[i, iP] - tr.x[i + 1, iP]) / h + (3 * s2 - 4 * s + 1) * tr.xd[i, iP]
                         + (3 * s2 - 2 * s) * tr.xd[i + 1, iP])
        return np.maximum(F, 0.0)


# -- fast recording: the per-sample Pinocchio evaluations of :func:`.trial.record` ----------
# Each sample costs a few Pinocchio calls (< 1 us each); everything around them is hoisted
# (frame ids, placements, the external-force vector) or done once over all samples in NumPy
# (0.5 v^T H v from the stack of mass matrices, n^T J v, the pendulum's and the contact's
# energy). The values are the plant's own evaluations (FixedBasePlant.energy / tip_speed /
# mount_wrench, IdealCouplingPlant.energy / tip_speed / mount_wrench, VesLoopPlant.energy_at /
# arm_at) up to round-off; tests/rig/test_rig.py checks them against plain per-sample Pinocchio.

def _kind(plant) -> str:
    """'fixed', 'ideal' (arm + structure integrated) or 'loop' (VES-prescribed platform)."""
    if hasattr(plant, "loop"):
        return "loop"
    if hasattr(plant, "ibase"):
        return "ideal"
    return FIXED


def _point_force(r, n: np.ndarray, R: np.ndarray, F: float) -> pin.Force:
    """Force ``n F`` (world axes) at the point ``r`` of a joint's frame (rotation ``R`` to the
    world), as a Pinocchio force in that joint's frame (RNEA's fext; as :func:`base_wrench`).
    The moment ``r x f`` is taken in Python floats (the same IEEE products and differences
    as NumPy's scalars, without their per-operation overhead)."""
    f0, f1, f2 = (R.T @ (n * F)).tolist()
    r0, r1, r2 = r
    return pin.Force(np.array([f0, f1, f2, r1 * f2 - r2 * f1, r2 * f0 - r0 * f2, r0 * f1 - r1 * f0]))


def mount_wrenches(plant, X, XD, F) -> np.ndarray:
    """F/T wrenches (n, 6: force [N], moment [N m]) of the arm on its mounting at states ``X``
    with derivatives ``XD`` and contact forces ``F`` (n each): the plant's ``mount_wrench``
    per row, in one tight loop (Pinocchio RNEA with the contact force as an external force on
    the link that carries the impact point).

    Fixed base: base frame, about the base origin. Ideal coupling: platform (mount) axes,
    about the mount origin, the free-flyer configuration from the state's chart."""
    kind = _kind(plant)
    if kind == "loop":
        raise ValueError("the VES loop samples its F/T sensor at the emulator ticks (plant.ticks())")
    X = np.asarray(X, dtype=float)
    XD = np.asarray(XD, dtype=float)
    F = np.asarray(F, dtype=float)
    N = X.shape[0]
    out = np.empty((N, 6))
    if N == 0:
        return out
    nv, n = plant.nv, plant.n
    if kind == FIXED:
        model, data, fid = plant.model, plant.data, plant.fid
        joint = 1                                 # the first joint: the wrench below it
        Q = X[:, :nv]
    else:
        model, data, fid = plant.fmodel, plant.fdata, plant.ffid
        joint = plant.arm_joint
        Q = np.array([plant.q7(x) for x in X[:, :nv]])
    V, A = X[:, plant.i_v], XD[:, plant.i_v]
    frame = model.frames[fid]
    jid = frame.parentJoint
    r = tuple(np.array(frame.placement.translation).tolist())
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    zero = pin.Force.Zero()
    oMi = data.oMi
    # live references into data (Pinocchio hands its elements by reference), read after
    # each RNEA: the wrench below ``joint`` and that joint's placement in the world; for
    # the fixed base joint 1 hangs from the universe, so its placement is RNEA's liMi[1]
    # (oMi[1] = oMi[0] liMi[1] with oMi[0] the identity) and no forward pass is needed
    f_joint = data.f[joint]
    M_joint = data.liMi[joint] if kind == FIXED else oMi[joint]
    fk, rnea = pin.forwardKinematics, pin.rnea
    if kind == "ideal":
        mount = plant.mount_id
        place = pin.updateFramePlacement
        M_mount = data.oMf[mount]
    for k, (q, v, a, Fk) in enumerate(zip(Q, V, A, F.tolist(), strict=True)):
        if Fk != 0.0:                             # (a NaN force still reaches the wrench)
            fk(model, data, q)
            fext[jid] = _point_force(r, n, oMi[jid].rotation, Fk)
            rnea(model, data, q, v, a, fext)
            fext[jid] = zero
        else:                                     # no external force: RNEA without fext is identical
            if kind != FIXED:
                fk(model, data, q)
            rnea(model, data, q, v, a)
        if kind == FIXED:
            out[k] = M_joint.act(f_joint).vector
        else:
            place(model, data, mount)
            out[k] = M_mount.actInv(M_joint.act(f_joint)).vector
    return np.negative(out, out=out)


def _platform_chart(pose, twist):
    """Free-flyer configurations (n, 7) and body twists (n, 6) of small-angle platform
    states ``pose``/``twist`` (n, 6 each): :func:`.flexible.platform_free_flyer` with zero
    acceleration, the matrix products done once over all rows."""
    pose = np.asarray(pose, dtype=float)
    twist = np.asarray(twist, dtype=float)
    N = pose.shape[0]
    R = np.empty((N, 3, 3))
    Jr = np.empty((N, 3, 3))
    exp3, Jexp3 = pin.exp3, pin.Jexp3
    for k in range(N):
        rv = pose[k, 3:]
        R[k] = exp3(rv)
        Jr[k] = Jexp3(rv)
    r = pose[:, 3:]
    angle = np.sqrt(r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1] + r[:, 2] * r[:, 2])
    small = angle < 1e-4
    with np.errstate(invalid="ignore", divide="ignore"):
        kq = np.where(small, 0.5 - angle * angle / 48.0, np.sin(0.5 * angle) / angle)
    q = np.empty((N, 7))
    q[:, 0:3] = pose[:, 0:3]
    q[:, 3:6] = kq[:, None] * r
    q[:, 6] = np.cos(0.5 * angle)
    v = np.empty((N, 6))
    v[:, 0:3] = np.einsum("kji,kj->ki", R, twist[:, :3])
    v[:, 3:6] = np.einsum("kij,kj->ki", Jr, twist[:, 3:])
    return q, v


def _kinematic_terms(model, data, fid: int, Q, V, *, need_J: bool, symmetrize: bool):
    """Per row of (Q, V): the mass matrix (stack), potential energy, impact-frame position
    and (``need_J``) its world-aligned linear Jacobian; one tight Pinocchio loop."""
    N, nv = Q.shape[0], model.nv
    H = np.empty((N, nv, nv))
    pe = np.empty(N)
    P = np.empty((N, 3))
    J = np.empty((N, 3, nv)) if need_J else None
    crba, jac, pot = pin.crba, pin.computeJointJacobians, pin.computePotentialEnergy
    place, fjac, lwa = pin.updateFramePlacement, pin.getFrameJacobian, pin.LOCAL_WORLD_ALIGNED
    M_tip = data.oMf[fid]                         # live reference, updated by place()
    for k in range(N):
        q = Q[k]
        H[k] = crba(model, data, q)
        jac(model, data, q)
        pe[k] = pot(model, data)                  # on the placements jac just computed
        place(model, data, fid)
        P[k] = M_tip.translation
        if need_J:
            J[k] = fjac(model, data, fid, lwa)[:3]
    if symmetrize:                                # lower triangle from the upper one (what
        iu, ju = np.triu_indices(nv, 1)           # np.triu(H) + np.triu(H, 1).T gives, exactly)
        H[:, ju, iu] = H[:, iu, ju]
    return H, pe, P, J


def truth_terms(plant, X, pre, post, pose=None, twist=None):
    """Truth energy [J] and tip speed along n [m/s] at states ``X`` (n rows).

    ``pre``/``post`` mark rows where the arm (and base) state is the same in every row (at
    rest before the touch, held after the integration stopped): one evaluation serves each
    group, only the pendulum's terms vary there; the tip speed is left 0 in those rows.
    ``pose``/``twist`` (n, 6) are the platform's for a VES-loop plant (its energy is
    :meth:`.flexible.VesLoopPlant.energy_at`, with the platform at rest in ``pre``/``post``
    rows, as the recording has always evaluated it).

    The energy is the plant's ``energy`` (``energy_at``): arm kinetic ``0.5 v^T H v`` and
    potential energy (Pinocchio), pendulum, contact spring (and the beam's for the ideal
    coupling); the tip speed is ``n^T J_lin v`` (``tip_speed`` / ``arm_at``)."""
    kind = _kind(plant)
    X = np.asarray(X, dtype=float)
    N = X.shape[0]
    pre, post = np.asarray(pre, bool), np.asarray(post, bool)
    mid = np.flatnonzero(~(pre | post))
    rows = [mid]
    for group in (pre, post):
        g = np.flatnonzero(group)
        rows.append(g[:1])
    sel = np.concatenate(rows)
    nm = mid.size
    nv = plant.nv
    Xs = X[sel]
    if kind == "loop":
        na = plant.na
        ps = np.zeros((sel.size, 6))
        ts = np.zeros((sel.size, 6))
        ps[:nm] = np.asarray(pose, float)[mid]
        ts[:nm] = np.asarray(twist, float)[mid]
        qb, vb = _platform_chart(ps, ts)
        Q = np.concatenate([qb, Xs[:, :na]], axis=1)
        V = np.concatenate([vb, Xs[:, plant.i_v]], axis=1)
        model, data, fid, sym = plant.fmodel, plant.fdata, plant.ffid, True
    elif kind == "ideal":
        Q = np.array([plant.q7(x) for x in Xs[:, :nv]])
        V = Xs[:, plant.i_v]
        model, data, fid, sym = plant.fmodel, plant.fdata, plant.ffid, True
    else:
        Q = Xs[:, :nv]
        V = Xs[:, plant.i_v]
        model, data, fid, sym = plant.model, plant.data, plant.fid, not getattr(plant, "_crba_full", False)
    H, pe_s, P, J = _kinematic_terms(model, data, fid, Q, V, need_J=True, symmetrize=sym)
    ke_s = 0.5 * np.einsum("ki,kij,kj->k", V, H, V)
    if kind == "loop":
        ke_s = ke_s - 0.5 * np.einsum("ki,kij,kj->k", V[:, :6], H[:, :6, :6], V[:, :6])
    s_s = (P - plant.p_tip0) @ plant.n
    v_s = np.einsum("kij,i,kj->k", J, plant.n, V)
    extra_s = np.array([plant.ibase.potential(q[:7]) for q in Q]) if kind == "ideal" else None
    # spread the evaluated rows over all samples
    ke, pe, s = np.empty(N), np.empty(N), np.empty(N)
    tip_v = np.zeros(N)
    extra = np.empty(N) if extra_s is not None else None
    ke[mid], pe[mid], s[mid], tip_v[mid] = ke_s[:nm], pe_s[:nm], s_s[:nm], v_s[:nm]
    if extra is not None:
        extra[mid] = extra_s[:nm]
    j = nm
    for group in (pre, post):
        if np.any(group):
            ke[group], pe[group], s[group] = ke_s[j], pe_s[j], s_s[j]
            if extra is not None:
                extra[group] = extra_s[j]
            j += 1
    th, thd = X[:, plant.i_th], X[:, plant.i_thd]
    ke = ke + 0.5 * plant._Ip * thd**2
    pe = pe + plant._mgl * (1.0 - np.cos(th))
    if extra is not None:
        pe = pe + extra
    delta = plant._r * np.sin(th) - s
    return ke + pe + plant.contact.energy(delta), tip_v
