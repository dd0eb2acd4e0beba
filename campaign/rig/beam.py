"""The flexible long-reach structure: a vertical cantilever beam with the arm's base at its tip.

The paper (section 4.2, eq 8, Figure 2) describes the structure at the arm's base by a
stiffness ``K``, a damping ``B`` and a mass ``M``. This module gives those three 6x6
matrices at the beam tip (Euler-Bernoulli stiffness, the Hermite consistent tip mass stored
as a rigid body, modal damping) for the VES-II emulation loop (:mod:`campaign.rig.ves`) and
the ideal coupling (:mod:`campaign.rig.ideal_base`). Tip displacements are
``(u_x, u_y, u_z, theta_x, theta_y, theta_z)`` in Pinocchio's ``[linear; angular]`` order,
``z`` up along the beam; the conjugate force is the wrench at the tip.

Derivations and the accuracy of the mass model: user guide, *The rig*, section "The
flexible long-reach structure" (``docs/rig.rst``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np
import pinocchio as pin
import scipy.linalg as sla

from ..core.errors import InputError
from ..model.robot.floating import BaseBody

__all__ = [
    "Beam",
    "cantilever_flexibility",
    "exact_first_frequency",
    "rayleigh_first_frequency",
    "tip_inertia_matrix",
]

#: Hermite (consistent) tip-mass coefficients of one Euler-Bernoulli element, over m/420.
_C_UU, _C_UPHI, _C_PHIPHI = 156.0, 22.0, 4.0
#: first root of 1 + cos(l) cosh(l) = 0 (bare cantilever), used to bracket the frequency equation
_LAMBDA1_BARE = 1.8751040687119611


def _positive(name: str, value: Any, units: str, key: str | None = None) -> float:
    """``float(value)`` if finite and > 0, else an InputError naming the value (and config key)."""
    where = f" ({key})" if key else ""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"beam {name}{where} must be a number > 0 {units}, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise InputError(f"beam {name}{where} must be > 0 {units}, got {value!r}")
    return v


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=float)
    a.setflags(write=False)
    return a


def cantilever_flexibility(EI: float, length: float) -> np.ndarray:
    """Closed-form tip flexibility of one bending plane, ``(u, phi)`` per ``(F, M)``.

    Parameters
    ----------
    EI : float
        Bending stiffness [N m^2].
    length : float
        Beam length [m].

    Returns
    -------
    ndarray, shape (2, 2)
        ``[[L^3/(3EI), L^2/(2EI)], [L^2/(2EI), L/EI]]`` [m/N, 1/N; 1/N, 1/(N m)]
        (Gere & Timoshenko, cantilever with a tip load and a tip moment).
    """
    L = float(length)
    return np.array([[L**3 / (3 * EI), L**2 / (2 * EI)], [L**2 / (2 * EI), L / EI]])


def rayleigh_first_frequency(EI: float, length: float, beam_mass: float, tip_mass: float) -> float:
    """Rayleigh's first bending frequency of a cantilever with a tip point mass [Hz].

    ``f = (1 / 2 pi) sqrt(3 EI / (L^3 (M_tip + 33/140 m)))`` (Rayleigh's method with the
    static tip-load shape; e.g. Thomson & Dahleh, *Theory of Vibration with
    Applications*, sec. 2.5). Within about 1.5 % of the exact value (exact for a heavy
    tip mass, 1.5 % high for a bare beam). Kept as a quick sanity check; the reference
    for tests is :func:`exact_first_frequency`.
    """
    return math.sqrt(3.0 * EI / (length**3 * (tip_mass + 33.0 / 140.0 * beam_mass))) / (2.0 * math.pi)


def _frequency_determinant(lam: float, alpha: float, eps: float, iota: float) -> float:
    """Determinant of the tip boundary conditions of a clamped Euler-Bernoulli beam with a
    rigid tip body, as a function of ``lam = beta L`` (dimensionless).

    ``W(z) = A (cosh bz - cos bz) + B (sinh bz - sin bz)`` satisfies the clamp. At the tip
    (Hamilton's principle with the tip body's kinetic energy
    ``T = M/2 (w' + e phi')^2 + J_c/2 phi'^2``, ``phi = W'(L)``)::

        EI W''' + omega^2 M (W + e W')               = 0
        EI W''  - omega^2 (M e W + (M e^2 + J_c) W') = 0

    with ``omega^2 = beta^4 EI / mu``. In dimensionless form (lengths over ``L``,
    ``alpha = M/m``, ``eps = e/L``, ``iota = J_c/(m L^2)``) the rows below are divided by
    ``cosh(lam)`` for conditioning.
    """
    ch, c, sh, s = math.cosh(lam), math.cos(lam), math.sinh(lam), math.sin(lam)
    W = np.array([ch - c, sh - s])          # W(L)
    W1 = lam * np.array([sh + s, ch - c])   # L W'(L)
    W2 = lam**2 * np.array([ch + c, sh + s])  # L^2 W''(L)
    W3 = lam**3 * np.array([sh - s, ch + c])  # L^3 W'''(L)
    l4 = lam**4
    row1 = W3 + l4 * alpha * (W + eps * W1)
    row2 = W2 - l4 * (alpha * eps * W + (alpha * eps**2 + iota) * W1)
    return float(row1[0] * row2[1] - row1[1] * row2[0]) / ch**2


def exact_first_frequency(EI: float, length: float, beam_mass: float, tip_mass: float = 0.0,
                          tip_inertia: float = 0.0, tip_com_height: float = 0.0) -> float:
    """Exact first bending frequency of a uniform cantilever carrying a rigid tip body [Hz].

    Solves the transcendental frequency equation of the continuous Euler-Bernoulli beam
    (clamped foot; at the tip a rigid body of mass ``M``, centre of mass ``e`` above the
    tip on the beam axis, rotary inertia ``J_c`` about its centre of mass in the bending
    plane) by bracketing its first root. With ``e = J_c = 0`` it is the classical
    ``1 + cos l cosh l + (M/m) l (cos l sinh l - sin l cosh l) = 0`` (Blevins, *Formulas
    for Natural Frequency and Mode Shape*, table 8-8; Laura, Pombo & Susemihl, J. Sound
    Vib. 37, 1974), and with ``M = 0`` the bare beam's ``lambda_1 = 1.8751``.

    This is the reference for the beam model's tests, not a Rayleigh formula: the
    ``33/140`` or ``0.24`` Rayleigh factors are themselves approximations at the percent
    level, the size of the tolerance they would be checking.

    Parameters
    ----------
    EI : float
        Bending stiffness [N m^2].
    length, beam_mass : float
        [m], [kg].
    tip_mass : float
        ``M`` [kg].
    tip_inertia : float
        ``J_c``, about the tip body's centre of mass, bending-plane axis [kg m^2].
    tip_com_height : float
        ``e``, centre of mass above the tip along the beam axis [m].

    Returns
    -------
    float
        ``f_1 = lambda_1^2 / (2 pi L^2) sqrt(EI / mu)`` with ``mu = m / L`` [Hz].
    """
    EI = _positive("EI", EI, "N m^2")
    L = _positive("length", length, "m")
    m = _positive("mass", beam_mass, "kg")
    if tip_mass < 0 or tip_inertia < 0:
        raise InputError(f"tip mass and inertia must be >= 0, got {tip_mass!r} kg, {tip_inertia!r} kg m^2")
    args = (tip_mass / m, tip_com_height / L, tip_inertia / (m * L**2))
    # A tip body lowers every frequency (Rayleigh), so the root lies below the bare beam's.
    hi = _LAMBDA1_BARE * (1.0 + 1e-9)
    f_hi = _frequency_determinant(hi, *args)
    lo = hi
    for _ in range(200):
        lo *= 0.9
        if _frequency_determinant(lo, *args) * f_hi < 0:
            break
    else:  # pragma: no cover - a tip body 1e9 times the beam
        raise InputError("no first bending root found: the tip body is out of range")
    # the second root of any tip body lies above the bare beam's first (clamped-pinned 3.93,
    # clamped-sliding 2.37 in the limits), so [lo, hi] brackets the first root only
    from scipy.optimize import brentq  # lazily: scipy.optimize costs ~0.5 s to import
    lam = brentq(_frequency_determinant, lo, hi, args=args, xtol=1e-15, rtol=1e-14)
    return lam**2 / (2.0 * math.pi * L**2) * math.sqrt(EI * L / m)


def tip_inertia_matrix(tip) -> np.ndarray:
    """6x6 spatial inertia matrix ``[linear; angular]`` at the tip frame of ``tip``.

    ``tip`` is a :class:`pinocchio.Inertia` expressed in the tip frame (e.g. the composite
    inertia of a locked arm), a 6x6 matrix, or None (zero).
    """
    if tip is None:
        return np.zeros((6, 6))
    if isinstance(tip, pin.Inertia):
        return np.array(tip.matrix())
    a = np.asarray(tip, dtype=float)
    if a.shape != (6, 6) or not np.all(np.isfinite(a)):
        raise InputError(f"tip inertia must be a pinocchio.Inertia or a finite 6x6 matrix, got shape {a.shape}")
    return a


@dataclasses.dataclass(frozen=True)
class Beam:
    """Vertical cantilever with the emulated base body (platform) at its tip.

    Parameters
    ----------
    EI : float
        Bending stiffness, both planes [N m^2] (paper section 4.2: 2.5e8).
    length : float
        [m].
    mass : float
        Total beam mass, uniform [kg].
    GJ_ratio : float
        Torsional over bending stiffness ``GJ/EI`` [1].
    EA_ratio : float
        Axial over bending stiffness ``EA/EI`` [m^-2]; also sets the polar radius of
        gyration of the section, ``r_p^2 = 2 / EA_ratio`` (axisymmetric section).
    damping_ratio : float
        Modal damping ratio of every structural mode [1], >= 0.
    platform_mass : float
        Rigid base body at the tip (the structure's end fitting the arm stands on) [kg].
    platform_inertia : 3 values or 3x3
        Its rotational inertia about its centre of mass, tip-frame axes [kg m^2]; three
        values are principal moments.
    platform_com : 3 values
        Its centre of mass in the tip frame [m] (default at the tip).
    mount_height : float
        The arm's base frame above the tip, along z [m] (>= 0).

    Notes
    -----
    The model and its sources: user guide, *The rig*, "The flexible long-reach
    structure". All matrices are read-only arrays, computed once.
    """

    EI: float
    length: float
    mass: float
    GJ_ratio: float = 0.77
    EA_ratio: float = 100.0
    damping_ratio: float = 0.02
    platform_mass: float = 50.0
    platform_inertia: Any = (5.0, 5.0, 5.0)
    platform_com: Any = (0.0, 0.0, 0.0)
    mount_height: float = 0.0

    def __post_init__(self):
        keys = {"EI": ("N m^2", "flexible.beam_EI"), "length": ("m", "flexible.beam_length"),
                "mass": ("kg", "flexible.beam_mass"), "GJ_ratio": ("(ratio)", "flexible.beam_GJ_ratio"),
                "EA_ratio": ("m^-2", "flexible.beam_EA_ratio"), "platform_mass": ("kg", "flexible.platform_mass")}
        for name, (units, key) in keys.items():
            object.__setattr__(self, name, _positive(name, getattr(self, name), units, key))
        for name, key in (("damping_ratio", "flexible.damping_ratio"), ("mount_height", "flexible.mount_height")):
            try:
                v = float(getattr(self, name))
            except (TypeError, ValueError):
                raise InputError(f"beam {name} ({key}) must be a number >= 0, got {getattr(self, name)!r}") from None
            if not (math.isfinite(v) and v >= 0.0):
                raise InputError(f"beam {name} ({key}) must be >= 0, got {getattr(self, name)!r}")
            object.__setattr__(self, name, v)
        if self.damping_ratio >= 1.0:
            raise InputError(f"beam damping_ratio (flexible.damping_ratio) must be < 1 (underdamped structure), "
                             f"got {self.damping_ratio!r}")
        try:
            inertia = np.asarray(self.platform_inertia, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"platform_inertia must be 3 values or a 3x3 matrix [kg m^2], "
                             f"got {self.platform_inertia!r}") from None
        if inertia.shape == (3,):
            inertia = np.diag(inertia)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)) or not np.allclose(inertia, inertia.T):
            raise InputError(f"platform_inertia (flexible.platform_inertia) must be 3 values or a symmetric 3x3 "
                             f"matrix [kg m^2], got {self.platform_inertia!r}")
        if np.min(np.linalg.eigvalsh(inertia)) <= 0:
            raise InputError(f"platform_inertia (flexible.platform_inertia) must be positive definite [kg m^2], "
                             f"got {self.platform_inertia!r}")
        object.__setattr__(self, "platform_inertia", tuple(map(tuple, inertia.tolist())))
        com = np.asarray(self.platform_com, dtype=float)
        if com.shape != (3,) or not np.all(np.isfinite(com)):
            raise InputError(f"platform_com must be 3 finite values [m], got {self.platform_com!r}")
        object.__setattr__(self, "platform_com", tuple(com.tolist()))

    @classmethod
    def from_values(cls, values) -> Beam:
        """The beam of flat rig values (``flexible.*``, dotted keys)."""
        v = values
        return cls(
            EI=v["flexible.beam_EI"], length=v["flexible.beam_length"], mass=v["flexible.beam_mass"],
            GJ_ratio=v["flexible.beam_GJ_ratio"], EA_ratio=v["flexible.beam_EA_ratio"],
            damping_ratio=v["flexible.damping_ratio"], platform_mass=v["flexible.platform_mass"],
            platform_inertia=v["flexible.platform_inertia"], mount_height=v["flexible.mount_height"],
        )

    @classmethod
    def from_scene(cls, scene) -> Beam:
        """The beam of a :class:`~campaign.scene.description.Scene` (its ``flexible.*`` parameters)."""
        return cls.from_values(scene.param_dict)

    # -- section properties --------------------------------------------------------------
    @property
    def GJ(self) -> float:
        """Torsional stiffness [N m^2]."""
        return self.GJ_ratio * self.EI

    @property
    def EA(self) -> float:
        """Axial stiffness [N]."""
        return self.EA_ratio * self.EI

    @property
    def polar_gyration_radius(self) -> float:
        """Polar radius of gyration of the section, ``sqrt(2 EI/EA)`` [m] (axisymmetric)."""
        return math.sqrt(2.0 / self.EA_ratio)

    # -- stiffness -----------------------------------------------------------------------
    @functools.cached_property
    def stiffness(self) -> np.ndarray:
        """Tip stiffness ``K`` (6x6, tip frame, ``[u; theta]``) [N/m, N/rad; N, N m/rad]."""
        EI, L = self.EI, self.length
        k_uu, k_uphi, k_phiphi = 12.0 * EI / L**3, -6.0 * EI / L**2, 4.0 * EI / L  # (u, phi), phi = slope
        K = np.zeros((6, 6))
        # x-z plane: (u_x, theta_y), slope = +theta_y
        K[0, 0], K[0, 4], K[4, 0], K[4, 4] = k_uu, k_uphi, k_uphi, k_phiphi
        # y-z plane: (u_y, theta_x), slope = -theta_x
        K[1, 1], K[1, 3], K[3, 1], K[3, 3] = k_uu, -k_uphi, -k_uphi, k_phiphi
        K[2, 2] = self.EA / L
        K[5, 5] = self.GJ / L
        return _readonly(K)

    @functools.cached_property
    def flexibility(self) -> np.ndarray:
        """``K^-1``: tip displacement per tip wrench (6x6) [m/N, ...]."""
        return _readonly(np.linalg.inv(self.stiffness))

    def deflection(self, wrench) -> np.ndarray:
        """Static tip displacement ``x = K^-1 w`` under a tip wrench ``w = (f, m)`` [m, rad]."""
        w = np.asarray(wrench, dtype=float)
        if w.shape != (6,):
            raise InputError(f"tip wrench must have 6 components (force, moment), got shape {w.shape}")
        return self.flexibility @ w

    # -- mass ----------------------------------------------------------------------------
    @functools.cached_property
    def beam_inertia(self) -> pin.Inertia:
        """The beam's share of the tip mass as a rigid body (tip frame), see module notes."""
        m, L = self.mass, self.length
        mass = _C_UU / 420.0 * m
        c = -_C_UPHI / _C_UU * L  # centre of mass below the tip
        j_bend = (_C_PHIPHI - _C_UPHI**2 / _C_UU) * m * L**2 / 420.0
        j_tors = m * self.polar_gyration_radius**2 / 3.0
        return pin.Inertia(mass, np.array([0.0, 0.0, c]), np.diag([j_bend, j_bend, j_tors]))

    @functools.cached_property
    def platform_body(self) -> pin.Inertia:
        """The platform (emulated end fitting) as a rigid body in the tip frame."""
        return pin.Inertia(self.platform_mass, np.array(self.platform_com), np.array(self.platform_inertia))

    @functools.cached_property
    def spatial_inertia(self) -> pin.Inertia:
        """Emulated base body: beam share + platform, one rigid body in the tip frame."""
        return self.beam_inertia + self.platform_body

    @functools.cached_property
    def mass_matrix(self) -> np.ndarray:
        """``M_s`` (6x6, tip frame, ``[u; theta]``) [kg, kg m; kg m, kg m^2]."""
        return _readonly(self.spatial_inertia.matrix())

    def base_body(self) -> BaseBody:
        """The emulated base as a :class:`~campaign.model.robot.floating.BaseBody` (free-flyer base
        of the ideal coupling): its frame is the tip frame, the arm mounted ``mount_height``
        above it."""
        I = self.spatial_inertia
        return BaseBody(mass=float(I.mass), inertia=np.array(I.inertia), com=np.array(I.lever),
                        mount=pin.SE3(np.eye(3), np.array([0.0, 0.0, self.mount_height])))

    # -- damping and modes ---------------------------------------------------------------
    def modes(self, tip=None) -> tuple[np.ndarray, np.ndarray]:
        """Undamped modes of the tip model, with an optional rigid tip body on top.

        Parameters
        ----------
        tip : pinocchio.Inertia or (6, 6) array, optional
            Extra inertia at the tip frame (e.g. the locked arm's composite inertia).

        Returns
        -------
        freq : ndarray, shape (6,)
            Natural frequencies, ascending [Hz].
        shapes : ndarray, shape (6, 6)
            Mode shapes as columns, mass-normalised (``Phi^T M Phi = I``).
        """
        M = self.mass_matrix + tip_inertia_matrix(tip)
        w2, phi = sla.eigh(self.stiffness, M)
        return np.sqrt(w2) / (2.0 * math.pi), phi

    def first_mode_frequency(self, tip=None) -> float:
        """Lowest natural frequency of the tip model [Hz] (with an optional tip body)."""
        return float(self.modes(tip)[0][0])

    @functools.cached_property
    def damping(self) -> np.ndarray:
        """Modal damping matrix ``B = M_s Phi diag(2 zeta omega) Phi^T M_s`` (6x6) [N s/m, ...]."""
        freq, phi = self.modes()
        omega = 2.0 * math.pi * freq
        MP = self.mass_matrix @ phi
        B = MP @ np.diag(2.0 * self.damping_ratio * omega) @ MP.T
        return _readonly(0.5 * (B + B.T))

    def exact_first_frequency(self, tip_mass: float = 0.0, tip_inertia: float = 0.0,
                              tip_com_height: float = 0.0) -> float:
        """:func:`exact_first_frequency` of this beam carrying its platform body plus an
        extra tip body on the beam axis, bending in the y-z plane (about x) [Hz].

        Parameters
        ----------
        tip_mass : float
            Extra tip mass [kg].
        tip_inertia : float
            Its inertia about its own centre of mass, about x [kg m^2].
        tip_com_height : float
            Its centre of mass above the tip [m].

        Notes
        -----
        The platform and the extra body are combined into one planar rigid body (mass,
        centre-of-mass height, inertia about x); horizontal centre-of-mass offsets are
        ignored, so this is the closed form of the tip model only when both bodies sit on
        the beam axis.
        """
        P = self.platform_body
        m_tot = P.mass + tip_mass
        e = (P.mass * P.lever[2] + tip_mass * tip_com_height) / m_tot
        j = (P.inertia[0, 0] + P.mass * (P.lever[2] - e) ** 2
             + tip_inertia + tip_mass * (tip_com_height - e) ** 2)
        return exact_first_frequency(self.EI, self.length, self.mass, m_tot, j, e)
