"""The peak contact force with the arm's joints resisting over the compression (the planner's force term).

The contact law's peak force between two free bodies depends on their reduced mass only
(:meth:`campaign.rig.contact.ContactLaw.peak_force`). The arm is no free body during the
contact: its servo, the joints' viscous friction and the rotors resist from the first
instant on, and the force peaks early, at a fixed fraction of the contact (about a
quarter for the rig's law, :func:`campaign.rig.contact.pulse_shape`). The Virtual Rotor
Inertia lambda (eq 5) is the joints' resistance averaged over the whole contact (the
impulse and the velocity change at its end, eq 10), so it overstates the arm's inertia at
the force's peak, most where the servo is stiff and the object heavy (long contacts).

This module replaces the arm's effective mass in the peak force by its apparent mass over
the compression: the impulse the contact has delivered by its force peak over the tip's
velocity along ``n`` then, for the joints obeying

    H qdd + (K_d + B_v) qd + K_p q = J^T n F(t),   q(0) = qd(0) = 0

(``H`` the joint-space inertia with the reflected rotor inertia, eq 7 with lambda = 0; the
servo's proportional and derivative gains and the viscous friction of
:class:`campaign.plan.post_contact.ArmAfterImpact`) under the contact law's own pulse up to its
peak (:func:`campaign.joints.pulse.pulse_compliance`, exact for the pulse held over equal
steps). The pulse's duration follows from the reduced mass, which follows from the
apparent mass: a fixed-point iteration. Without servo and friction it is eq 7's m* with
lambda = 0 for any duration. Gravity's stiffness is left out: over the tens of
milliseconds to the peak it changes the joint velocities by about a per cent.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import SimulationError
from ..joints.pulse import pulse_compliance
from ..rig.contact import pulse_shape

__all__ = ["compression_mass", "PEAK_SEGMENTS"]

#: equal steps of the contact pulse from its start to its force peak
PEAK_SEGMENTS = 48


def _peak_shares(shape: np.ndarray, segments: int) -> tuple[float, np.ndarray]:
    """(peak time as a fraction of the contact, the pulse's impulse share on each of
    ``segments`` equal steps up to the peak)."""
    f = np.asarray(shape, dtype=float)
    frac = int(np.argmax(f)) / (f.size - 1)
    s = np.linspace(0.0, frac, segments + 1)
    vals = np.interp(s, np.linspace(0.0, 1.0, f.size), f)
    return frac, 0.5 * (vals[1:] + vals[:-1])


def _tip_response(H, kp, damping, Jn):
    """Modal parts of the tip's velocity response: ``n.v_tip(t) = sum_j a_j * (e^(lambda_j .) * u)(t)``
    for the joint torque ``J^T n u(t)``; returns ``(lambda (N, G, 2nv), a (N, G, D, 2nv))``, or
    None if any pose's state matrix is (close to) defective."""
    N, nv = H.shape[0], H.shape[-1]
    G = kp.shape[0]
    Hi = np.linalg.inv(H)
    A = np.zeros((N, G, 2 * nv, 2 * nv))
    A[:, :, :nv, nv:] = np.eye(nv)
    A[:, :, nv:, :nv] = -Hi[:, None] * kp[None, :, None, :]
    A[:, :, nv:, nv:] = -Hi[:, None] * damping[None, :, None, :]
    lam, V = np.linalg.eig(A)
    if np.max(np.linalg.cond(V)) > 1e8:
        return None
    Vi = np.linalg.inv(V)
    left = np.einsum("ndj,ngjk->ngdk", Jn, V[:, :, nv:])                 # n^T J (velocity rows of V)
    right = np.einsum("ngkj,nji,ndi->ngdk", Vi[:, :, :, nv:], Hi, Jn)     # V^-1 [0; H^-1] J^T n
    return lam, left * right


def compression_mass(H, J, n, kp, damping, *, contact, mass: float, speed: float,
                     tol: float = 1e-10, max_iter: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """The arm's apparent mass along ``n`` over the compression, and the peak contact force it gives.

    Parameters
    ----------
    H : (N, nv, nv) array
        Joint-space inertia with the reflected rotor inertia (no lambda) [kg m^2].
    J : (N, 3, nv) array
        Linear rows of the impact point's Jacobian.
    n : (D, 3) array
        Unit impact directions.
    kp, damping : (G, nv) arrays
        Per gain set: the servo's proportional gain [N m/rad] and the joints' total damping
        ``K_d + B_v`` [N m s/rad].
    contact : campaign.rig.contact.ContactLaw
    mass, speed : float
        The object's mass ``m_b`` [kg] and approach speed [m/s].
    tol, max_iter
        The fixed-point iteration on the pulse's duration stops at a relative change of the
        apparent mass below ``tol``; SimulationError if it has not after ``max_iter``.

    Returns
    -------
    m_c : (N, G, D) array
        ``P(t_peak) / n.v_tip(t_peak)`` [kg].
    peak_force : (N, G, D) array
        :meth:`~campaign.rig.contact.ContactLaw.peak_force` at the reduced mass ``m_c m_b / (m_c + m_b)`` [N].

    Notes
    -----
    The response is taken modally: with ``A = V diag(lambda) V^-1`` the joints' state matrix
    (one eigen-decomposition per pose and gain set), the pulse held over ``K`` equal steps
    of length ``h`` gives ``n.v_tip(t_peak) = sum_j a_j (1 - e^(-lambda_j h)) / (lambda_j h)
    sum_k w_k e^(lambda_j (K - k) h)`` per unit impulse (``w_k`` the steps' impulse shares),
    the same held pulse :func:`campaign.joints.pulse.pulse_compliance` propagates with
    matrix exponentials; that path is taken where the state matrix is close to defective
    (e.g. no servo and no friction).
    """

    H, J, n = (np.asarray(x, dtype=float) for x in (H, J, n))
    kp, damping = np.atleast_2d(kp), np.atleast_2d(damping)
    N = H.shape[0]
    G, D = kp.shape[0], n.shape[0]
    _, shape = pulse_shape(contact.damping, float(contact.exponent))
    frac, shares = _peak_shares(shape, PEAK_SEGMENTS)
    w = shares / shares.sum()
    K = w.size
    Jn = np.einsum("nij,di->ndj", J, n)                                  # (N, D, nv): J^T n
    modal = _tip_response(H, kp, damping, Jn)
    if modal is None:
        tip = _held_pulse_tip(H, kp, damping, Jn, w)
    else:
        lam, a = modal

        def tip(h):
            x = lam[:, :, None, :] * h[..., None]                        # (N, G, D, 2nv)
            small = np.abs(x) < 1e-8
            hold = np.where(small, 1.0 - 0.5 * x, -np.expm1(-x) / np.where(small, 1.0, x))
            r = np.exp(x)
            acc = np.zeros_like(r)
            for wk in w:                                                 # Horner: sum_k w_k r^(K-k)
                acc = (acc + wk) * r
            return np.real(np.sum(a * hold * acc, axis=-1))
    # start from the free arm (eq 7, lambda = 0): the apparent mass at an instant
    m = np.broadcast_to(1.0 / np.einsum("ndi,ndi->nd", Jn, np.linalg.solve(H[:, None], Jn[..., None])[..., 0])
                        [:, None], (N, G, D))
    for _ in range(max_iter):
        mu = m * mass / (m + mass)
        h = frac * contact.duration(mu, speed) / K
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):    # checked on the next line
            m_new = 1.0 / tip(h)
        if not np.all(np.isfinite(m_new) & (m_new > 0)):
            raise SimulationError("the arm's apparent mass over the compression is not finite and positive")
        done = np.max(np.abs(m_new - m) / m_new) <= tol
        m = m_new
        if done:
            break
    else:
        raise SimulationError(f"apparent mass over the compression did not settle in {max_iter} iterations")
    return m, contact.peak_force(m * mass / (m + mass), speed)


def _held_pulse_tip(H, kp, damping, Jn, w):
    """``h -> n.v_tip`` per unit impulse by :func:`campaign.joints.pulse.pulse_compliance`
    (matrix exponentials), for state matrices the modal form cannot take."""

    N, D, nv = Jn.shape
    G = kp.shape[0]
    rows = (N, G, D)
    Hr = np.broadcast_to(H[:, None, None], rows + (nv, nv)).reshape(-1, nv, nv)
    Kr = np.broadcast_to(kp[None, :, None], rows + (nv,)).reshape(-1, nv)
    Dr = np.broadcast_to(damping[None, :, None], rows + (nv,)).reshape(-1, nv)
    Jr = np.broadcast_to(Jn[:, None], rows + (nv,)).reshape(-1, nv)

    def tip(h):
        Gc = pulse_compliance(Hr, stiffness=Kr, damping=Dr, duration=(h * w.size).ravel(), shape=w)
        return np.einsum("ri,rij,rj->r", Jr, Gc, Jr).reshape(rows)
    return tip
