"""A table of impacts: what a joint-resistance model fits on and predicts for.

Each row is one blow: the arm's pose (DH angles), the impact direction n (the force on the
arm), the object's speed and mass, the gain set of the arm's servo, and on fitting the
identified m* (eq 10) and restitution (eq 12). The table states its base (fixed or
flexible) and, on the flexible base, the named structure. :meth:`Impacts.from_records` builds
it from identification records (:func:`campaign.identify.table.read_identification`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, bases
from ..identify.results import is_usable

__all__ = ["Impacts"]


def _vector(name: str, value, n: int) -> np.ndarray:
    a = np.asarray(value, float)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise InputError(f"impacts: {name} must be {n} finite numbers, got shape {a.shape}")
    return a


@dataclasses.dataclass(frozen=True)
class Impacts:
    """N impacts on one base.

    Attributes
    ----------
    q : (N, nv) DH joint angles [rad].
    direction : (N, 3) unit impact directions, base frame.
    speed : (N,) object speed along n [m/s], > 0.
    gain : tuple of N gain-set names (the paper's Table 1).
    mass : (N,) object mass [kg], > 0, or None: the rig's hammer.
    pendulum : bool
        The object is the rig's pendulum hammer (eq 10 then counts its gravity's impulse over
        the contact); False: a free object.
    base : {"fixed", "flexible"}
    structure : str or None
        The flexible base's named structure (None: the rig file's own).
    m_eff : (N,) identified m* [kg], or None (predictions only).
    restitution : (N,) identified e, or None.
    keys : tuple of N str, or None
        The impacts' names (trial paths), keys of a fit's residuals.
    """

    q: np.ndarray
    direction: np.ndarray
    speed: np.ndarray
    gain: tuple
    mass: np.ndarray | None = None
    pendulum: bool = True
    base: str = FIXED
    structure: str | None = None
    m_eff: np.ndarray | None = None
    restitution: np.ndarray | None = None
    keys: tuple | None = None

    def __post_init__(self):
        q = np.atleast_2d(np.asarray(self.q, float))
        N = q.shape[0]
        if q.ndim != 2 or not np.all(np.isfinite(q)):
            raise InputError(f"impacts: q must be finite with shape (N, nv), got {np.asarray(self.q).shape}")
        d = np.broadcast_to(np.asarray(self.direction, float), (N, 3)).copy()
        norm = np.linalg.norm(d, axis=1)
        if not np.all(np.isfinite(norm) & (norm > 0)):
            raise InputError("impacts: every direction must be a finite non-zero 3-vector")
        sp = np.broadcast_to(np.asarray(self.speed, float), (N,)).copy()
        if not np.all(np.isfinite(sp) & (sp > 0)):
            raise InputError(f"impacts: speed must be finite and > 0 m/s, got {sp[~(np.isfinite(sp) & (sp > 0))][:3]}")
        gain = (self.gain,) * N if isinstance(self.gain, str) else tuple(str(g) for g in self.gain)
        if len(gain) != N:
            raise InputError(f"impacts: {len(gain)} gain sets for {N} impacts")
        if self.base not in bases():
            raise InputError(f"impacts: unknown base {self.base!r}; expected one of {bases()}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "direction", d / norm[:, None])
        object.__setattr__(self, "speed", sp)
        object.__setattr__(self, "gain", gain)
        for name in ("mass", "m_eff", "restitution"):
            v = getattr(self, name)
            if v is not None:
                a = np.broadcast_to(np.asarray(v, float), (N,)).copy()
                if name != "restitution" and not np.all(np.isfinite(a) & (a > 0)):
                    raise InputError(f"impacts: {name} must be finite and > 0")
                object.__setattr__(self, name, a)
        if self.keys is not None:
            keys = tuple(str(k) for k in self.keys)
            if len(keys) != N:
                raise InputError(f"impacts: {len(keys)} keys for {N} impacts")
            object.__setattr__(self, "keys", keys)

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def take(self, index) -> Impacts:
        """The impacts ``index`` (an index array or boolean mask)."""
        idx = np.arange(len(self))[np.asarray(index)]
        pick = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for name in ("q", "direction", "speed", "mass", "m_eff", "restitution"):
            if pick[name] is not None:
                pick[name] = pick[name][idx]
        pick["gain"] = tuple(self.gain[i] for i in idx)
        if self.keys is not None:
            pick["keys"] = tuple(self.keys[i] for i in idx)
        return Impacts(**pick)

    @classmethod
    def from_records(cls, records: Iterable[Mapping], *, structure: str | None = None,
                     gain_sets: Sequence[str] | None = None) -> Impacts:
        """The usable identification records (not excluded, m* finite and > 0) as a table:
        ``q_cmd``, ``impact_direction``, ``speed``, ``gain``, ``hammer_mass`` (the rig's hammer
        where a record lacks it), ``m_eff``, ``e``, ``path``, ``base``; all of one base.
        ``gain_sets`` keeps those gain sets only."""
        rows = [r for r in records if is_usable(r) and (gain_sets is None or r.get("gain") in gain_sets)]
        if not rows:
            raise InputError("no usable identification records (every one is excluded or has no finite m*)")
        base = {str(r.get("base") or FIXED) for r in rows}
        if len(base) != 1:
            raise InputError(f"the records mix bases {sorted(base)}; give one base at a time")
        nv = len(rows[0]["q_cmd"])
        masses = [r.get("hammer_mass") for r in rows]
        known = all(m is not None and math.isfinite(float(m)) for m in masses)
        return cls(q=np.array([_vector("q_cmd", r["q_cmd"], nv) for r in rows]),
                   direction=np.array([_vector("impact_direction", r["impact_direction"], 3) for r in rows]),
                   speed=np.array([float(r["speed"]) for r in rows]), gain=tuple(str(r["gain"]) for r in rows),
                   mass=np.array([float(m) for m in masses]) if known else None, base=base.pop(), structure=structure,
                   m_eff=np.array([float(r["m_eff"]) for r in rows]),
                   restitution=np.array([float(r.get("e", math.nan)) for r in rows]),
                   keys=tuple(str(r.get("path", "")) for r in rows))
