"""What a user types, checked before any work: one layer for the CLI, the API and the workflow.

Each check raises :class:`campaign.errors.InputError` with one line that names the key or
option, the bad value and what is allowed. The CLI turns it into ``campaign <cmd>: error:
...`` and exit status 2; the workflow's start-up (``workflow/rules/common.smk``) calls
:func:`check_workflow_config`, so ``snakemake -n`` fails the same way before any job.

Only the standard library and PyYAML are imported at the top: Snakemake evaluates the
workflow's helpers on every start, a dry run included. The scene (numpy) is imported when
a check needs it, the identification options (pinocchio) only when the configuration sets
them; the rig itself never.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from .errors import InputError, allowed_names

__all__ = [
    "SPEED_DECIMALS", "check_seed", "check_rig_params", "pendulum_reach", "check_speeds",
    "check_identify_options", "check_output_file", "check_output_dir", "check_positive_int",
    "parse_typed_strings", "check_schema", "check_workflow_config",
]

#: decimals of a speed in a trial's path (``v1.500``); speeds must differ at this precision
SPEED_DECIMALS = 3


def check_seed(seed: Any, *, key: str = "seed") -> int:
    """A seed: an integer in [0, 2**63 - 1] (what a trial file's int64 attribute holds)."""
    from .scene import SEED_MAX

    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_MAX:
        raise InputError(f"{key} = {seed!r} is not an integer in [0, 2**63 - 1]")
    return seed


def check_positive_int(value: Any, *, key: str) -> int:
    """An integer >= 1 (a budget, a count)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InputError(f"{key} = {value!r} must be an integer >= 1")
    return value


def check_rig_params(params: Mapping[str, Any] | None, *, rig: str | os.PathLike | None = None,
                     key: str = "rig_params") -> dict[str, Any]:
    """Every key of ``params`` is a parameter of the rig file; the scene checks the values.

    Returns the rig file's values with ``params`` applied (dotted keys)."""
    from .scene import load_rig

    values, _ = load_rig(rig)
    for name in params or {}:
        if name not in values:
            raise InputError(f"{key}: unknown rig parameter {name!r}; {allowed_names(str(name), list(values))}")
    return {**values, **dict(params or {})}


def pendulum_reach(values: Mapping[str, Any]) -> float:
    """Largest head speed [m/s] the pendulum of the rig values ``values`` reaches (``inf``
    without gravity, where the hammer is launched at the asked speed)."""
    from .scene import hammer_reach

    return hammer_reach(float(values["pendulum.head_mass"]), float(values["pendulum.rod_mass"]),
                        float(values["pendulum.radius"]), float(values["gravity"]),
                        float(values["pendulum.max_release_deg"]))


def check_speeds(speeds: Iterable[Any], *, key: str = "speeds", reach: float = math.inf) -> list[float]:
    """Impact speeds: finite, > 0, within the pendulum's ``reach``, distinct in their paths."""
    out: list[float] = []
    seen: dict[str, float] = {}
    for s in speeds:
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not math.isfinite(s) or s <= 0:
            raise InputError(f"{key}: speed {s!r} must be a finite number > 0 m/s")
        if s > reach:
            raise InputError(f"{key}: speed {s} m/s is beyond what the pendulum can reach (max {reach:.3f} m/s "
                             f"at its release limit, pendulum.max_release_deg)")
        label = f"{float(s):.{SPEED_DECIMALS}f}"
        if label in seen:
            raise InputError(f"{key}: speeds {seen[label]} and {s} m/s are the same trial path v{label} "
                             f"(speeds must differ in the first {SPEED_DECIMALS} decimals)")
        seen[label] = s
        out.append(float(s))
    return out


def check_identify_options(options: Mapping[str, Any] | None, *, key: str = "identify"):
    """:class:`campaign.identify.IdentifyOptions` from ``options``, every name and value checked."""
    import dataclasses

    from .identify import IdentifyOptions

    names = [f.name for f in dataclasses.fields(IdentifyOptions)]
    for name in options or {}:
        if name not in names:
            raise InputError(f"{key}: unknown identification option {name!r}; {allowed_names(str(name), names)}")
    try:
        return IdentifyOptions(**dict(options or {}))
    except InputError as exc:
        raise InputError(f"{key}: {exc}") from None


def check_output_file(path: str | os.PathLike, *, option: str = "--out") -> Path:
    """A file that can be written: not a folder, its folder a folder (or creatable) and writable."""
    out = Path(path)
    if out.is_dir():
        raise InputError(f"{option} {path}: is a folder; name a file")
    _check_parent(out, option=option, path=path)
    if out.exists() and not os.access(out, os.W_OK):
        raise InputError(f"{option} {path}: the file is not writable")
    return out


def check_output_dir(path: str | os.PathLike, *, option: str = "--out") -> Path:
    """A folder that can be written into (created if missing): not an existing file."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise InputError(f"{option} {path}: is a file; name a folder (created if missing)")
    if out.is_dir():
        if not os.access(out, os.W_OK | os.X_OK):
            raise InputError(f"{option} {path}: the folder is not writable")
        return out
    _check_parent(out, option=option, path=path)
    return out


def _check_parent(out: Path, *, option: str, path) -> None:
    """The nearest existing ancestor of ``out`` is a writable folder."""
    parent = out.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"{option} {path}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: the folder {parent} is not writable")


# ---------------------------------------------------------------------------------------
# the workflow's configuration
# ---------------------------------------------------------------------------------------
def parse_typed_strings(config: dict, schema: Mapping[str, Any]) -> dict:
    """Values given on Snakemake's command line as the user typed them (``--config
    simulate=false``, ``--config 'speeds=[1.0,2.5]'``): Snakemake passes a value it does
    not recognise as a string (also each item of a list), so a string where the schema
    wants a boolean, number, array or object is read as YAML, in place, at any depth. A
    value that stays a string is left for the schema to name."""
    for name, value in list(config.items()):
        config[name] = _typed(value, schema.get("properties", {}).get(name, {}), schema)
    return config


def _typed(value: Any, spec: Mapping[str, Any], root: Mapping[str, Any]) -> Any:
    import yaml

    if "$ref" in spec:
        spec = root.get("$defs", {}).get(spec["$ref"].rsplit("/", 1)[-1], {})
    types = spec.get("type", [])
    types = [types] if isinstance(types, str) else list(types)
    if isinstance(value, str) and types and "string" not in types:
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError:
            return value  # the schema then names the key and the bad string
    if isinstance(value, list) and isinstance(spec.get("items"), Mapping):
        return [_typed(v, spec["items"], root) for v in value]
    if isinstance(value, dict):
        props = spec.get("properties", {})
        return {k: _typed(v, props.get(k, {}), root) for k, v in value.items()}
    return value


def check_schema(config: Mapping[str, Any], schema: Mapping[str, Any]) -> None:
    """``config`` against the JSON schema: the first failure as one line naming its key."""
    import jsonschema

    cls = jsonschema.validators.validator_for(schema)
    error = jsonschema.exceptions.best_match(cls(schema).iter_errors(config))
    if error is not None:
        key = ".".join(str(p) for p in error.absolute_path) or "(top level)"
        raise InputError(f"configuration key {key}: {error.message}")


def check_workflow_config(config: Mapping[str, Any], *, sweeps: Mapping[str, Mapping[str, Any]]) -> None:
    """What the schema cannot say about a workflow configuration (after it passed the schema).

    ``sweeps`` is ``{base: {configurations, gains, speeds, repeats}}`` as the workflow runs
    it. Checked: every ``rig_params`` key is a rig parameter and the resulting scene is
    valid; every speed of every base is within the pendulum's reach and distinct at the
    path's precision; every ``identify`` option exists and has an allowed value.
    """
    from .scene import make_scene

    rig = config.get("rig") or None
    if rig is not None and not Path(rig).is_file():
        raise InputError(f"configuration key rig: rig parameter file {rig!r} does not exist")
    params = dict(config.get("rig_params") or {})
    values = check_rig_params(params, rig=rig, key="configuration key rig_params")
    for base, sweep in sweeps.items():
        try:
            make_scene(base=base, config=sweep["configurations"][0], gain=sweep["gains"][0],
                       speed=min(sweep["speeds"]), params=params, rig=rig)
        except InputError as exc:
            raise InputError(f"configuration key rig_params: {exc}") from None
        where = f"bases.{base}.speeds" if "speeds" in (config.get("bases", {}).get(base) or {}) else "speeds"
        check_speeds(sweep["speeds"], key=f"configuration key {where}", reach=pendulum_reach(values))
    if config.get("identify"):
        check_identify_options(config["identify"], key="configuration key identify")
