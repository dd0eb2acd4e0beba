"""Closed-form propagation of the VES loop while the arm is a rigid body on the platform.

On the flexible base (``ves.mode = loop``) the arm is frozen once every joint is stuck, the
hammer is caught and the contact is over: nothing in the arm's state moves, the arm rides on
the platform as one rigid body, and the emulator (structure + latency + platform servo,
:class:`.ves.VesLoop`) is linear and time-invariant. What closes the loop is the F/T wrench
of the rigid arm on the platform::

    w = w(pose, twist, accel) = w_0 + W_p pose + W_a accel + O(|twist|^2, |pose| |accel|, |pose|^2)

(platform axes, about the mount: the arm's composite inertia times the platform's
acceleration, plus gravity turning with the platform's rotation). Dropping the second-order
terms makes the whole loop one affine map per emulator tick, ``xi_{k+1} = A xi_k``, on
``xi = [structure (12), platform pose and twist (12), platform acceleration (6), set-points
in flight (6 N), 1]``. :class:`FrozenArm` builds it from the plant's own Pinocchio model
(``W_0``, ``W_p``, ``W_a`` by differences of the F/T wrench the per-tick path samples, exact
in ``accel``, central in ``pose``) and :meth:`FrozenArm.propagate` runs it tick by tick as
matrix-vector products: no RNEA, no Python-side platform kinematics, no per-tick
consistency solve. The holding torques ``lam = -(tau - bias(pose, accel))`` are affine in
the same state, so the stick check of every tick comes with the same products; the
phase ends (and the per-tick path resumes) at the first tick where a joint would break loose.

What is dropped, and its size: the centrifugal and Coriolis wrench of the platform's twist
(``v x* I v``, quadratic in the twist) and the cross terms of the rotation with the
acceleration and with gravity (second order in the rotation). :func:`neglected_wrench`
evaluates them along a propagated phase against the exact wrench; the scene option
``flexible.linear_phases`` turns the propagation on (user guide and benchmarks/README.md:
the measured error and cost).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from .flexible import platform_free_flyer

__all__ = ["FrozenArm", "neglected_wrench", "frozen_wrench"]

#: central-difference step of the rotation derivative [rad] (and of the translation [m]):
#: truncation ~ step^2 / 6 relative, rounding ~ 1e-16 / step relative
_POSE_STEP = 1e-5
#: ticks of a closed-form phase's first chunk (then four times more each)
_FIRST_CHUNK = 32


def frozen_wrench(plant, q_arm, pose, accel, twist=None):
    """F/T wrench (6) of the frozen arm at ``q_arm`` on the platform at ``pose``/``twist``/
    ``accel`` (6 each), and the bias torques ``rnea(q, 0, [a_b, 0])_m`` (na): what the
    per-tick path computes at an emulator tick (:meth:`.flexible.VesLoopPlant.on_emulator_tick`,
    :meth:`.flexible.VesLoopPlant._bias`) with the arm still."""

    twist = np.zeros(6) if twist is None else np.asarray(twist, float)
    qb, vb, ab = platform_free_flyer(np.asarray(pose, float), twist, np.asarray(accel, float))
    na = plant.na
    qf = np.concatenate([qb, q_arm])
    vf = np.concatenate([vb, np.zeros(na)])
    af = np.concatenate([ab, np.zeros(na)])
    w = plant._mount_wrench6(qf, vf, af, 0.0)
    bias = np.array(pin.rnea(plant.fmodel, plant.fdata, qf, vf, af)[6:])
    return w, bias


class FrozenArm:
    """The VES loop closed through a frozen arm, as one affine map per emulator tick.

    Parameters
    ----------
    plant : VesLoopPlant
        The trial's plant (its F/T model, emulator matrices and latency).
    q_arm : ndarray, shape (na,)
        The arm's (frozen) joint angles [rad].
    pose_terms : bool, optional
        Keep the wrench's and the bias's dependence on the platform's pose (gravity seen in
        the tilted sensor's axes: a lateral force ``m g`` times the tilt, a ~0.1 % stiffness
        change of the space-class first mode). Off, the loop is closed through the arm's
        inertia alone, as :meth:`.ves.VesLoop.closed_loop_matrix` closes it (tests).

    Attributes
    ----------
    A_ : ndarray, shape (n, n)
        One tick of ``xi`` (layout in the module docstring).
    out_ : ndarray, shape (STEP_WIDTH, n)
        The emulator step's output (:meth:`.ves.VesLoop.advance`) as a function of ``xi``.
    w_ : ndarray, shape (6, n)
        The sampled F/T wrench as a function of ``xi``.
    bias_ : ndarray, shape (na, n)
        The arm's bias torques with the platform at the state's pose and acceleration.
    """

    def __init__(self, plant, q_arm, *, pose_terms: bool = True):
        loop = plant.loop
        self.plant = plant
        self.q_arm = np.asarray(q_arm, float).copy()
        na = plant.na
        N = loop.latency_ticks
        self.N = N
        n = 31 + 6 * N
        self.n = n
        ic = n - 1                           # the constant's column
        # -- the rigid arm's wrench and bias: affine in (pose, accel) -----------------------
        z6 = np.zeros(6)
        w0, b0 = frozen_wrench(plant, self.q_arm, z6, z6)
        Wa, Ba = np.zeros((6, 6)), np.zeros((na, 6))
        Wp, Bp = np.zeros((6, 6)), np.zeros((na, 6))
        for i in range(6):
            if not pose_terms:
                e = np.zeros(6)
                e[i] = 1.0
                w1, b1 = frozen_wrench(plant, self.q_arm, z6, e)
                Wa[:, i], Ba[:, i] = w1 - w0, b1 - b0
                continue
            e = np.zeros(6)
            e[i] = 1.0
            w1, b1 = frozen_wrench(plant, self.q_arm, z6, e)       # exact: linear in accel
            Wa[:, i], Ba[:, i] = w1 - w0, b1 - b0
            e[i] = _POSE_STEP
            wp, bp = frozen_wrench(plant, self.q_arm, e, z6)
            wm, bm = frozen_wrench(plant, self.q_arm, -e, z6)
            Wp[:, i], Bp[:, i] = (wp - wm) / (2 * _POSE_STEP), (bp - bm) / (2 * _POSE_STEP)
        self.w0, self.Wp, self.Wa, self.b0, self.Bp, self.Ba = w0, Wp, Wa, b0, Bp, Ba
        # -- the emulator's input vector [s, p, w, u0, u1, 1] (43) from xi ------------------
        W = np.zeros((6, n))
        W[:, 12:18] = Wp
        W[:, 24:30] = Wa
        W[:, ic] = w0
        Bsel = np.zeros((43, n))
        Bsel[0:24, 0:24] = np.eye(24)
        Bsel[24:30] = W
        if N:
            Bsel[30:36, 30:36] = np.eye(6)                                 # x_{k-N}
            Bsel[36:42, 36:42] = np.eye(6) if N >= 2 else np.zeros((6, 6))  # x_{k+1-N}
            if N == 1:
                Bsel[36:42, 0:6] = np.eye(6)                               # x_k itself
        Bsel[42, ic] = 1.0
        # einsum, not BLAS: a matrix product this size starts OpenBLAS's threads, whose
        # spinning afterwards costs the process more CPU than the whole propagation
        out = np.einsum("ij,jk->ik", loop._G, Bsel)
        A = np.zeros((n, n))
        A[0:24] = out[0:24]                    # structure, platform pose and twist
        A[24:30] = out[24:30]                  # platform acceleration
        if N:
            A[30:24 + 6 * N, 36:30 + 6 * N] = np.eye(6 * (N - 1))   # the set-points move up
            A[24 + 6 * N:30 + 6 * N, 0:6] = np.eye(6)               # x_k enters the line
        A[ic, ic] = 1.0
        self.A_, self.out_, self.w_ = A, out, W
        bias = np.zeros((na, n))
        bias[:, 12:18] = Bp
        bias[:, 24:30] = Ba
        bias[:, ic] = b0
        self.bias_ = bias
        # one product per tick gives the next state and the tick's outputs (matrix-vector
        # products this size stay on one thread)
        self._M = np.ascontiguousarray(np.vstack([A, out, W, bias]))

    # -- the loop's state in and out -------------------------------------------------------
    def state(self) -> np.ndarray:
        """``xi`` of the plant's emulator now (after its last tick)."""
        loop = self.plant.loop
        xi = np.empty(self.n)
        xi[0:24] = loop._in[0:24]
        xi[24:30] = loop._last[24:30]
        N = self.N
        if N:
            ring, j0 = loop._ring, loop._j0
            for i in range(N):
                xi[30 + 6 * i:36 + 6 * i] = ring[(j0 + i) % (N + 1)]
        xi[-1] = 1.0
        return xi

    def load(self, xi: np.ndarray, out: np.ndarray, ticks: int) -> None:
        """Set the plant's emulator to ``xi`` reached after ``ticks`` ticks whose last output was
        ``out`` (what :meth:`.ves.VesLoop.advance` leaves behind)."""
        loop = self.plant.loop
        loop._in[0:24] = xi[0:24]
        N = self.N
        if N:
            for i in range(N):
                loop._ring[i] = xi[30 + 6 * i:36 + 6 * i]
            loop._ring[N] = xi[0:6]
            loop._j0 = 0
        loop._last = out
        loop.tick += ticks

    # -- propagation -----------------------------------------------------------------------
    def propagate(self, xi0: np.ndarray, n: int) -> dict:
        """``n`` ticks from ``xi0``: the states after each tick ``X`` (n, size) and, per tick,
        the emulator step's output ``out`` (n, STEP_WIDTH), the sampled wrench ``w`` (n, 6)
        and the bias torques ``bias`` (n, na) at the state the tick starts from."""
        M = self._M
        size = self.n
        Y = np.empty((n, M.shape[0]))
        x = xi0
        for k in range(n):
            np.dot(M, x, out=Y[k])
            x = Y[k, :size]
        i1 = size + self.out_.shape[0]
        return {"X": Y[:, :size], "out": Y[:, size:i1], "w": Y[:, i1:i1 + 6], "bias": Y[:, i1 + 6:]}


def neglected_wrench(frozen: FrozenArm, X: np.ndarray, every: int = 1) -> tuple[float, float]:
    """The exact F/T wrench (twist, rotation-acceleration and second-order gravity terms
    included) against the affine one along the states ``X`` (every ``every``-th row).

    Returns
    -------
    (float, float)
        Largest ``|w_exact - w_affine|`` over the force rows [N] and the largest swing of
        the affine force from its rest value over the same rows [N].
    """
    err = swing = 0.0
    for xi in np.asarray(X)[::every]:
        w, _ = frozen_wrench(frozen.plant, frozen.q_arm, xi[12:18], xi[24:30], twist=xi[18:24])
        wl = frozen.w_ @ xi
        err = max(err, float(np.max(np.abs(w[:3] - wl[:3]))))
        swing = max(swing, float(np.max(np.abs(wl[:3] - frozen.w0[:3]))))
    return err, swing


def last_tick(t_end: float, period: float) -> int:
    """Index of the first tick at or after ``t_end - 1e-12`` (the integrator's stop test)."""
    k = max(0, math.ceil((t_end - 1e-12) / period))
    while k > 0 and (k - 1) * period >= t_end - 1e-12:
        k -= 1
    while k * period < t_end - 1e-12:
        k += 1
    return k


def run_frozen(plant, pid, x, tau, fs, k_first: int, k_last: int, period: float):
    """Ticks ``k_first .. k_last`` (emulator and servo, both at ``period``) of a frozen arm in
    closed form, up to the first tick where a joint would break loose.

    The per-tick path at a tick ``k`` checks the holding torques with the platform at ``t_k``
    and the torque held so far, samples the F/T wrench and steps the emulator, then updates
    the servo and checks the holding torques again if the torque changed: the same checks
    here, on every tick at once, with the platform from the affine loop and the torques from
    :meth:`.controller.PID.held`. The emulator's record, its state and the controller's
    state are left where that many per-tick steps leave them.

    Returns
    -------
    m : int
        Ticks done (0: the first tick breaks a joint loose; the caller steps it).
    taus : ndarray, shape (m, na)
        The servo torque held after each of them.
    """
    q = x[plant.arm_q]
    key = q.tobytes()
    frozen = plant._frozen.get(key)
    if frozen is None:
        if len(plant._frozen) > 8:
            plant._frozen.clear()
        frozen = plant._frozen[key] = FrozenArm(plant, q)
    n = k_last - k_first + 1
    tp = np.array([lim[0] for lim in fs.stuck_limits])
    tn = np.array([lim[1] for lim in fs.stuck_limits])
    done, chunk, held = 0, _FIRST_CHUNK, []
    while done < n:
        # chunks growing from a few dozen ticks: a phase that ends soon costs little
        c = min(chunk, n - done)
        run = frozen.propagate(frozen.state(), c)
        taus, e_sums, e = pid.held(q, c)
        # lam = -(tau - bias): with the torque held before the tick's servo update, then after it
        bad = np.zeros(c, bool)
        for lam in (run["bias"] - np.vstack([tau, taus[:-1]]), run["bias"] - taus):
            bad |= np.any(np.where(lam < 0, -lam - tp, lam - tn) > 0, axis=1)
        m = int(np.argmax(bad)) if bad.any() else c
        if m:
            out = run["out"]
            t = (k_first + done + np.arange(m)) * period
            plant.history.extend(zip(t.tolist(), run["w"][:m], out[:m], strict=True))
            frozen.load(run["X"][m - 1], out[m - 1], m)
            plant.t_last = float(t[-1])
            pid.set_state(e, e_sums[m - 1])
            tau = taus[m - 1]
            held.append(taus[:m])
            done += m
        if m < c:
            break
        chunk *= 4
    if done:
        plant._cache = {}
        plant._bias_last = None
    return done, (np.vstack(held) if held else np.zeros((0, q.size)))
