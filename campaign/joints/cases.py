"""What the contact response's two integrators share: the checked cases, the contact's pulse
and the exact discretisation of linear systems.

The cases are C poses (each with its servo gains) x D variants (impact direction, speed,
object); matrices are per case, states per case and variant, shaped ``(C, n, D)`` so that
one stacked product advances every variant of a case.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import expm

from ..core.errors import InputError
from ..rig.contact import pulse_shape
from .terms import ArmTerms

__all__ = ["Cases", "ContactPulse", "zoh", "foh", "second_order", "start_mass", "reduced_mass", "pulse_of",
           "object_impulse", "mass_of", "check_directions"]


@dataclasses.dataclass
class Cases:
    """The inputs of a response, checked and broadcast: the poses' ``terms`` (one per case),
    per case the servo's proportional gains ``kp`` (C, nv) [N m/rad] and the joints' total
    ``damping`` ``K_d + beta - K_p T_s / 2`` (C, nv) [N m s/rad]; the Coulomb levels ``tc_pos``,
    ``tc_neg`` (nv) [N m]; per variant the unit directions ``n`` (C, D, 3), ``speed`` [m/s],
    object ``mass`` [kg] and ``restitution`` (C, D); ``gravity`` [m/s^2]; the object's own
    restoring stiffness along n ``object_stiffness`` [N/m] (the rig's pendulum under gravity,
    whose impulse eq 10 counts); and, derived, ``Jn = n^T J`` (C, D, nv) and
    ``Sn = n . d^2 p / dq^2`` (C, D, nv, nv)."""

    terms: ArmTerms
    kp: np.ndarray
    damping: np.ndarray
    tc_pos: np.ndarray
    tc_neg: np.ndarray
    n: np.ndarray
    speed: np.ndarray
    mass: np.ndarray
    restitution: np.ndarray
    gravity: float
    object_stiffness: np.ndarray = 0.0
    Jn: np.ndarray = None
    Sn: np.ndarray = None

    def __post_init__(self):
        self.Jn = np.einsum("cdi,cij->cdj", self.n, self.terms.J)
        self.Sn = np.einsum("cdi,cijk->cdjk", self.n, self.terms.hessian)
        self.JnT = np.ascontiguousarray(np.swapaxes(self.Jn, 1, 2))          # (C, nv, D)

    @property
    def shape(self) -> tuple[int, int]:
        return self.speed.shape

    @property
    def nv(self) -> int:
        return self.terms.nv

    def joint_force(self, dq):
        """The contact force's joint torque per newton with the pose moved by ``dq`` (C, nv, D):
        ``J^T n + (n . d^2 p/dq^2) dq``."""
        return self.JnT + np.einsum("cdij,cjd->cid", self.Sn, dq)

    def tip_speed(self, dq, qd):
        """``n . v`` of the impact point from the joints, the pose moved by ``dq`` (C, D)."""
        return np.einsum("cid,cid->cd", self.joint_force(dq), qd)


class ContactPulse:
    """The rig's contact law's pulse between two free bodies (:func:`campaign.rig.contact.pulse_shape`):
    the impulse share of a time span, the force at an instant."""

    def __init__(self, contact):
        self.contact = contact
        _, f = pulse_shape(contact.damping, float(contact.exponent))
        self.s = np.linspace(0.0, 1.0, f.size)
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]))])
        self.area = float(cum[-1]) / (f.size - 1)           # integral of the shape over [0, 1]
        self.cum = cum / cum[-1]
        self.f = f
        # the penetration x(tau) of the dimensionless contact x'' = -f, x(0) = 0, x'(0) = 1, and
        # its integral over the contact (what an object's restoring force acts on)
        tau_end, _ = pulse_shape(contact.damping, float(contact.exponent))
        dtau = tau_end / (f.size - 1)
        xd = 1.0 - np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]))]) * dtau
        x = np.concatenate([[0.0], np.cumsum(0.5 * (xd[1:] + xd[:-1]))]) * dtau
        self.penetration_integral = float(np.sum(0.5 * (x[1:] + x[:-1])) * dtau)

    def shares(self, t0, t1, T):
        """Impulse share delivered over ``[t0, t1]`` by a pulse of duration ``T`` starting at 0."""
        a = np.interp(np.clip(t0 / T, 0.0, 1.0), self.s, self.cum)
        b = np.interp(np.clip(t1 / T, 0.0, 1.0), self.s, self.cum)
        return b - a

    def force(self, t, T, P):
        """The force at ``t`` of a pulse of duration ``T`` and impulse ``P`` [N]."""
        x = t / T
        inside = (x >= 0.0) & (x <= 1.0)
        return np.where(inside, np.interp(np.clip(x, 0.0, 1.0), self.s, self.f) * P / (T * self.area), 0.0)


def zoh(A, B, h):
    """``(Phi, Gamma)``: ``z(h) = Phi z(0) + Gamma u`` for ``z' = A z + B u`` with ``u`` held
    (stacked over leading axes; Van Loan's block exponential)."""
    n, m = A.shape[-1], B.shape[-1]
    h = np.asarray(h, float)
    lead = np.broadcast_shapes(A.shape[:-2], h.shape[:-2] if h.ndim >= 2 else ())
    big = np.zeros(lead + (n + m, n + m))
    big[..., :n, :n] = A * h
    big[..., :n, n:] = B * h
    E = expm(big)
    return E[..., :n, :n], E[..., :n, n:]


def foh(A, B, h):
    """``(Phi, Gamma0, Gamma1)`` for ``u`` ramping from ``u0`` to ``u1`` over ``h`` (stacked)."""
    n, m = A.shape[-1], B.shape[-1]
    big = np.zeros(A.shape[:-2] + (n + 2 * m, n + 2 * m))
    big[..., :n, :n] = A * h
    big[..., :n, n:n + m] = B * h
    big[..., n:n + m, n + m:] = np.eye(m)
    E = expm(big)
    return E[..., :n, :n], E[..., :n, n:n + m] - E[..., :n, n + m:], E[..., :n, n + m:]


def second_order(M, C, K):
    """``A``, ``B`` of ``z' = A z + B f`` for ``M x'' + C x' + K x = f``, ``z = [x, x']``."""
    nx = M.shape[-1]
    Mi = np.linalg.inv(M)
    A = np.zeros(M.shape[:-2] + (2 * nx, 2 * nx))
    A[..., :nx, nx:] = np.eye(nx)
    A[..., nx:, :nx] = -Mi @ K
    A[..., nx:, nx:] = -Mi @ C
    B = np.zeros(M.shape[:-2] + (2 * nx, nx))
    B[..., nx:, :] = Mi
    return A, B


def start_mass(cases: Cases) -> np.ndarray:
    """A first m* to size the pulse with: eq 7 (or eq 8) with ``lambda = 0``, doubled for the
    joints' resistance (C, D)."""
    t = cases.terms
    if t.base is None:
        s = np.einsum("cdi,cij,cdj->cd", cases.Jn, np.linalg.inv(t.H), cases.Jn)
    else:
        Jn = np.einsum("cdi,cij->cdj", cases.n, t.base.J)
        s = np.einsum("cdi,cij,cdj->cd", Jn, np.linalg.inv(t.base.M), Jn)
    with np.errstate(divide="ignore"):
        return np.where(s > 0, 2.0 / s, np.inf)


def reduced_mass(cases: Cases, m):
    """``m m_b / (m + m_b)`` of the arm's ``m`` and the object (C, D); ``m_b`` where m is infinite."""
    finite = np.isfinite(m)
    return np.where(finite, m * cases.mass / np.where(finite, m + cases.mass, 1.0), cases.mass)


def pulse_of(cases: Cases, contact, m):
    """Duration [s] and impulse (eq 14) [N s] of the contact law's pulse at the reduced mass
    of ``m`` and the object (C, D)."""
    mu = reduced_mass(cases, m)
    return contact.duration(mu, cases.speed), (1.0 + cases.restitution) * cases.speed * mu


def object_impulse(cases: Cases, pulse: ContactPulse, m, P):
    """The object's momentum change over the contact [N s] (C, D): the contact's impulse ``P``
    and its own restoring force's, ``k_o int delta dt`` with ``delta`` the contact law's
    penetration (the impact device's pendulum under gravity, ``k_o = m g l_c / r^2``; zero
    for a free object). Eq 10 measures m* with it."""
    if not np.any(cases.object_stiffness):
        return P
    mu = reduced_mass(cases, m)
    c = pulse.contact
    p = float(c.exponent)
    dstar = (mu * cases.speed ** 2 / c.stiffness) ** (1.0 / (p + 1.0))
    return P + cases.object_stiffness * dstar * dstar / cases.speed * pulse.penetration_integral


def mass_of(P, v):
    """``m* = P / v``, ``inf`` where the tip does not move along n."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(v > 1e-12 * np.maximum(P, 1e-300), P / v, np.inf)


def check_directions(directions, C: int) -> np.ndarray:
    """Unit directions (C, D, 3) from (C, D, 3) or (D, 3)."""
    n = np.asarray(directions, float)
    if n.ndim == 2:
        n = np.broadcast_to(n, (C,) + n.shape)
    if n.ndim != 3 or n.shape[0] != C or n.shape[2] != 3 or not np.all(np.isfinite(n)):
        raise InputError(f"directions must be finite with shape (C, D, 3) or (D, 3), got {np.asarray(directions).shape}")
    norm = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise InputError("an impact direction is the zero vector")
    return n / norm
