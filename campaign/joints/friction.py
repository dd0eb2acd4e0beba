"""Coulomb friction impulses with sticking: the joints' velocity after a friction impulse.

Over a short step a joint can lose at most the impulse ``kappa`` its Coulomb friction
delivers (the level times the step); a joint whose motion needs less than that to stop
stays still. With the joints' velocity-level inertia ``A`` (symmetric positive definite)
and their velocity ``v`` before the impulse, the velocity after it is

    x = argmin 1/2 x^T A x - (A v)^T x + sum_j (kappa_pos_j max(x_j, 0) + kappa_neg_j max(-x_j, 0)),

the implicit (Moreau) friction step of a time-stepping scheme: slipping joints move in their
friction's direction, stuck joints' holding impulse stays within ``[-kappa_neg, kappa_pos]``.
:func:`stick_slip` finds the stick/slip assignment whose conditions hold, trying each row's
previous assignment first (over a contact the assignment rarely changes from one step to
the next), then moving each violated joint where its violation points (an active set), and
enumerating the ``3^nv`` assignments only for the rows where a few rounds of that fail.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np

__all__ = ["stick_slip", "StickSlip"]

#: rounds of the active-set search before the remaining rows enumerate every assignment
ACTIVE_SET_ROUNDS = 4
#: slack of the stick/slip conditions, relative to the largest generalised momentum of the row
_TOL = 1e-12


@functools.lru_cache(maxsize=8)
def _assignments(nv: int) -> np.ndarray:
    """Every stick (0) / slip (+-1) assignment of ``nv`` joints, all stuck first."""
    return np.array(list(itertools.product((0, 1, -1), repeat=nv)), int)


def _try(A, b, kp, kn, mode, tol):
    """Velocities under the assignments ``mode`` (rows, nv), whether their conditions hold,
    and the assignments the violated conditions point to (a slipping joint moving against its
    friction sticks, a stuck joint held beyond its static level slips that way)."""
    free = mode != 0
    kappa = np.where(mode > 0, kp, np.where(mode < 0, -kn, 0.0))
    eye = np.eye(A.shape[-1])
    # stuck joints decoupled and held at zero: solve the free joints' block only
    both = free[:, :, None] & free[:, None, :]
    Am = np.where(both, A, eye)
    rhs = np.where(free, b - kappa, 0.0)
    x = np.linalg.solve(Am, rhs[:, :, None])[:, :, 0]
    backward = free & (x * mode < 0.0)
    hold = b - np.einsum("rij,rj->ri", A, x)
    push = ~free & (hold > kp + tol[:, None])
    pull = ~free & (hold < -kn - tol[:, None])
    ok = ~np.any(backward | push | pull, axis=1)
    nxt = np.where(backward, 0, np.where(push, 1, np.where(pull, -1, mode)))
    return x, ok, nxt


def stick_slip(A, b, *, kappa_pos, kappa_neg, modes=None) -> tuple[np.ndarray, np.ndarray]:
    """Joint velocities after a Coulomb friction impulse, and each joint's stick/slip mode.

    Parameters
    ----------
    A : ndarray, shape (R, nv, nv)
        Velocity-level inertia of the joints (symmetric positive definite).
    b : ndarray, shape (R, nv)
        ``A v``: the joints' generalised momentum before the impulse.
    kappa_pos, kappa_neg : array_like, shape (R, nv) or (nv,)
        The largest friction impulse against positive and negative motion [N m s], >= 0.
    modes : ndarray of int, shape (R, nv), optional
        An assignment to try first for each row (0 stuck, +-1 slipping).

    Returns
    -------
    x : ndarray, shape (R, nv)
        The velocities after the impulse; ``A^-1 b`` where ``kappa = 0``.
    modes : ndarray of int, shape (R, nv)
    """
    A = np.asarray(A, float)
    b = np.asarray(b, float)
    R, nv = b.shape
    kp = np.broadcast_to(np.asarray(kappa_pos, float), (R, nv))
    kn = np.broadcast_to(np.asarray(kappa_neg, float), (R, nv))
    tol = _TOL * (1.0 + np.abs(b).max(axis=1))
    x_out = np.zeros((R, nv))
    m_out = np.zeros((R, nv), int)
    # active set: from the given assignments (all stuck by default), move each violated
    # joint to the assignment its violation points to; a few rounds settle almost every row
    rows = np.arange(R)
    mode = np.zeros((R, nv), int) if modes is None else np.array(modes, int)
    for _ in range(ACTIVE_SET_ROUNDS):
        x, ok, nxt = _try(A[rows], b[rows], kp[rows], kn[rows], mode, tol[rows])
        x_out[rows[ok]], m_out[rows[ok]] = x[ok], mode[ok]
        rows, mode = rows[~ok], nxt[~ok]
        if rows.size == 0:
            break
    for mode in _assignments(nv):
        if rows.size == 0:
            break
        m = np.broadcast_to(mode, (rows.size, nv))
        x, ok, _ = _try(A[rows], b[rows], kp[rows], kn[rows], m, tol[rows])
        x_out[rows[ok]], m_out[rows[ok]] = x[ok], mode
        rows = rows[~ok]
    if rows.size:   # pragma: no cover - the convex problem always has one consistent assignment
        raise FloatingPointError("stick_slip: no consistent stick/slip assignment")
    return x_out, m_out


class StickSlip:
    """:func:`stick_slip` for many steps of C cases x D variants whose inertia ``A`` is one per
    case: the inverse of ``A``'s block over every set of slipping joints is computed once, so
    a step is a few array operations (no linear solve).

    Parameters
    ----------
    A : ndarray, shape (C, nv, nv)
        Velocity-level inertia of the joints per case (symmetric positive definite).
    """

    def __init__(self, A):
        A = np.asarray(A, float)
        C, nv = A.shape[0], A.shape[-1]
        self.A = A
        self.nv = nv
        subsets = 1 << nv
        inv = np.zeros((C, subsets, nv, nv))
        for sid in range(1, subsets):
            free = np.array([(sid >> j) & 1 for j in range(nv)], bool)
            idx = np.flatnonzero(free)
            inv[:, sid][:, idx[:, None], idx[None, :]] = np.linalg.inv(A[:, idx][:, :, idx])
        self.inv = inv.reshape(C * subsets, nv, nv)           # case c, subset s at c * subsets + s
        self._full = inv[:, subsets - 1]                       # A^-1: every joint slipping
        self._bits = 1 << np.arange(nv)
        self._offset = (np.arange(C) * subsets)[:, None]
        self._A = A[:, None]
        self._rows = None

    def _try(self, sid0, A, b, kp, kn, mode):
        """:func:`_try` for rows whose case offsets are ``sid0`` and inertia ``A`` (rows, nv, nv)."""
        free = mode != 0
        kappa = np.where(mode > 0, kp, np.where(mode < 0, -kn, 0.0))
        Ainv = np.take(self.inv, free @ self._bits + sid0, axis=0)          # (rows, nv, nv)
        r = np.where(free, b - kappa, 0.0)
        x = _matvec(Ainv, r)
        hold = b - _matvec(A, x)
        tol = _TOL * (1.0 + np.abs(b).max(axis=-1, keepdims=True))
        backward = free & (x * mode < 0.0)
        push = ~free & (hold > kp + tol)
        pull = ~free & (hold < -kn - tol)
        bad = backward | push | pull
        return x, ~bad.any(axis=-1), np.where(backward, 0, np.where(push, 1, np.where(pull, -1, mode)))

    def step(self, v, *, kappa_pos, kappa_neg, modes=None) -> tuple[np.ndarray, np.ndarray]:
        """Velocities (C, D, nv) after the friction impulses ``kappa`` (broadcast to (C, D, nv))
        from the velocities ``v``, and the modes; ``modes`` is the assignment to try first."""
        v = np.asarray(v, float)
        C, D, nv = v.shape
        if self._rows is None or self._rows[0] != D:
            # every variant of a case shares its inertia: expanded once per shape, not per step
            self._rows = (D, np.broadcast_to(self._A, (C, D, nv, nv)).reshape(-1, nv, nv),
                          np.broadcast_to(self._offset, (C, D)).reshape(-1))
        _, A, sid0 = self._rows
        vr = v.reshape(-1, nv)
        kp = np.broadcast_to(np.asarray(kappa_pos, float), v.shape).reshape(-1, nv)
        kn = np.broadcast_to(np.asarray(kappa_neg, float), v.shape).reshape(-1, nv)
        mode = np.zeros((C * D, nv), int) if modes is None else np.asarray(modes, int).reshape(-1, nv)
        x_out = np.zeros((C * D, nv))
        m_out = mode.copy()
        # the two common cases need no solve: every joint slipping on (x = v - A^-1 kappa(signs)),
        # every joint held (x = 0 while the holding impulse A v stays within the static levels)
        slipping = np.all(mode != 0, axis=1)
        kappa = np.where(mode > 0, kp, -kn).reshape(C, D, nv)
        x = vr - np.einsum("cij,cdj->cdi", self._full, kappa).reshape(-1, nv)
        ok = slipping & np.all(x * mode > 0.0, axis=1)
        x_out[ok] = x[ok]
        b = _matvec(A, vr)
        held = ~np.any(mode, axis=1) & np.all((b <= kp) & (b >= -kn), axis=1)
        ok |= held
        if ok.all():
            return x_out.reshape(C, D, nv), m_out.reshape(C, D, nv)
        rows = np.flatnonzero(~ok)
        x, ok2, nxt = self._try(sid0[rows], A[rows], b[rows], kp[rows], kn[rows], mode[rows])
        x_out[rows[ok2]] = x[ok2]
        rows, mode = rows[~ok2], nxt[~ok2]
        # only the rows whose assignment changed go on: the active set, then enumeration
        for _ in range(ACTIVE_SET_ROUNDS):
            if rows.size == 0:
                break
            x, ok, nxt = self._try(sid0[rows], A[rows], b[rows], kp[rows], kn[rows], mode)
            x_out[rows[ok]], m_out[rows[ok]] = x[ok], mode[ok]
            rows, mode = rows[~ok], nxt[~ok]
        if rows.size:
            x, m = stick_slip(A[rows], b[rows], kappa_pos=kp[rows], kappa_neg=kn[rows])
            x_out[rows], m_out[rows] = x, m
        return x_out.reshape(C, D, nv), m_out.reshape(C, D, nv)


def _matvec(A, x):
    """``A @ x`` for stacks of small matrices (rows, n, n) and vectors (rows, n), column by column
    (faster than a stacked matmul for n of a few)."""
    out = A[:, :, 0] * x[:, 0:1]
    for j in range(1, x.shape[-1]):
        out = out + A[:, :, j] * x[:, j:j + 1]
    return out
