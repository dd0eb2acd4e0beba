"""The joints' velocity response to a force pulse of finite duration: ``G(T)`` of the joint impedance.

Separate from :mod:`campaign.joints.impedance` (which fits the impedance to identified trials)
so that the planner's contact prediction (:mod:`campaign.plan.compression`), which a
simulation job imports for its stroke check, loads NumPy and SciPy's matrix exponential only,
not the identification and the lambda fit.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError

__all__ = ["pulse_compliance"]


def pulse_compliance(H, *, stiffness, damping, duration, shape) -> np.ndarray:
    """Joint velocity at the end of a unit-impulse force pulse, per unit of joint impulse.

    ``G(T)`` with ``qd(T) = G(T) u`` for ``H qdd + D qd + K q = u f(t)``, ``q(0) = qd(0) = 0``,
    ``D = diag(damping)``, ``K = diag(stiffness)``, ``f`` a pulse of duration ``T`` and unit
    integral, constant over each of its equal steps with the step's share ``shape[k]`` of
    the impulse. Exact for that pulse (zero-order hold: one matrix exponential per row).
    With ``D = K = 0`` it is ``H^-1`` (eq 11 with ``lambda = 0``) for any pulse.

    Parameters
    ----------
    H : ndarray, shape (N, nv, nv)
    stiffness, damping : array_like, shape (nv,) or (N, nv)
    duration : array_like, shape () or (N,)
        Pulse duration ``T`` [s].
    shape : array_like, shape (K,)
        Impulse share of each step (:func:`campaign.joints.impedance.half_sine_shape`,
        :func:`campaign.joints.impedance.measured_pulse_shape`).

    Returns
    -------
    ndarray, shape (N, nv, nv)
    """
    from scipy.linalg import expm

    H = np.asarray(H, float)
    N, nv = H.shape[:2]
    K = np.broadcast_to(np.asarray(stiffness, float), (N, nv))
    D = np.broadcast_to(np.asarray(damping, float), (N, nv))
    T = np.broadcast_to(np.asarray(duration, float), (N,))
    w = np.asarray(shape, float)
    if not np.all(np.isfinite(T) & (T > 0)):
        raise InputError(f"pulse duration must be > 0 s, got {np.asarray(duration).tolist()}")
    if w.ndim != 1 or w.size < 1 or not np.all(np.isfinite(w) & (w >= 0)) or not w.sum() > 0:
        raise InputError(f"pulse shape must be K >= 1 finite shares >= 0, got {w.tolist()}")
    w = w / w.sum()
    dt = T / w.size
    Hi = np.linalg.inv(H)
    # [[A, B], [0, 0]] dt  ->  exp = [[Ad, Bd], [0, I]]: the step's state transition and the
    # response to a constant unit joint torque over it (x = [q, qd])
    M = np.zeros((N, 3 * nv, 3 * nv))
    M[:, :nv, nv:2 * nv] = np.eye(nv)
    M[:, nv:2 * nv, :nv] = -Hi * K[:, None, :]
    M[:, nv:2 * nv, nv:2 * nv] = -Hi * D[:, None, :]
    M[:, nv:2 * nv, 2 * nv:] = Hi
    E = expm(M * dt[:, None, None])                      # batched over the rows
    Ad, Bd = E[:, :2 * nv, :2 * nv], E[:, :2 * nv, 2 * nv:] / dt[:, None, None]
    Z = np.zeros((N, 2 * nv, nv))
    for share in w:
        Z = Ad @ Z + Bd * share
    G = Z[:, nv:]
    return 0.5 * (G + np.swapaxes(G, 1, 2))
