"""One trial's validated description.

A :class:`Scene` names the cell of the campaign (base x configuration x gain set x impact
speed x repeat), its seed, and every rig parameter in SI units (defaults from
``config/rig.yaml``). It is immutable, serialises to canonical JSON (stored in every trial
file with its sha256) and is validated on construction, so a bad value is reported before
any simulation starts.

Parameters are addressed by dotted keys, ``scene.p("contact.stiffness")``.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
from pathlib import Path
from typing import Any, Mapping

from .errors import InputError, allowed_names
from .paper import config_dir, load_paper, read_yaml

__all__ = ["Scene", "load_rig", "make_scene", "derive_seed", "BASES", "GAINS", "SCENE_NAMES", "SEED_MAX", "hammer_reach"]

BASES = ("fixed", "flexible")
GAINS = ("zero", "low", "high")
SCENE_NAMES = ("default", "ideal")

# Parameters that must be > 0, and those that must be >= 0.
_POSITIVE = (
    "pendulum.head_mass", "pendulum.radius", "contact.stiffness", "contact.exponent",
    "controller.servo_rate", "sensors.joint_encoder_rate", "sensors.pendulum_encoder_rate",
    "sensors.pendulum_encoder_counts", "sensors.piezo_rate", "sensors.ft_rate", "sensors.truth_rate",
    "sensors.piezo_full_scale", "trial.pre_contact", "trial.min_post_contact", "trial.max_post_contact",
    "trial.settle_velocity", "integration.substeps_contact", "integration.substeps_free",
    "flexible.beam_EI", "flexible.beam_length", "flexible.beam_mass", "flexible.beam_GJ_ratio",
    "flexible.beam_EA_ratio", "flexible.platform_mass", "flexible.trial_periods", "ves.rate", "ves.bandwidth",
    "pendulum.max_release_deg", "arm.stick_velocity", "pendulum.catch_delay",
)
_NONNEGATIVE = (
    "gravity", "arm.coulomb_scale", "arm.viscous_scale", "controller.torque_per_unit", "pendulum.rod_mass",
    "sensors.joint_encoder_noise_counts", "sensors.piezo_noise", "sensors.piezo_resolution",
    "sensors.ft_noise_force", "sensors.ft_noise_torque", "trial.contact_jitter", "flexible.damping_ratio",
    "ves.latency", "flexible.mount_height",
)


#: largest seed a trial file can store (its attributes are signed 64-bit integers)
SEED_MAX = 2**63 - 1


def _flatten(tree: Mapping, prefix: str = "") -> dict[str, Any]:
    """{a: {b: {value: 1, units: ...}}} -> {"a.b": 1}."""
    out: dict[str, Any] = {}
    for key, node in tree.items():
        name = f"{prefix}{key}"
        if isinstance(node, Mapping) and "value" in node:
            out[name] = node["value"]
        elif isinstance(node, Mapping):
            out.update(_flatten(node, name + "."))
        else:
            out[name] = node
    return out


def load_rig(path: str | Path | None = None) -> tuple[dict[str, Any], dict[str, dict]]:
    """Read a rig file: (flat parameter values, named scene overrides)."""
    path = Path(path) if path is not None else config_dir() / "rig.yaml"
    if not path.is_file():
        raise InputError(f"rig parameter file {path} does not exist")
    tree = read_yaml(path)      # parsed once per file content; a fresh copy to modify
    if not isinstance(tree, dict):
        raise InputError(f"rig parameter file {path}: expected a mapping of parameters, got {type(tree).__name__}")
    scenes = tree.pop("scenes", {}) or {}
    tree.pop("calibration", None)
    return _flatten(tree), {k: dict(v.get("overrides", {})) for k, v in scenes.items()}


def hammer_reach(head_mass: float, rod_mass: float, radius: float, gravity: float, max_release_deg: float) -> float:
    """Largest head speed [m/s] of the pendulum released at rest from its largest angle.

    Energy balance of the pendulum (:mod:`campaign.rig.pendulum`): a point head at
    ``radius`` on a uniform rod, ``I_p w^2 / 2 = m g l_c (1 - cos theta_0)``, head speed
    ``radius w``; ``inf`` without gravity, where the hammer is launched at the asked speed.
    Standard library only, so the workflow's start-up checks speeds without the rig.
    """
    if gravity == 0:
        return math.inf
    inertia = head_mass * radius**2 + rod_mass * radius**2 / 3.0
    mgl = (head_mass * radius + 0.5 * rod_mass * radius) * gravity
    return radius * math.sqrt(2.0 * mgl * (1.0 - math.cos(math.radians(max_release_deg))) / inertia)


def derive_seed(*parts: Any) -> int:
    """A deterministic 63-bit seed from the cell's identity (stable across runs and machines)."""
    text = json.dumps([str(p) for p in parts])
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "big") >> 1


@dataclasses.dataclass(frozen=True)
class Scene:
    """One trial: the campaign cell, seed and all rig parameters (SI units).

    Attributes
    ----------
    base : {"fixed", "flexible"}
    config : int
        Paper configuration (Table 1), or 0 when ``q_paper_deg`` is given directly.
    q_paper_deg : tuple of float
        Commanded joint angles in the paper's convention [deg].
    gain : {"zero", "low", "high"}
    gains_counts : tuple of float
        (P, D, I) in the paper's controller counts (Table 1).
    speed : float
        Hammer speed along n at the contact [m/s].
    repeat : int
    seed : int
    name : {"default", "ideal"}
    params : tuple of (key, value)
        Every rig parameter by dotted key, sorted.
    """

    base: str
    config: int
    q_paper_deg: tuple[float, ...]
    gain: str
    gains_counts: tuple[float, float, float]
    speed: float
    repeat: int
    seed: int
    name: str
    params: tuple[tuple[str, Any], ...]

    def __post_init__(self):
        self.validate()

    # -- access ---------------------------------------------------------------------
    def p(self, key: str) -> Any:
        """Value of a rig parameter by dotted key (``"contact.stiffness"``)."""
        try:
            return self._lookup[key]
        except KeyError:
            raise KeyError(f"scene has no parameter {key!r}") from None

    @functools.cached_property
    def _lookup(self) -> dict[str, Any]:
        # params is immutable: its dict is built once per scene (a trial reads ~60 keys)
        return dict(self.params)

    @property
    def param_dict(self) -> dict[str, Any]:
        return dict(self.params)

    def replace(self, **changes) -> "Scene":
        """A copy with fields and/or parameters (``params={"contact.stiffness": 1e4}``) changed."""
        params = dict(self.params)
        for k, v in (changes.pop("params", None) or {}).items():
            if k not in params:
                raise InputError(f"unknown rig parameter {k!r}")
            params[k] = v
        return dataclasses.replace(self, params=tuple(sorted(params.items())), **changes)

    # -- identity -------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        # the fields are scalars and tuples (no nested dataclasses): what dataclasses.asdict
        # gave, without its recursive copying (the scene's identity is hashed every trial)
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["params"] = dict(self.params)
        d["q_paper_deg"] = list(self.q_paper_deg)
        d["gains_counts"] = list(self.gains_counts)
        return d

    def to_json(self) -> str:
        """Canonical JSON (sorted keys, no spaces): the scene's identity in every file."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.to_json().encode()).hexdigest()

    @classmethod
    def from_json(cls, text: str) -> "Scene":
        d = json.loads(text)
        d["params"] = tuple(sorted(d["params"].items()))
        d["q_paper_deg"] = tuple(d["q_paper_deg"])
        d["gains_counts"] = tuple(d["gains_counts"])
        return cls(**d)

    @property
    def cell(self) -> str:
        """Predictable relative path of the trial: base/config/gain/speed/repeat."""
        cfg = f"config{self.config}" if self.config else "config-custom"
        return f"{self.base}/{cfg}/{self.gain}/v{self.speed:.3f}/r{self.repeat:02d}"

    # -- checks ---------------------------------------------------------------------
    def validate(self) -> None:
        if self.base not in BASES:
            raise InputError(f"unknown base {self.base!r}; expected one of {BASES}")
        if self.gain not in GAINS:
            raise InputError(f"unknown gain set {self.gain!r}; expected one of {GAINS}")
        if self.name not in SCENE_NAMES:
            raise InputError(f"unknown scene {self.name!r}; expected one of {SCENE_NAMES}")
        if not (isinstance(self.speed, (int, float)) and math.isfinite(self.speed) and self.speed > 0):
            raise InputError(f"impact speed must be a finite number > 0 m/s, got {self.speed!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or not 0 <= self.seed <= SEED_MAX:
            raise InputError(f"seed {self.seed!r} is not an integer in [0, 2**63 - 1] (trial files store it as int64)")
        if not isinstance(self.repeat, int) or self.repeat < 0:
            raise InputError(f"repeat must be an integer >= 0, got {self.repeat!r}")
        if len(self.gains_counts) != 3 or any(not math.isfinite(g) or g < 0 for g in self.gains_counts):
            raise InputError(f"PID gains (P, D, I) must be 3 finite counts >= 0, got {list(self.gains_counts)}")
        params = dict(self.params)
        for key in _POSITIVE:
            v = params.get(key)
            if v is None:
                raise InputError(f"rig parameter {key!r} is missing")
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"rig parameter {key} must be > 0, got {v!r}")
        for key in _NONNEGATIVE:
            v = params.get(key)
            if v is None:
                raise InputError(f"rig parameter {key!r} is missing")
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InputError(f"rig parameter {key} must be >= 0, got {v!r}")
        e = params.get("contact.restitution")
        if not (isinstance(e, (int, float)) and 0 < e <= 1):
            raise InputError(f"contact.restitution must be in (0, 1], got {e!r}")
        if params.get("ves.mode") not in ("loop", "ideal"):
            raise InputError(f"ves.mode must be 'loop' or 'ideal', got {params.get('ves.mode')!r}")
        inertia = params.get("flexible.platform_inertia")
        if not (isinstance(inertia, (list, tuple)) and len(inertia) == 3 and all(float(x) > 0 for x in inertia)):
            raise InputError(f"flexible.platform_inertia must be 3 values > 0 kg m^2, got {inertia!r}")
        if self.p("trial.max_post_contact") < self.p("trial.min_post_contact"):
            raise InputError("trial.max_post_contact must be >= trial.min_post_contact")


def make_scene(*, base: str = "fixed", config: int | None = 1, gain: str = "zero", speed: float = 1.5,
               repeat: int = 0, seed: int | None = None, scene: str = "default",
               q_paper_deg=None, gains_counts=None, params: Mapping[str, Any] | None = None,
               rig: str | Path | None = None, campaign_seed: int = 0) -> Scene:
    """Build a validated :class:`Scene` from the rig file, the paper's tables and overrides.

    Parameters
    ----------
    base, config, gain, speed, repeat
        The campaign cell. ``config`` is a paper configuration (1-3); pass
        ``q_paper_deg`` instead for another arm pose (paper degrees).
    seed : int, optional
        RNG seed of the sensors and the contact instant; by default derived from the cell
        and ``campaign_seed``, so the same cell always gets the same numbers.
    scene : {"default", "ideal"}
        ``ideal`` applies the rig file's ideal overrides (no gravity, friction, servo, noise;
        stiff contact; dense sampling).
    gains_counts : (P, D, I), optional
        Controller gains in counts; by default the paper's Table 1 row of ``gain``.
    params : mapping, optional
        Dotted-key rig parameter overrides, applied last.
    rig : path, optional
        Rig parameter file (default ``config/rig.yaml``).
    """
    paper = load_paper()
    values, scenes = load_rig(rig)
    if scene not in SCENE_NAMES:
        raise InputError(f"unknown scene {scene!r}; expected one of {SCENE_NAMES}")
    if scene != "default":
        over = dict(scenes.get(scene, {}))
        gain = over.pop("gain", gain)
        for k, v in over.items():
            if k not in values:
                raise InputError(f"scene {scene!r} overrides unknown rig parameter {k!r}")
            values[k] = v
    for k, v in (params or {}).items():
        if k not in values:
            raise InputError(f"unknown rig parameter {k!r}; {allowed_names(str(k), list(values))}")
        values[k] = v
    if gain not in paper["gains"]:
        raise InputError(f"unknown gain set {gain!r}; expected one of {sorted(paper['gains'])}")
    if q_paper_deg is None:
        try:
            key = int(config)
        except (TypeError, ValueError):
            key = None
        if key not in paper["configurations"]:
            raise InputError(f"unknown configuration {config!r}; known: {sorted(paper['configurations'])}")
        q_paper_deg = paper["configurations"][key]
        config = key
    else:
        config = 0 if config is None else int(config)
    if gains_counts is None:
        g = paper["gains"][gain]
        gains_counts = (float(g["P"]), float(g["D"]), float(g["I"]))
    try:
        speed = float(speed)
    except (TypeError, ValueError):
        raise InputError(f"impact speed must be a number in m/s, got {speed!r}") from None
    if seed is None:
        seed = derive_seed(campaign_seed, base, config, gain, f"{speed:.6f}", repeat, scene)
    return Scene(
        base=str(base), config=int(config), q_paper_deg=tuple(float(x) for x in q_paper_deg), gain=str(gain),
        gains_counts=tuple(float(x) for x in gains_counts), speed=speed, repeat=int(repeat), seed=int(seed),
        name=scene, params=tuple(sorted(values.items())),
    )
