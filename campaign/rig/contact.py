"""The compliant contact between the hammer head and the soft-wrapped arm tip.

Normal force along n, never tensile (Flores et al. 2011 type damping, normalised by the
approach speed at first touch ``v0``):

    F = k delta^p (1 + d * ddelta / v0),   F >= 0,   contact while delta > 0.

With this normalisation the dimensionless problem ``x'' = -x^p (1 + d x')``, ``x(0) = 0``,
``x'(0) = 1`` (``x = delta / delta*``, ``delta* = (m v0^2 / k)^(1/(p+1))``) does not depend
on ``k``, the reduced mass ``m`` or ``v0``: two free bodies meeting through this contact
rebound with a coefficient ``e(d, p)`` that is a function of ``d`` and ``p`` only. We solve
it once for the ``d`` that gives the asked ``e``: ``e`` turns out independent of ``p`` and
``d`` solves ``ln((1+d)/(1-d e)) = d (1+e)`` (Flores' ``8(1-e)/(5e)`` is a first-order
approximation of that root; ours makes e exact).
Hunt-Crossley and Lankarani-Nikravesh assume ``e`` near 1 and are not used (design 4).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..core.errors import InputError

__all__ = ["ContactLaw", "restitution_of_damping", "damping_for_restitution", "contact_duration_estimate",
           "peak_force_factor", "pulse_shape"]


def _dimensionless_contact(d: float, p: float, *, x0: float, dense_output: bool = False):
    """Integrate ``x'' = -x^p (1 + d x')`` from ``x = x0``, ``x' = 1`` until the contact ends.

    It ends when ``x`` returns to 0 or the force ``x^p (1 + d x')`` reaches 0 (no tension);
    ``solve_ivp``'s solution is returned, with its events (``y_events``) in that order.
    """
    from scipy.integrate import (
        solve_ivp,  # only the contact's closed-form checks integrate
    )

    def rhs(_, y):
        f = max(y[0], 0.0) ** p * (1.0 + d * y[1])
        return [y[1], -max(f, 0.0)]

    def back_to_zero(_, y):
        return y[0]

    def no_force(_, y):
        return 1.0 + d * y[1]

    back_to_zero.terminal, back_to_zero.direction = True, -1
    no_force.terminal, no_force.direction = True, -1
    return solve_ivp(rhs, (0.0, 50.0), [x0, 1.0], events=(back_to_zero, no_force), rtol=1e-12, atol=1e-14,
                     method="DOP853", dense_output=dense_output)


def restitution_of_damping(d: float, p: float = 1.0) -> float:
    """Restitution of the dimensionless contact ``x'' = -x^p (1 + d x')`` (x(0)=0, x'(0)=1).

    The contact ends when ``x`` returns to 0 or the force ``x^p (1 + d x')`` reaches 0
    (no tension); ``e = -x'`` then.
    """

    # start slightly inside so the x = 0 event of the start does not fire
    sol = _dimensionless_contact(d, p, x0=1e-9)
    for ev in sol.y_events:
        if len(ev):
            return float(-ev[0][1])
    raise RuntimeError(f"dimensionless contact with d={d}, p={p} did not end")  # pragma: no cover


@functools.lru_cache(maxsize=64)
def damping_for_restitution(e: float, p: float = 1.0) -> float:
    """The damping factor ``d`` of :class:`ContactLaw` that yields restitution ``e`` (0 < e <= 1).

    Separating ``x' dx' / (1 + d x') = -x^p dx`` and integrating over the whole contact
    (``x`` returns to 0, so the right side vanishes) gives, for any exponent ``p``,

        ln((1 + d) / (1 - d e)) = d (1 + e),

    solved here by bracketing; :func:`restitution_of_damping` integrates the ODE instead
    and serves as the independent check.
    """
    if not (isinstance(e, (int, float)) and 0.0 < e <= 1.0):
        raise InputError(f"restitution must be in (0, 1], got {e!r}")
    if e == 1.0:
        return 0.0

    def g(d):
        return math.log1p(d) - math.log1p(-d * e) - d * (1.0 + e)

    # g < 0 for small d (g ~ d^2 (e^2 - 1) / 2) and g -> +inf as d e -> 1; the cubic
    # expansion puts the root near 3 (1 - e^2) / (2 (1 + e^3)), so bracket below that.
    lo = 0.25 * 3.0 * (1.0 - e * e) / (2.0 * (1.0 + e**3))
    hi = (1.0 - 1e-12) / e
    if g(hi) <= 0.0:
        # for e below ~0.04 the root needs 1 - d e below 1e-12: not representable
        raise InputError(f"restitution {e} is too low for the contact model (use e >= 0.05)")
    from scipy.optimize import brentq  # lazily: scipy.optimize costs ~0.5 s to import
    return float(brentq(g, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps))


@functools.lru_cache(maxsize=64)
def peak_force_factor(d: float, p: float = 1.0) -> float:
    """Largest dimensionless force ``max_t x^p (1 + d x')`` of the contact ``x'' = -x^p (1 + d x')``,
    ``x(0) = 0``, ``x'(0) = 1`` [1].

    The dimensionless problem does not depend on the stiffness, the masses or the speed
    (module notes), so one integration per ``(d, p)`` gives the peak force of every impact
    of two free bodies through this contact: ``F_max = k delta*^p * peak_force_factor(d, p)``
    (:meth:`ContactLaw.peak_force`). Without damping the peak sits at the largest compression,
    ``x_max = ((p + 1) / 2)^(1/(p+1))`` (energy), so the factor is ``x_max^p``.
    """
    d, p = float(d), float(p)
    if not (math.isfinite(d) and d >= 0.0 and math.isfinite(p) and p > 0.0):
        raise InputError(f"contact damping d = {d!r} must be >= 0 and exponent p = {p!r} > 0")
    from scipy.optimize import minimize_scalar

    sol = _dimensionless_contact(d, p, x0=1e-12, dense_output=True)
    t_end = float(sol.t[-1])

    def force(t):
        x, xd = sol.sol(t)
        return max(x, 0.0) ** p * (1.0 + d * xd)

    ts = np.linspace(0.0, t_end, 2001)
    fs = np.array([force(t) for t in ts])
    i = int(np.argmax(fs))
    lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, ts.size - 1)]
    res = minimize_scalar(lambda t: -force(t), bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
    return float(max(fs[i], -res.fun))


@functools.lru_cache(maxsize=64)
def pulse_shape(d: float, p: float = 1.0, *, samples: int = 257) -> tuple[float, np.ndarray]:
    """The dimensionless force pulse of the contact ``x'' = -x^p (1 + d x')``, ``x(0) = 0``,
    ``x'(0) = 1``: its duration ``tau_end`` and the force ``x^p (1 + d x')`` at ``samples``
    equally spaced times from 0 to ``tau_end`` [1].

    Like the peak (:func:`peak_force_factor`) it does not depend on the stiffness, the masses
    or the speed: two free bodies of reduced mass ``m`` meeting at ``v0`` feel
    ``F(t) = k delta*^p f(t v0 / delta*)`` for ``t`` up to ``tau_end delta* / v0``
    (:meth:`ContactLaw.duration`), with ``delta* = (m v0^2 / k)^(1/(p+1))``. The force starts
    and ends at zero and integrates to ``1 + e`` (the momentum exchanged, eq 14).
    """
    d, p = float(d), float(p)
    if not (math.isfinite(d) and d >= 0.0 and math.isfinite(p) and p > 0.0):
        raise InputError(f"contact damping d = {d!r} must be >= 0 and exponent p = {p!r} > 0")
    if not (isinstance(samples, int) and samples >= 3):
        raise InputError(f"pulse samples = {samples!r} must be an integer >= 3")
    sol = _dimensionless_contact(d, p, x0=1e-12, dense_output=True)
    t_end = float(sol.t[-1])
    x, xd = sol.sol(np.linspace(0.0, t_end, samples))
    f = np.maximum(x, 0.0) ** p * (1.0 + d * xd)
    f[0] = f[-1] = 0.0                              # it starts at x = 0 and ends at x = 0 or zero force
    f = np.maximum(f, 0.0)
    f.setflags(write=False)
    return t_end, f


def contact_duration_estimate(k: float, p: float, m: float, v0: float) -> float:
    """Contact duration of an undamped contact of stiffness ``k`` (exponent ``p``) between a
    mass ``m`` and a wall at approach speed ``v0`` [s]; an upper-bound scale for the step."""
    # dimensionless half period of x'' = -x^p is 2 * int_0^1 dx / sqrt(2/(p+1) (1 - x^(p+1)))
    # times delta*/v0; for p = 1 it is pi sqrt(m / k).
    dstar = (m * v0**2 / k) ** (1.0 / (p + 1.0))
    from scipy.special import beta
    a = 1.0 / (p + 1.0)
    tau = 2.0 * math.sqrt((p + 1.0) / 2.0) * a * beta(a, 0.5)
    return tau * dstar / v0


@dataclasses.dataclass(frozen=True)
class ContactLaw:
    """The contact law of hammer and arm: compliant, never-tensile normal contact.

    Attributes
    ----------
    stiffness : float
        ``k`` [N / m^p].
    exponent : float
        ``p`` [1]; 1 is a linear spring.
    restitution : float
        The ``e`` the damping is solved for [1].
    """

    stiffness: float
    exponent: float
    restitution: float

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> ContactLaw:
        """The contact law of flat rig values (``contact.*``, dotted keys)."""
        return cls(float(values["contact.stiffness"]), float(values["contact.exponent"]),
                   float(values["contact.restitution"]))

    @classmethod
    def from_scene(cls, scene) -> ContactLaw:
        """The contact law of a :class:`~campaign.scene.description.Scene`."""
        return cls.from_values(scene.param_dict)

    def __post_init__(self):
        for name in ("stiffness", "exponent"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"contact {name} must be > 0, got {v!r}")

    @functools.cached_property
    def damping(self) -> float:
        """Dimensionless damping factor ``d`` (solved for ``restitution``)."""
        return damping_for_restitution(float(self.restitution), float(self.exponent))

    def force(self, delta, ddelta, v0):
        """Contact force [N] for penetration ``delta`` [m], its rate [m/s] and the approach
        speed at first touch ``v0`` [m/s]. Zero where ``delta <= 0``; never negative."""
        delta = np.asarray(delta, dtype=float)
        pos = np.maximum(delta, 0.0)
        f = self.stiffness * pos**self.exponent * (1.0 + self.damping * np.asarray(ddelta, float) / v0)
        return np.maximum(f, 0.0)

    def peak_force(self, m, v0):
        """Peak contact force [N] of two free bodies of reduced mass ``m`` [kg] meeting at the
        relative speed ``v0`` [m/s]: ``k^(1/(p+1)) (m v0^2)^(p/(p+1)) * peak_force_factor(d, p)``.

        Element-wise on arrays; ``m = inf`` is not allowed (pass the finite reduced mass).
        """
        m = np.asarray(m, dtype=float)
        v0 = np.asarray(v0, dtype=float)
        p = float(self.exponent)
        scale = self.stiffness ** (1.0 / (p + 1.0)) * (m * v0 * v0) ** (p / (p + 1.0))
        out = scale * peak_force_factor(self.damping, p)
        return out[()] if out.ndim == 0 else out

    def duration(self, m, v0):
        """Duration [s] of the contact between two free bodies of reduced mass ``m`` [kg]
        meeting at ``v0`` [m/s]: ``tau_end (m / k)^(1/(p+1)) v0^((1-p)/(1+p))``
        (:func:`pulse_shape`). Element-wise on arrays."""
        m = np.asarray(m, dtype=float)
        v0 = np.asarray(v0, dtype=float)
        p = float(self.exponent)
        tau_end, _ = pulse_shape(self.damping, p)
        dstar = (m * v0 * v0 / self.stiffness) ** (1.0 / (p + 1.0))
        out = tau_end * dstar / v0
        return out[()] if out.ndim == 0 else out

    def energy(self, delta):
        """Elastic energy stored in the contact spring [J]."""
        pos = np.maximum(np.asarray(delta, dtype=float), 0.0)
        p = self.exponent
        return self.stiffness * pos ** (p + 1.0) / (p + 1.0)
