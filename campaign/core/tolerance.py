"""The project's tolerance policy: where two computations of the same thing must agree bit for
bit, and by how much they may differ where their arithmetic differs.

**Bit for bit** (:data:`BIT_FOR_BIT`) where the same arithmetic runs: a rerun on one machine,
recovery after a killed job, a cluster run against the local run on the same machine, a
model saved and loaded. The same instructions on the same inputs give the same bits; any
difference there is a bug.

**By tolerance** where the arithmetic differs: two code paths that compute the same physics
in a different order (the lean trial loop against the reference array loop, a float kernel
against the plant's array methods: :data:`CROSS_PATH_RTOL`), and another machine, whose
BLAS kernel, libm and compiled libraries pick their instructions by CPU
(:data:`CROSS_MACHINE_RTOL` for trial channels, :data:`IDENTIFY_RTOL` for identification
results). Every tolerance is relative to the quantity's own scale (the largest magnitude of
its channel over the trial, or a named related scale: :data:`SCALE_OF`,
:data:`IDENTIFICATION_SCALES`), never an absolute number that means different things for a
5e-6 m/s velocity and a 70 N force. Quantised channels may in addition flip by one step
(:data:`QUANTUM_FLIP_FRACTION`).

:func:`compare` checks one array, :func:`differences` every channel of two groups,
:func:`identification_differences` two identification results, and :func:`worst` names the
worst offender; tests and the archive share them. The user guide's reproducibility page
states the measured differences and margins.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Collection, Iterable, Mapping
from typing import Any

import numpy as np

__all__ = ["BIT_FOR_BIT", "CROSS_PATH_RTOL", "CROSS_MACHINE_RTOL", "QUANTUM_FLIP_FRACTION", "IDENTIFY_RTOL",
           "SCALE_OF", "IDENTIFICATION_SCALES", "Difference", "compare", "differences", "worst",
           "identification_differences"]

#: Same arithmetic, same machine: no difference at all. The same instructions on the same
#: inputs give the same bits, so a rerun, a recovered job, a cluster job on this machine and
#: a saved-and-loaded model reproduce every byte of what they write.
BIT_FOR_BIT = 0.0

#: Two code paths of the same physics on one machine, relative to each quantity's scale.
#: They round differently (a dot product summed in another order, a product formed on an
#: array or on Python floats: one unit roundoff, 1.1e-16, per operation), and the
#: integration carries those differences over its ~10^3 steps and event locations. The
#: largest measured is 5.8e-14 (about 500 roundoffs); 1e-11 is 170 times that, and 150 times
#: below what a change of 1e-9 in one rig parameter moves.
CROSS_PATH_RTOL = 1e-11

#: A trial's channels computed on another machine (another CPU, BLAS kernel or libm),
#: relative to each channel's scale. The same roundoff as :data:`CROSS_PATH_RTOL`, in more
#: places (every BLAS call, the transcendental functions, the compiled dynamics library),
#: carried through the VES loop's feedback: the largest measured is 9.5e-14 of a channel's
#: scale; 1e-9 leaves a margin of 10^4 for machines not measured, and is far below any
#: physical effect (noise, quantisation steps and the sensors' accuracy are >= 1e-6).
CROSS_MACHINE_RTOL = 1e-9

#: Quantised channels (encoders, the piezo ADC) round a value to whole steps: a value
#: within a roundoff of a step boundary rounds to either side, so its sample may differ by
#: one step. At most this fraction of a channel's samples (and at least one) may differ by
#: exactly one step; every other sample is held to the channel's tolerance. The chance of
#: one flip per sample is about 2 x rtol x (scale / step), below 1e-4 for any channel of the
#: rig at :data:`CROSS_MACHINE_RTOL`; a change of the physics moves more samples or by more.
QUANTUM_FLIP_FRACTION = 1e-3

#: Identification's results on another machine, relative to each result's scale
#: (:data:`IDENTIFICATION_SCALES`). They pass through iterative fits whose stopping rules
#: follow the last bits of their objectives (the joint-space fit's bounded search of the
#: viscous scale stops at xatol = 1e-3, the contact edges' least squares at their default
#: tolerances), so another machine's arithmetic moves them far more than it moves a trial:
#: the largest measured is 1.4e-6 (m*). 1e-4 leaves a margin of 70 and stays ten times below
#: identification's own accuracy (about 1e-3, the scatter over repeats).
IDENTIFY_RTOL = 1e-4

#: scalars measured on another channel's scale: velocities on the hammer's approach speed,
#: contact times on the recording's duration (the truth clock's largest time)
SCALE_OF = {"v_a_pre": "v_b_pre", "v_a_post": "v_b_pre", "v_b_post": "v_b_pre",
            "contact_start": "t_truth", "contact_end": "t_truth"}

#: the scale of each identification result (:data:`IDENTIFY_RTOL`): ``"itself"`` its own
#: magnitude, ``"unit"`` one in its units (a ratio, an angle in rad), ``"speed"`` the trial's
#: hammer speed (the row's ``speed``), ``"contact"`` the contact's duration (``contact_end -
#: contact_start``). Other numeric results are held to :data:`CROSS_MACHINE_RTOL` of their
#: own magnitude (the instrument constants a trial states), integers and text exactly.
IDENTIFICATION_SCALES = {
    "m_eff": "itself", "e": "unit", "v_a": "speed", "v_a_post": "speed", "v_b": "speed", "v_b_post": "speed",
    "impulse": "itself", "impulse_momentum": "itself", "peak_force": "itself", "contact_start": "contact",
    "contact_end": "contact", "theta_contact": "unit",
}


@dataclasses.dataclass(frozen=True)
class Difference:
    """How far two computations of one quantity differ, against what the policy allows.

    Attributes
    ----------
    name : str
        The quantity (a channel, ``group/channel``, ``channel[column]``, a result).
    largest : float
        The largest absolute difference, one-step flips of a quantised channel left out
        (``inf`` for a difference of shape, presence, NaN or text).
    scale : float
        The scale it is relative to.
    allowed : float
        The largest difference the policy allows on that scale.
    flips : int
        Samples of a quantised channel that differ by exactly one step.
    max_flips : int
        The most such samples allowed.
    step : float
        The step those samples differ by (the largest, per-column steps differing).
    note : str
        Why the two cannot be compared number by number (shape, missing, text), else "".
    """

    name: str
    largest: float
    scale: float
    allowed: float
    flips: int = 0
    max_flips: int = 0
    step: float = 0.0
    note: str = ""

    @property
    def relative(self) -> float:
        """The largest difference on the quantity's scale (``inf`` on a zero scale)."""
        if self.largest == 0:
            return 0.0
        return self.largest / self.scale if self.scale > 0 else math.inf

    @property
    def ok(self) -> bool:
        """Within the policy: every difference allowed, at most ``max_flips`` flips."""
        return self.largest <= self.allowed and self.flips <= self.max_flips and not self.note

    def _rank(self) -> tuple:
        excess = 0.0 if self.largest == 0 else (self.largest / self.allowed if self.allowed > 0 else math.inf)
        return (not self.ok, excess, self.flips, self.relative)

    def __str__(self) -> str:
        if self.note:
            return f"{self.name}: {self.note}"
        parts = []
        if self.largest or not self.flips:
            parts.append(f"largest difference {self.largest:.3g} ({self.relative:.3g} of its scale {self.scale:.3g}), "
                         f"allowed {self.allowed:.3g}")
        if self.flips:
            parts.append(f"{self.flips} sample(s) one step ({self.step:.3g}) apart (allowed {self.max_flips})")
        return f"{self.name}: " + "; ".join(parts)


def _floats(x: Any) -> np.ndarray | None:
    """``x`` as a float array, or None for text and other non-numbers."""
    a = np.asarray(x)
    if a.dtype.kind in "biuf":
        return a.astype(float)
    if a.dtype.kind == "O":
        try:
            return a.astype(float)
        except (TypeError, ValueError):
            return None
    return None


def _texts(x: Any) -> list[str]:
    """Every element of ``x`` as text (bytes decoded as UTF-8, as HDF5 returns strings)."""
    return [v.decode() if isinstance(v, bytes) else str(v) for v in np.asarray(x, dtype=object).ravel().tolist()]


def _magnitude(a: np.ndarray, b: np.ndarray, axis: int | None) -> np.ndarray | float:
    """The largest finite magnitude of ``a`` and ``b`` (per column with ``axis=0``)."""
    both = np.concatenate([np.abs(np.where(np.isfinite(a), a, 0.0)), np.abs(np.where(np.isfinite(b), b, 0.0))],
                          axis=0 if axis == 0 else None)
    if axis == 0:
        return np.max(both, axis=0, initial=0.0)
    return float(np.max(both, initial=0.0))


def compare(a: Any, b: Any, *, name: str = "", rtol: float, floor: float = 0.0, scale: float | None = None,
            per_column: bool = False, quantum: Any = None,
            flip_fraction: float = QUANTUM_FLIP_FRACTION) -> Difference:
    """Compare two computations of one quantity under a tolerance of the policy.

    Parameters
    ----------
    a, b : array-like
        The two computations (same shape). Integers and text compare exactly; NaN equals
        NaN at the same place.
    name : str
        The quantity's name, for the report.
    rtol : float
        The tolerance relative to the scale (:data:`CROSS_PATH_RTOL`,
        :data:`CROSS_MACHINE_RTOL`, :data:`IDENTIFY_RTOL`, :data:`BIT_FOR_BIT`).
    floor : float
        The difference allowed where the scale is zero (default: none).
    scale : float, optional
        The scale (default: the largest magnitude of ``a`` and ``b``).
    per_column : bool
        Each column of a 2-d array (each element of a 1-d one) is its own quantity with its
        own scale, as the components of a state vector (a 1-d array is one row).
    quantum : float or array-like, optional
        The step of a quantised channel (per column: the last axis): samples exactly one
        step apart count as flips, at most ``flip_fraction`` of the samples and at least one.
    flip_fraction : float
        See ``quantum``.

    Returns
    -------
    Difference
        With a per-column comparison, the worst column's (named ``name[column]``).
    """
    fa, fb = _floats(a), _floats(b)
    shape_a, shape_b = np.shape(a), np.shape(b)
    if shape_a != shape_b:
        return Difference(name, math.inf, 0.0, 0.0, note=f"shape {shape_a} against {shape_b}")
    if fa is None or fb is None:
        same = _texts(a) == _texts(b)
        return Difference(name, 0.0 if same else math.inf, 0.0, 0.0, note="" if same else "the text differs")
    exact = np.asarray(a).dtype.kind in "biu" and np.asarray(b).dtype.kind in "biu"
    rtol = 0.0 if exact else rtol
    if per_column:
        fa2, fb2 = np.atleast_2d(fa), np.atleast_2d(fb)
        fa2, fb2 = fa2.reshape(fa2.shape[0], -1), fb2.reshape(fb2.shape[0], -1)
        scales = _magnitude(fa2, fb2, 0) if scale is None else np.full(fa2.shape[1], float(scale))
        steps = np.broadcast_to(np.asarray(quantum if quantum is not None else np.nan, float), fa2.shape[1:])
        cols = [_compare_values(fa2[:, j], fb2[:, j], f"{name}[{j}]", rtol, floor, float(scales[j]),
                                None if np.isnan(steps[j]) else float(steps[j]), flip_fraction)
                for j in range(fa2.shape[1])]
        return worst(cols) if cols else Difference(name, 0.0, 0.0, 0.0)
    s = _magnitude(fa, fb, None) if scale is None else float(scale)
    return _compare_values(fa, fb, name, rtol, floor, s, quantum, flip_fraction)


def _compare_values(a: np.ndarray, b: np.ndarray, name: str, rtol: float, floor: float, scale: float,
                    quantum: Any, flip_fraction: float) -> Difference:
    """:func:`compare` of two float arrays of one shape on one scale."""
    allowed = max(rtol * scale, floor)
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    if np.any(nan_a != nan_b):
        return Difference(name, math.inf, scale, allowed, note="NaN in one computation only")
    with np.errstate(invalid="ignore"):
        d = np.where(nan_a | (a == b), 0.0, np.abs(a - b))   # equal infinities are equal
    d = np.where(np.isnan(d), math.inf, d)
    flips, max_flips, size = 0, 0, 0.0
    if quantum is not None and d.size:
        step = np.broadcast_to(np.asarray(quantum, float), d.shape[-1:] if d.ndim else ())
        one = (d > allowed) & (np.abs(d - step) <= allowed + 1e-9 * step)
        flips = int(np.count_nonzero(one))
        max_flips = max(1, int(flip_fraction * d.size))
        size = float(np.max(d[one], initial=0.0))
        d = np.where(one, 0.0, d)
    return Difference(name, float(np.max(d, initial=0.0)), scale, allowed, flips, max_flips, size)


def worst(found: Iterable[Difference]) -> Difference:
    """The worst offender: a difference beyond the policy before any within it, then the
    largest against what is allowed (an empty list: no difference, named "nothing")."""
    found = list(found)
    if not found:
        return Difference("nothing", 0.0, 0.0, 0.0)
    return max(found, key=Difference._rank)


def differences(a: Mapping[str, Any], b: Mapping[str, Any], *, rtol: float, prefix: str = "",
                per_column: Collection[str] = (), quanta: Mapping[str, Any] | None = None,
                scales: Mapping[str, str] | None = None) -> list[Difference]:
    """Compare every channel of two groups (``{name: array}``) under a tolerance of the policy.

    Parameters
    ----------
    a, b : mapping of str to array-like
        The two computations; a channel only one of them holds is a difference.
    rtol : float
        See :func:`compare`.
    prefix : str
        Put before each name in the report (``"truth/"``).
    per_column : collection of str
        Channels whose columns are separate quantities (a state vector).
    quanta : mapping, optional
        ``{channel: step}`` of the quantised channels (a step per column allowed).
    scales : mapping of str to str, optional
        ``{channel: channel whose scale it takes}`` (default :data:`SCALE_OF`).

    Returns
    -------
    list of Difference
        One per channel, in name order.
    """
    scales = SCALE_OF if scales is None else scales
    quanta = quanta or {}
    out = []
    for key in sorted(set(a) | set(b)):
        if key not in a or key not in b:
            out.append(Difference(prefix + key, math.inf, 0.0, 0.0,
                                  note=f"only in the {'first' if key in a else 'second'} computation"))
            continue
        ref = scales.get(key)
        scale = None
        if ref in a and ref in b and _floats(a[ref]) is not None and _floats(b[ref]) is not None:
            scale = _magnitude(_floats(a[ref]), _floats(b[ref]), None)
        out.append(compare(a[key], b[key], name=prefix + key, rtol=rtol, scale=scale,
                           per_column=key in per_column, quantum=quanta.get(key)))
    return out


def _number(value: Any) -> float | None:
    """An identification result as a float (NaN for an empty cell), None for text."""
    if isinstance(value, str):
        if value.strip() == "":
            return math.nan
        try:
            return float(value)
        except ValueError:
            return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def identification_differences(stored: Mapping[str, Any], new: Mapping[str, Any], *, name: str = "",
                               ) -> list[Difference]:
    """Compare two identifications of one trial (results by name: a row of an identification
    table, or the fields of a result) under the policy: the results of
    :data:`IDENTIFICATION_SCALES` to :data:`IDENTIFY_RTOL` of their scale, other numbers to
    :data:`CROSS_MACHINE_RTOL` of their magnitude (space-separated numbers as vectors),
    integers and text exactly. Only the keys both hold are compared; each difference is
    named ``<name>: <key>``."""
    out = []
    speed = _number(stored.get("speed"))
    start, end = _number(stored.get("contact_start")), _number(stored.get("contact_end"))
    related = {"unit": 1.0, "speed": abs(speed) if speed is not None else None,
               "contact": abs(end - start) if start is not None and end is not None else None}
    for key in [k for k in stored if k in new]:
        label = f"{name}: {key}" if name else key
        a, b = stored[key], new[key]
        how = IDENTIFICATION_SCALES.get(key)
        if how is not None:
            x, y = _number(a), _number(b)
            if x is None or y is None:
                out.append(compare(str(a), str(b), name=label, rtol=0.0))
                continue
            scale = related.get(how)
            if scale is not None and not math.isfinite(scale):
                scale = None        # no contact found: the result on its own magnitude
            out.append(compare(x, y, name=label, rtol=IDENTIFY_RTOL, scale=scale))
            continue
        x, y = _vector(a), _vector(b)
        if x is None or y is None:
            out.append(compare(str(a), str(b), name=label, rtol=0.0))
        else:
            out.append(compare(x, y, name=label, rtol=CROSS_MACHINE_RTOL))
    return out


def _vector(value: Any) -> Any:
    """A result as numbers: a number, space-separated numbers, a sequence; None for text."""
    if isinstance(value, str) and " " in value.strip():
        parts = [_number(p) for p in value.split()]
        return None if any(p is None for p in parts) else np.array(parts)
    if isinstance(value, (list, tuple, np.ndarray)):
        return _floats(value)
    return _number(value)
