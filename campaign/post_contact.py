"""The structure's peak after the impact, with the arm's joints still moving (the planner's post-contact term).

Eq 8 gives the base's velocity right after the impact with the arm's joints free: the
impulse ``p = n I`` leaves the arm with ``dq0 = (H* + lambda)^-1 J*^T p`` (eq 13) and the
base with ``dv_b = M_b^-1 (J_b^T p - H_bm dq0)``. The structure then peaks a quarter of its
first period later (0.36 s on a 0.7 Hz structure), and meanwhile the servo's PD, the joints'
viscous friction and gravity slow the joints and pass the arm's momentum to the base: the
base's generalised momentum ``M_b v_b + H_bm dq`` is changed only by the structure's spring
and damper, so every joint velocity the arm loses reappears in the base.

This module follows that exchange with the linearised coupled system about the struck pose
(base displacement ``x_b`` in the tip frame, arm deviation ``dq``), released with eq 8's
velocities::

    M [x_b'', q''] + C [x_b', q'] + K [x_b, q - q0] = 0,
    M = [[M_b, H_bm], [H_bm^T, H_m]]     (Pinocchio's CRBA of the arm on its free base),
    C = diag(B_s, K_d + B_v),  K = diag(K_s, K_p + dG/dq)

with the structure's stiffness ``K_s`` and damping ``B_s``, the servo's proportional and
derivative gains ``K_p``, ``K_d`` (the gain set's PID in joint units), the joints' viscous
friction ``B_v`` and the gradient of the gravity torque ``dG/dq`` (Pinocchio). Coulomb
friction and the servo's integral term are left out (it is linear). The response to each
unit impulse component is propagated with the exact discrete propagator ``expm(A dt)``
over one first-mode period; the peak of the base translation's norm over that window is
the predicted peak displacement. With free joints and no gravity it is the free arm on the
structure; with joints that stop at once it is the structure released with the composite
(arm locked) body's momentum ``J_b^T p``.
"""

from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np
from scipy.linalg import expm

from .errors import InputError

__all__ = ["ArmAfterImpact", "unit_responses", "peak_displacement"]


@dataclasses.dataclass(frozen=True)
class ArmAfterImpact:
    """What acts on the arm's joints after the impact (joint side, SI units).

    Attributes
    ----------
    gains : mapping of str to (Kp, Kd)
        Per gain class: the servo's proportional [N m/rad] and derivative [N m s/rad] gains
        per joint. A class not named here has no servo after the impact (friction only).
    viscous : (nv,) array_like
        The joints' viscous friction [N m s/rad].
    gravity : float
        Gravitational acceleration [m/s^2] (its torque's gradient acts as a joint stiffness).
    samples : int
        Time samples over the window (one first-mode period) where the peak is sought.
    """

    gains: Mapping[str, tuple]
    viscous: object
    gravity: float = 9.81
    samples: int = 96

    def matrices(self, names, nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(Kp (G, nv), Kd + B_v (G, nv), viscous (nv,))`` for the gain classes ``names``;
        InputError naming a bad value."""
        visc = np.asarray(self.viscous, dtype=float)
        if visc.shape != (nv,) or not np.all(np.isfinite(visc)) or np.any(visc < 0):
            raise InputError(f"joint viscous friction {np.asarray(self.viscous).tolist()} must be {nv} values >= 0")
        if not (np.isfinite(self.gravity) and self.gravity >= 0):
            raise InputError(f"gravity = {self.gravity!r} m/s^2 must be >= 0")
        if not (isinstance(self.samples, (int, np.integer)) and self.samples >= 8):
            raise InputError(f"post-contact samples = {self.samples!r} must be an integer >= 8")
        kp = np.zeros((len(names), nv))
        kd = np.zeros((len(names), nv))
        for g, name in enumerate(names):
            if name not in self.gains:
                continue
            pair = self.gains[name]
            for arr, value, what in ((kp, pair[0], "Kp"), (kd, pair[1], "Kd")):
                v = np.broadcast_to(np.asarray(value, dtype=float), (nv,))
                if not np.all(np.isfinite(v)) or np.any(v < 0):
                    raise InputError(f"gain class {name!r}: {what} = {np.asarray(value).tolist()} must be >= 0")
                arr[g] = v
        return kp, kd + visc[None], visc


def unit_responses(terms, X: np.ndarray, kp: np.ndarray, damping: np.ndarray, *, gravity: float,
                   samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Base translation over one first-mode period per unit impulse component.

    Parameters
    ----------
    terms : campaign.plan.PoseTerms
        Flexible-base terms (``M_full``, ``gravity_stiffness``, the structure's stiffness and
        damping).
    X : (N, G, nv, 3) array
        ``(H* + lambda)^-1 J*^T``: post-impact joint velocities per unit impulse vector (eq 13).
    kp, damping : (G, nv) arrays
        The servo's proportional gain and the joints' total damping (``K_d + B_v``).
    gravity : float
        [m/s^2]; scales ``terms.gravity_stiffness`` (given per unit gravity).
    samples : int
        Propagation steps over the window.

    Returns
    -------
    R : (N, G, samples + 1, 3, 3) array
        ``x_b[:3](t_k) = R[k] p`` for the impulse vector ``p = n I`` on the arm [m / (N s)].
    t : (N, samples + 1) array
        The sample times [s] (one period of each pose's first mode with the arm locked).
    """
    N, G, nv = X.shape[0], X.shape[1], X.shape[2]
    nx = terms.M_full.shape[-1]
    nb = nx - nv
    K = np.zeros((N, G, nx, nx))
    K[:, :, :nb, :nb] = terms.structure_stiffness
    K += gravity * terms.gravity_stiffness[:, None]
    K[:, :, nb + np.arange(nv), nb + np.arange(nv)] += kp[None]
    C = np.zeros((G, nx, nx))
    C[:, :nb, :nb] = terms.structure_damping
    C[:, nb + np.arange(nv), nb + np.arange(nv)] = damping
    Minv = np.linalg.inv(terms.M_full)                                   # (N, nx, nx)
    A = np.zeros((N, G, 2 * nx, 2 * nx))
    A[:, :, :nx, nx:] = np.eye(nx)
    A[:, :, nx:, :nx] = -Minv[:, None] @ K
    A[:, :, nx:, nx:] = -Minv[:, None] @ C[None]
    period = 1.0 / terms.frequency[:, 0]                                 # (N,)
    dt = period / samples
    E = expm(A * dt[:, None, None, None])                                # exact discrete propagator
    # eq 8/13 release: joints at dq0 = X p, base at M_b^-1 (J_b^T p - H_bm dq0)
    Z = np.zeros((N, G, 2 * nx, 3))
    Z[:, :, nx + nb:] = X
    Z[:, :, nx:nx + nb] = terms.base_from_impulse[:, None] - terms.base_from_dq[:, None] @ X
    R = np.empty((N, G, samples + 1, 3, 3))
    R[:, :, 0] = 0.0
    for k in range(1, samples + 1):
        Z = E @ Z
        R[:, :, k] = Z[:, :, :3]
    return R, dt[:, None] * np.arange(samples + 1)[None]


def peak_displacement(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Peak norm of the base translation over the window, ``max_k |R[k] p|`` [m].

    ``R`` (N, G, T, 3, 3) from :func:`unit_responses`; ``p`` (N, G, D, 3) the impulse vectors
    ``n I``. Returns (N, G, D).
    """
    x = np.einsum("ngtij,ngdj->ngdti", R, p)
    return np.sqrt(np.max(np.einsum("ngdti,ngdti->ngdt", x, x), axis=-1))
