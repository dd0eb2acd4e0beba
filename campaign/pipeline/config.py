"""The workflow's configuration checked at start-up: one line naming the key, before any job.

``workflow/rules/common.smk`` calls these, so ``snakemake -n`` fails the same way as a run.
Only the standard library and PyYAML are imported at the top (a dry run evaluates this on
every start); the scene is imported when a check needs it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from ..core.errors import InputError
from ..core.files import source_date_epoch

__all__ = ["parse_typed_strings", "check_environment", "check_schema", "check_workflow_config"]
# ---------------------------------------------------------------------------------------
# the workflow's configuration
# ---------------------------------------------------------------------------------------
def parse_typed_strings(config: dict, schema: Mapping[str, Any], *, given: Mapping[str, Any] | None = None) -> dict:
    """Values given on Snakemake's command line as the user typed them (``--config
    simulate=false``, ``--config 'speeds=[1.0,2.5]'``): Snakemake passes a value it does
    not recognise as a string (also each item of a list), so a string where the schema
    wants a number, array or object is read as YAML, and one where it wants a boolean is
    ``true`` or ``false`` (any case), in place, at any depth. A value that stays a string
    is left for the schema to name.

    ``given`` holds the command line's values (Snakemake's ``workflow.config_settings.config``);
    only their keys are read, so a value a configuration file quotes (``repeats: "3"``) stays
    the string it is and the schema refuses it. None reads every key.
    """
    for name, value in list(config.items()):
        if given is None or name in given:
            config[name] = _typed(value, schema.get("properties", {}).get(name, {}), schema)
    return config


def _typed(value: Any, spec: Mapping[str, Any], root: Mapping[str, Any]) -> Any:
    if "$ref" in spec:
        spec = root.get("$defs", {}).get(spec["$ref"].rsplit("/", 1)[-1], {})
    types = spec.get("type", [])
    types = [types] if isinstance(types, str) else list(types)
    if isinstance(value, str) and types and "string" not in types:
        if "boolean" in types:
            # YAML 1.1 would also read yes/no/on/off; a switch is spelled true or false
            return {"true": True, "false": False}.get(value.strip().lower(), value)
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


def check_environment() -> None:
    """The environment the jobs read: a ``SOURCE_DATE_EPOCH`` that is set is a whole number of
    seconds (:func:`campaign.core.files.source_date_epoch`), or one line naming it."""
    source_date_epoch()


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
    # the rig file and the scene (numpy) are read here, after the schema has passed
    from ..scene.checks import check_rig_params, check_speeds, pendulum_reach
    from ..scene.description import make_scene

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
        # identification's options module imports its package (pinocchio): only when set
        from ..identify.options import check_identify_options

        check_identify_options(config["identify"], key="configuration key identify")

