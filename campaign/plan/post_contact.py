"""The structure's peak during and after the contact, with the arm's joints moving (the planner's post-contact term).

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

The contact is not instantaneous: the rig's hammer stays on the arm about 70 ms, a 5 kg
object about 200 ms, over half the space-class structure's quarter period and longer than
the stiff mast's. :func:`pulse_peak_displacement` spreads the impulse over the contact
law's force pulse (:func:`campaign.rig.contact.pulse_shape`, of the candidate's duration)
and drives the same system with it as a force, exactly discretised (first-order hold);
the planner feeds it to the free arm (``H*^-1 J*^T``, no lambda), so the servo, friction
and gravity resist the contact explicitly. Its impulsive limit is the release above.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
from scipy.linalg import expm

from ..core.errors import InputError

__all__ = ["ArmAfterImpact", "unit_responses", "pulse_peak_displacement", "peak_displacement", "MAX_REFINE"]

#: most fine steps per window step under the contact's pulse
MAX_REFINE = 1024


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
    pulse : bool
        The impulse arrives as the contact law's pulse of finite duration
        (:func:`pulse_peak_displacement`; on the fixed base the peak force then follows
        :mod:`campaign.plan.compression`); False: all at once (:func:`unit_responses`).
    """

    gains: Mapping[str, tuple]
    viscous: object
    gravity: float = 9.81
    samples: int = 96
    pulse: bool = True

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


def _system(terms, X: np.ndarray, kp: np.ndarray, damping: np.ndarray, *, gravity: float):
    """``A`` (N, G, 2nx, 2nx) of ``z' = A z``, ``z = [x_b, q - q0, x_b', q']``, and the release
    ``Z0`` (N, G, 2nx, 3): the state's jump per unit impulse vector (eq 8 and 13)."""
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
    # eq 8/13 release: joints at dq0 = X p, base at M_b^-1 (J_b^T p - H_bm dq0)
    Z0 = np.zeros((N, G, 2 * nx, 3))
    Z0[:, :, nx + nb:] = X
    Z0[:, :, nx:nx + nb] = terms.base_from_impulse[:, None] - terms.base_from_dq[:, None] @ X
    return A, Z0


def unit_responses(terms, X: np.ndarray, kp: np.ndarray, damping: np.ndarray, *, gravity: float,
                   samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Base translation over one first-mode period per unit impulse component.

    Parameters
    ----------
    terms : campaign.plan.prediction.PoseTerms
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
    A, Z = _system(terms, X, kp, damping, gravity=gravity)
    N, G = X.shape[:2]
    period = 1.0 / terms.frequency[:, 0]                                 # (N,)
    dt = period / samples
    E = expm(A * dt[:, None, None, None])                                # exact discrete propagator
    R = np.empty((N, G, samples + 1, 3, 3))
    R[:, :, 0] = 0.0
    for k in range(1, samples + 1):
        Z = E @ Z
        R[:, :, k] = Z[:, :, :3]
    return R, dt[:, None] * np.arange(samples + 1)[None]


def pulse_peak_displacement(terms, X: np.ndarray, kp: np.ndarray, damping: np.ndarray, p: np.ndarray,
                            duration: np.ndarray, *, shape, gravity: float, samples: int,
                            pulse_steps: int = 16) -> np.ndarray:
    """Peak norm of the base translation over one first-mode period when the impulse ``p``
    arrives as a pulse of finite duration rather than at once [m].

    The contact spreads the impulse vector ``p = n I`` over ``T = duration`` with the contact
    law's shape ``f`` (``shape``: ``f`` at equal steps over the pulse,
    :func:`campaign.rig.contact.pulse_shape`); each slice ``p f(t) dt / int f`` changes the joints' velocities by
    ``X`` times it and the base's as eq 8 does, while the structure's spring, the servo,
    friction and gravity act from the first slice on. With ``X = H*^-1 J*^T`` (the free arm,
    no lambda) that is the pulse as a force ``J^T p f(t) / int f`` on the coupled system. The input is the pulse sampled
    on a grid and held first-order (linear between samples): ``z_{k+1} = Phi z_k +
    (Gamma_1 - Gamma_2) u_k + Gamma_2 u_{k+1}``, exact for that piecewise-linear pulse,
    with ``Phi``, ``Gamma_1``, ``Gamma_2`` from one matrix exponential (the block form of
    the first-order hold), the samples scaled so the held pulse carries exactly ``p``. The
    grid is the window's (``samples`` steps per period) refined by an integer factor so that
    the shortest pulse spans at least ``pulse_steps`` steps; past the longest pulse it
    continues on the window's grid. As ``T -> 0`` it is :func:`unit_responses` with
    :func:`peak_displacement`.

    Parameters
    ----------
    terms, kp, damping, gravity, samples
        As :func:`unit_responses`.
    X : (N, G, nv, 3) array
        The joints' velocity change per unit impulse vector of each slice.
    p : (N, G, D, 3) array
        Impulse vectors [N s].
    duration : (N, G, D) array
        Contact durations [s], > 0.
    shape : (K,) array_like
        The pulse's force at ``K >= 3`` equal steps from its start to its end.
    pulse_steps : int
        Fewest grid steps across the shortest pulse.

    Returns
    -------
    (N, G, D) array
    """
    f = np.asarray(shape, dtype=float)
    T = np.asarray(duration, dtype=float)
    if not np.all(np.isfinite(T) & (T > 0)):
        bad = T[~(np.isfinite(T) & (T > 0))]
        raise InputError(f"contact duration must be > 0 s, got {float(bad.flat[0]):g}")
    if f.ndim != 1 or f.size < 3 or not np.all(np.isfinite(f) & (f >= 0)) or not f.sum() > 0:
        raise InputError("contact pulse shape must be >= 3 finite values >= 0, not all zero")
    A, Z0 = _system(terms, X, kp, damping, gravity=gravity)
    N, G, D = p.shape[:3]
    n2 = A.shape[-1]
    period = 1.0 / terms.frequency[:, 0]                                 # (N,)
    h = period / samples
    # a pulse shorter than 1/MAX_REFINE of a window step is an impulse for the window's grid:
    # it then falls on the first fine step whole (below)
    refine = min(MAX_REFINE, max(1, int(np.ceil(pulse_steps * np.max(h[:, None, None] / T)))))
    hf = h / refine
    # first-order hold: expm([[A, B, 0], [0, 0, I/hf], [0, 0, 0]] hf) = [[Phi, Gamma_1, Gamma_2], ...]
    # with B = Z0 the state's jump per unit impulse, so u is the impulse rate [1/s] times p
    aug = np.zeros((N, G, n2 + 6, n2 + 6))
    aug[:, :, :n2, :n2] = A * hf[:, None, None, None]
    aug[:, :, :n2, n2:n2 + 3] = Z0 * hf[:, None, None, None]
    aug[:, :, n2:n2 + 3, n2 + 3:] = np.eye(3)
    Ef = expm(aug)
    Phi, Gam1, Gam2 = Ef[:, :, :n2, :n2], Ef[:, :, :n2, n2:n2 + 3], Ef[:, :, :n2, n2 + 3:]
    P = np.swapaxes(p, 2, 3)                                             # (N, G, 3, D)
    B1, B2 = (Gam1 - Gam2) @ P, Gam2 @ P                                 # (N, G, n2, D)
    # the pulse on the fine grid, scaled so its first-order hold integrates to 1 exactly
    fine = int(np.ceil(np.max(T / hf[:, None, None]))) + 1               # fine samples covering every pulse
    fine = refine * int(np.ceil((fine - 1) / refine)) + 1                # ending on the window's grid
    t = hf[:, None, None, None] * np.arange(fine)                        # (N, 1, 1, fine)
    u = np.interp(np.clip(t / T[..., None], 0.0, 1.0).ravel(), np.linspace(0.0, 1.0, f.size), f).reshape(
        T.shape + (fine,))
    u[..., 1] = np.where(u[..., 1:].any(axis=-1), u[..., 1], 1.0)        # a pulse between two samples
    area = hf[:, None, None] * (u.sum(axis=-1) - 0.5 * (u[..., 0] + u[..., -1]))
    u /= area[..., None]                                                 # (N, G, D, fine), [1/s]
    Z = np.zeros((N, G, n2, D))
    peak2 = np.zeros((N, G, D))
    for k in range(fine - 1):
        Z = Phi @ Z + B1 * u[:, :, None, :, k] + B2 * u[:, :, None, :, k + 1]
        if (k + 1) % refine == 0:
            peak2 = np.maximum(peak2, np.einsum("ngid,ngid->ngd", Z[:, :, :3], Z[:, :, :3]))
    done = (fine - 1) // refine                                          # window steps covered by the pulse
    if done < samples:
        E = expm(A * h[:, None, None, None])
        for _ in range(samples - done):
            Z = E @ Z
            peak2 = np.maximum(peak2, np.einsum("ngid,ngid->ngd", Z[:, :, :3], Z[:, :, :3]))
    return np.sqrt(peak2)


def peak_displacement(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Peak norm of the base translation over the window, ``max_k |R[k] p|`` [m].

    ``R`` (N, G, T, 3, 3) from :func:`unit_responses`; ``p`` (N, G, D, 3) the impulse vectors
    ``n I``. Returns (N, G, D).
    """
    x = np.einsum("ngtij,ngdj->ngdti", R, p)
    return np.sqrt(np.max(np.einsum("ngdti,ngdti->ngdt", x, x), axis=-1))
