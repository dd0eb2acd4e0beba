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
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..core.errors import InputError, allowed_names
from ..core.files import check_regular_file
from ..core.vocabulary import (
    FIXED,
    SPEED_DECIMALS,
    TRIAL_SUFFIX,
    ZERO,
    bases,
    config_folder,
    custom_pose_folder,
    gain_sets,
    layout,
    speed_folder,
)
from ..core.yamlfile import config_dir, read_yaml
from ..model.conventions import configurations, drive_file
from ..model.paper import impact_direction, load_paper

__all__ = ["Scene", "load_rig", "rig_values", "load_structures", "structure_of", "trial_structures", "make_scene", "derive_seed", "check_direction",
           "direction_from_azimuth", "SCENE_NAMES", "SEED_MAX", "hammer_reach"]

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
#: checked (> 0) where present: trials stored before the rig stated them carry no such key
_OPTIONAL_POSITIVE = ("ves.stroke", "ves.stroke_rotation")
#: a named structure may set only the structure's and the emulator's parameters
_STRUCTURE_PREFIXES = ("flexible.", "ves.")


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


#: the sections of a rig file beside its parameters, and what a parameter's leaf may say
_RIG_SECTIONS = ("scenes", "structures", "calibration")
_LEAF_KEYS = ("value", "units", "note", "assumption")


def _read_rig(path):
    project = config_dir() / "rig.yaml"
    path = Path(path) if path is not None else project
    if not path.exists():
        raise InputError(f"rig parameter file {path} does not exist")
    check_regular_file(path, what="rig parameter file")  # a FIFO or a folder, named as what it is
    tree = read_yaml(path)      # parsed once per file content; a fresh copy to modify
    if not isinstance(tree, dict):
        raise InputError(f"rig parameter file {path}: expected a mapping of parameters, got {type(tree).__name__}")
    scenes = tree.pop("scenes", {}) or {}
    structures = tree.pop("structures", {}) or {}
    tree.pop("calibration", None)
    if path.resolve() != project.resolve():
        _check_rig_keys(path, tree, project)
    return tree, scenes, structures


def _check_rig_keys(path: Path, tree: Mapping, project: Path) -> None:
    """Every parameter of the rig file ``path`` is one of the project's rig file, and each
    documented leaf says no more than :data:`_LEAF_KEYS`: InputError naming the first
    unknown key, as an unknown ``--set`` key is named (a misspelt key would otherwise be
    ignored and its parameter keep the project's value)."""
    known = read_yaml(project, copy=False)
    known = _flatten({k: v for k, v in known.items() if k not in _RIG_SECTIONS})
    for name in _flatten(tree):
        if name not in known:
            raise InputError(f"rig parameter file {path}: unknown rig parameter {name!r}; "
                             f"{allowed_names(name, list(known))}")

    def leaves(node, prefix=""):
        for key, sub in node.items():
            if isinstance(sub, Mapping) and "value" in sub:
                yield f"{prefix}{key}", sub
            elif isinstance(sub, Mapping):
                yield from leaves(sub, f"{prefix}{key}.")

    for name, leaf in leaves(tree):
        extra = [k for k in leaf if k not in _LEAF_KEYS]
        if extra:
            raise InputError(f"rig parameter file {path}: parameter {name} has unknown field {extra[0]!r} "
                             f"(a parameter's fields: {', '.join(_LEAF_KEYS)})")


def load_rig(path: str | Path | None = None) -> tuple[dict[str, Any], dict[str, dict]]:
    """Read a rig file: (flat parameter values, named scene overrides)."""
    tree, scenes, _ = _read_rig(path)
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


def load_structures(path: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """Named structures of a rig file: ``{name: {dotted key: value}}`` (the values a
    structure sets over the ``flexible:`` leaves; ``{}`` for the leaves themselves)."""
    tree, _, structures = _read_rig(path)
    values = _flatten(tree)
    out = {}
    for name, node in structures.items():
        over = {}
        for key, leaf in ((node or {}).get("overrides") or {}).items():
            if not str(key).startswith(_STRUCTURE_PREFIXES):
                raise InputError(f"structure {name!r} sets {key!r}: a structure may set only flexible.* and ves.* "
                                 "parameters")
            if key not in values:
                raise InputError(f"structure {name!r} sets unknown rig parameter {key!r}; "
                                 f"{allowed_names(str(key), list(values))}")
            over[str(key)] = leaf["value"] if isinstance(leaf, Mapping) and "value" in leaf else leaf
        out[str(name)] = over
    return out


#: the parameters that make a structure what it is (beam and end fitting): the recording
#: length and the closed-form switch do not
_STRUCTURE_IDENTITY = ("flexible.beam_EI", "flexible.beam_length", "flexible.beam_mass", "flexible.beam_GJ_ratio",
                       "flexible.beam_EA_ratio", "flexible.damping_ratio", "flexible.platform_mass",
                       "flexible.platform_inertia", "flexible.mount_height")


def structure_of(params: Mapping[str, Any], rig: str | Path | None = None) -> str:
    """The named structure a (stored) scene's parameters ``params`` emulate.

    A scene that names its structure (``flexible.structure``) and keeps its values is that
    one; one stored before structures were named is the structure whose values it holds.
    Otherwise ``"<name> with <keys> changed"`` (a named structure with overrides) or
    ``"unnamed"``. Read from the values, never assumed."""
    values = _flatten(_read_rig(rig)[0])
    named = {}
    for name, over in load_structures(rig).items():
        ref = dict(values)
        ref.update(over)
        named[name] = {k: ref.get(k) for k in _STRUCTURE_IDENTITY}

    def same(a, b):
        if isinstance(a, (list, tuple)) or isinstance(b, (list, tuple)):
            return a is not None and b is not None and [float(x) for x in a] == [float(x) for x in b]
        try:
            return float(a) == float(b)
        except (TypeError, ValueError):
            return a == b

    def changed(name):
        return [k for k in _STRUCTURE_IDENTITY if k in params and not same(params[k], named[name][k])]

    name = params.get("flexible.structure")
    if name in named:
        diff = changed(name)
        return name if not diff else f"{name} with {', '.join(diff)} changed"
    match = [n for n in named if not changed(n) and all(k in params for k in _STRUCTURE_IDENTITY)]
    return match[0] if len(match) == 1 else "unnamed"


def trial_structures(paths) -> list[str]:
    """The named structures (:func:`structure_of`) the flexible-base trial files ``paths``
    emulate, each read from the trial's stored scene (root attribute ``scene_json``), sorted
    and without repeats."""
    import h5py

    found = set()
    for path in paths:
        with h5py.File(path, "r") as f:
            text = f.attrs["scene_json"]
        found.add(structure_of(json.loads(text.decode() if isinstance(text, bytes) else str(text))["params"]))
    return sorted(found)


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
        The robot's configuration (the PUMA 560's: the paper's Table 1), or 0 when
        ``q_paper_deg`` is given directly.
    q_paper_deg : tuple of float
        Commanded joint angles in the robot's own angles [deg], the paper's for the PUMA 560
        (model angles: :meth:`campaign.model.robot.Robot.q_from_angles`).
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
    direction : tuple of float or None
        Unit impact direction n in the arm's base frame, horizontal (the hammer moves
        horizontally at the bottom of its swing); None is the paper's direction
        (``config/paper.yaml``), and is then left out of the scene's JSON.
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
    direction: tuple[float, float, float] | None = None

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

    def replace(self, **changes) -> Scene:
        """A copy with fields and/or parameters (``params={"contact.stiffness": 1e4}``) changed."""
        params = dict(self.params)
        for k, v in (changes.pop("params", None) or {}).items():
            if k not in params:
                raise InputError(f"unknown rig parameter {k!r}")
            if k == "flexible.structure" and v != params[k]:
                raise InputError("flexible.structure names a set of values: build the scene with make_scene("
                                 f"params={{'flexible.structure': {v!r}}}) instead of replacing it")
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
        if self.direction is None:
            # the paper's direction: the JSON (and sha256) of such a scene stays what it
            # was before scenes could carry a direction
            del d["direction"]
        else:
            d["direction"] = list(self.direction)
        return d

    def to_json(self) -> str:
        """Canonical JSON (sorted keys, no spaces): the scene's identity in every file."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.to_json().encode()).hexdigest()

    @classmethod
    def from_json(cls, text: str) -> Scene:
        d = json.loads(text)
        d["params"] = tuple(sorted(d["params"].items()))
        d["q_paper_deg"] = tuple(d["q_paper_deg"])
        d["gains_counts"] = tuple(d["gains_counts"])
        if d.get("direction") is not None:
            d["direction"] = tuple(d["direction"])
        return cls(**d)

    @property
    def impact_direction(self) -> tuple[float, float, float]:
        """Unit impact direction n, base frame: :attr:`direction`, or the paper's."""
        if self.direction is not None:
            return self.direction
        return tuple(float(x) for x in impact_direction())

    @property
    def pose_tag(self) -> str:
        """Folder name of the pose: ``config<N>`` for a paper configuration with the paper's
        direction, else ``pose-<q1>_<q2>_<q3>-n<azimuth>`` (paper degrees, the direction's
        azimuth from -x about +z in degrees), so each custom pose has its own folder."""
        if self.config and self.direction is None:
            return config_folder(self.config)
        return custom_pose_folder(self.q_paper_deg, self.impact_direction)

    @property
    def cell(self) -> str:
        """Predictable relative path of the trial: base/pose/gain/speed/repeat."""
        return "/".join(layout(self.base, self.pose_tag, self.gain, self.speed, self.repeat)).removesuffix(TRIAL_SUFFIX)

    # -- checks ---------------------------------------------------------------------
    def validate(self) -> None:
        if self.base not in bases():
            raise InputError(f"unknown base {self.base!r}; expected one of {bases()}")
        if self.gain not in gain_sets():
            raise InputError(f"unknown gain set {self.gain!r}; expected one of {gain_sets()}")
        if self.name not in SCENE_NAMES:
            raise InputError(f"unknown scene {self.name!r}; expected one of {SCENE_NAMES}")
        if not (isinstance(self.speed, (int, float)) and math.isfinite(self.speed) and self.speed > 0):
            raise InputError(f"impact speed must be a finite number > 0 m/s, got {self.speed!r}")
        if speed_folder(self.speed) == speed_folder(0):
            raise InputError(f"impact speed {self.speed!r} m/s would be stored as {speed_folder(0)}, the path of "
                             f"no speed (paths keep {SPEED_DECIMALS} decimals)")
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
        for key in _OPTIONAL_POSITIVE:
            v = params.get(key)
            if v is not None and not (isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0
                                      and (math.isfinite(v) or v == math.inf)):
                raise InputError(f"rig parameter {key} must be > 0, got {v!r}")
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
        if self.direction is not None:
            n = tuple(self.direction)
            if max(abs(a - b) for a, b in zip(check_direction(n), n, strict=True)) > 1e-12:
                raise InputError(f"scene direction {list(n)} must be a horizontal unit vector (check_direction)")


#: tolerance of the unit-length and horizontality checks of an impact direction
DIRECTION_TOL = 1e-3


def check_direction(n) -> tuple[float, float, float]:
    """An impact direction as a horizontal unit 3-vector, or InputError naming the bad value.

    The hammer moves horizontally at the bottom of its swing, so n must lie in the base
    frame's x-y plane (``|n_z| <= DIRECTION_TOL``) and have unit length within
    ``DIRECTION_TOL`` (typed decimals such as ``0.866,0.5,0`` pass); it is returned
    normalised with ``n_z = 0`` exactly.
    """
    try:
        v = [float(x) for x in n]
    except (TypeError, ValueError):
        raise InputError(f"impact direction must be 3 numbers, got {n!r}") from None
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise InputError(f"impact direction must be 3 finite numbers, got {v}")
    norm = math.sqrt(sum(x * x for x in v))
    if abs(norm - 1.0) > DIRECTION_TOL:
        raise InputError(f"impact direction {v} is not a unit vector (length {norm:.6g})")
    if abs(v[2]) > DIRECTION_TOL:
        raise InputError(f"impact direction {v} is not horizontal (n_z = {v[2]:g}): the hammer moves "
                         "horizontally at the bottom of its swing")
    h = math.hypot(v[0], v[1])
    return (v[0] / h, v[1] / h, 0.0)


def direction_from_azimuth(deg: float) -> tuple[float, float, float]:
    """The horizontal unit direction at ``deg`` from -x about +z (inverse of :func:`direction_azimuth`)."""
    a = math.radians(float(deg))
    return (-math.cos(a), -math.sin(a), 0.0)


def _apply_overrides(values: dict[str, Any], *, rig, params: Mapping[str, Any] | None) -> None:
    """The named structure's values, then the explicit overrides ``params`` (which win), in place."""
    structure = (params or {}).get("flexible.structure", values.get("flexible.structure"))
    if structure is not None:
        structures = load_structures(rig)
        if structure not in structures:
            raise InputError(f"unknown flexible.structure {structure!r}; expected one of {sorted(structures)}")
        for k, v in structures[structure].items():
            if k not in values:
                raise InputError(f"structure {structure!r} overrides unknown rig parameter {k!r}")
            values[k] = v
    for k, v in (params or {}).items():
        if k not in values:
            raise InputError(f"unknown rig parameter {k!r}; {allowed_names(str(k), list(values))}")
        values[k] = v


def rig_values(*, rig: str | Path | None = None, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The flat rig parameters of the default scene (dotted keys, SI units): the rig file's
    values, its named structure's, then ``params``; what :func:`make_scene` stores, without
    building a scene."""
    values, _ = load_rig(rig)
    _apply_overrides(values, rig=rig, params=params)
    return values


def make_scene(*, base: str = FIXED, config: int | None = 1, gain: str = ZERO, speed: float = 1.5,
               repeat: int = 0, seed: int | None = None, scene: str = "default",
               q_paper_deg=None, gains_counts=None, params: Mapping[str, Any] | None = None,
               rig: str | Path | None = None, campaign_seed: int = 0, direction=None) -> Scene:
    """Build a validated :class:`Scene` from the rig file, the paper's tables and overrides.

    Parameters
    ----------
    base, config, gain, speed, repeat
        The campaign cell. ``config`` is a configuration of the scene's robot (its drive
        file's ``configurations``; the PUMA 560's are the paper's Table 1, 1-3); pass
        ``q_paper_deg`` instead for another arm pose (the robot's angles [deg]).
    seed : int, optional
        RNG seed of the sensors and the contact instant; by default derived from the cell
        and ``campaign_seed``, so the same cell always gets the same numbers.
    scene : {"default", "ideal"}
        ``ideal`` applies the rig file's ideal overrides (no gravity, friction, servo, noise;
        stiff contact; dense sampling).
    gains_counts : (P, D, I), optional
        Controller gains in counts; by default the paper's Table 1 row of ``gain``.
    params : mapping, optional
        Dotted-key rig parameter overrides, applied last. ``flexible.structure`` names the
        structure of the rig file's ``structures:`` whose values are applied before them.
    rig : path, optional
        Rig parameter file (default ``config/rig.yaml``).
    direction : 3 numbers, optional
        Horizontal unit impact direction n, base frame (:func:`check_direction`); by default
        the paper's.
    """
    paper = load_paper()
    if direction is not None:
        direction = check_direction(direction)
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
    _apply_overrides(values, rig=rig, params=params)
    if gain not in paper["gains"]:
        raise InputError(f"unknown gain set {gain!r}; expected one of {sorted(paper['gains'])}")
    if q_paper_deg is None:
        q_paper_deg, config = _configuration(values["robot"], config)
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
        parts = [campaign_seed, base, config, gain, f"{speed:.6f}", repeat, scene]
        if config == 0 or direction is not None:   # a custom pose: its own seed per pose
            parts.append(custom_pose_folder(q_paper_deg, direction or _paper_direction()))
        seed = derive_seed(*parts)
    return Scene(
        base=str(base), config=int(config), q_paper_deg=tuple(float(x) for x in q_paper_deg), gain=str(gain),
        gains_counts=tuple(float(x) for x in gains_counts), speed=speed, repeat=int(repeat), seed=int(seed),
        name=scene, params=tuple(sorted(values.items())), direction=direction,
    )


def _configuration(robot: str, config) -> tuple[list[float], int]:
    """(angles [deg], number) of the robot's configuration ``config`` (its drive file's
    ``configurations``; the PUMA 560's are the paper's Table 1), or InputError."""
    try:
        table = configurations(robot)
    except ValueError as exc:
        raise InputError(f"rig parameter robot: {exc}") from None
    if not table:
        raise InputError(f"robot {robot} names no configurations (configurations: in its drive file "
                         f"{drive_file(robot)}): give the pose as joint angles")
    try:
        key = int(config)
    except (TypeError, ValueError):
        key = None
    if key not in table:
        raise InputError(f"unknown configuration {config!r}; known: {sorted(table)}")
    return table[key], key


def _paper_direction() -> tuple[float, float, float]:
    return tuple(float(x) for x in impact_direction())
