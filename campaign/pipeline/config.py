"""The workflow's configuration checked at start-up: one line naming the key, before any job.

The workflow's wiring (``workflow/rules/common.smk``) and the campaign's plan
(:mod:`campaign.pipeline.campaign_plan`) call these, so ``snakemake -n`` fails the same way as a run.
Only the standard library and PyYAML are imported at the top (a dry run evaluates this on
every start); the scene is imported when a check needs it. ``settings`` is the workflow
configuration (the mapping Snakemake calls ``config``), ``configuration`` an arm
configuration's number.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from ..core.errors import InputError
from ..core.files import source_date_epoch
from ..core.vocabulary import figure_cells
from ..core.yamlfile import yaml_load

__all__ = ["parse_typed_strings", "check_config_files", "check_environment", "check_schema", "check_paths", "check_workflow_config",
           "trial_pick_problem", "check_products"]
# ---------------------------------------------------------------------------------------
# the workflow's configuration
# ---------------------------------------------------------------------------------------
def parse_typed_strings(settings: dict, schema: Mapping[str, Any], *, given: Mapping[str, Any] | None = None) -> dict:
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
    for name, value in list(settings.items()):
        if given is None or name in given:
            settings[name] = _typed(value, schema.get("properties", {}).get(name, {}), schema)
    return settings


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
            value = yaml_load(value)
        except yaml.YAMLError:
            return value  # the schema then names the key and the bad string
    if isinstance(value, list) and isinstance(spec.get("items"), Mapping):
        return [_typed(v, spec["items"], root) for v in value]
    if isinstance(value, dict):
        props = spec.get("properties", {})
        return {k: _typed(v, props.get(k, {}), root) for k, v in value.items()}
    return value


def check_config_files(paths: Sequence[str | Path]) -> None:
    """The configuration files Snakemake read, read again as this project reads YAML
    (:func:`campaign.core.yamlfile.read_yaml`): a key given twice, which Snakemake's loader
    silently resolves to its last value, is refused naming the key and its lines; so are an
    alias bomb and a file over the size limit. One line naming the file."""
    from ..core.yamlfile import read_yaml

    for path in paths:
        if Path(path).is_file():
            read_yaml(path, copy=False)


def check_environment() -> None:
    """The environment the jobs read: a ``SOURCE_DATE_EPOCH`` that is set is a whole number of
    seconds (:func:`campaign.core.files.source_date_epoch`), or one line naming it."""
    source_date_epoch()


def check_schema(settings: Mapping[str, Any], schema: Mapping[str, Any], *, where: str = "configuration key") -> None:
    """``settings`` (the workflow configuration) against the JSON schema: the first failure
    as one line, ``"<where> <key>: <what is wrong>"``.

    An ``integer`` is an integer as written: JSON Schema also takes a float with no fraction
    (``1e30``, ``3.0``), which a seed or a count must not be."""
    import jsonschema

    base = jsonschema.validators.validator_for(schema)
    strict = base.TYPE_CHECKER.redefine("integer", lambda _, v: isinstance(v, int) and not isinstance(v, bool))
    cls = jsonschema.validators.extend(base, type_checker=strict)
    error = jsonschema.exceptions.best_match(cls(schema).iter_errors(settings))
    if error is not None:
        key = ".".join(str(p) for p in error.absolute_path) or "(top level)"
        raise InputError(f"{where} {key}: {error.message}")



def check_workflow_config(settings: Mapping[str, Any], *, sweeps: Mapping[str, Mapping[str, Any]]) -> None:
    """What the schema cannot say about a workflow configuration (after it passed the schema).

    ``sweeps`` is ``{base: {configurations, gains, speeds, repeats}}`` as the workflow runs
    it. Checked: every ``rig_params`` key is a rig parameter and the resulting scene is
    valid; every speed of every base is within the pendulum's reach and distinct at the
    path's precision; every ``identify`` option exists and has an allowed value.
    """
    # the rig file and the scene (numpy) are read here, after the schema has passed
    from ..scene.checks import check_rig_params, check_speeds, pendulum_reach
    from ..scene.description import make_scene

    rig = settings.get("rig") or None
    params = dict(settings.get("rig_params") or {})
    values = check_rig_params(params, rig=rig, key="configuration key rig_params")
    for base, sweep in sweeps.items():
        try:
            make_scene(base=base, config=sweep["configurations"][0], gain=sweep["gains"][0],
                       speed=min(sweep["speeds"]), params=params, rig=rig)
        except InputError as exc:
            raise InputError(f"configuration key rig_params: {exc}") from None
        where = f"bases.{base}.speeds" if "speeds" in (settings.get("bases", {}).get(base) or {}) else "speeds"
        check_speeds(sweep["speeds"], key=f"configuration key {where}", reach=pendulum_reach(values))
    if settings.get("identify"):
        # identification's options module imports its package (pinocchio): only when set
        from ..identify.options import check_identify_options

        check_identify_options(settings["identify"], key="configuration key identify")



def check_paths(settings: Mapping[str, Any]) -> None:
    """The folders and files a configuration names, before anything reads or writes them:
    ``archive_root`` and ``results_root`` are folders (or do not exist yet) and not the same
    folder, ``rig`` is an
    existing file, ``reuse_archive`` (when nothing is simulated) and ``identification_csv``
    are not folders of the wrong kind. One line naming the key."""
    for key in ("archive_root", "results_root"):
        value = settings.get(key)
        if value is not None and Path(value).exists() and not Path(value).is_dir():
            raise InputError(f"configuration key {key}: {value!r} is a file, not a folder")
    archive, results = settings.get("archive_root", "archive"), settings.get("results_root", "results")
    if Path(archive).resolve() == Path(results).resolve():
        raise InputError(f"configuration key results_root: {results!r} is also archive_root; an archive folder "
                         "holds its trials and their manifest only: give the results another folder")
    rig = settings.get("rig")
    if rig is not None and not Path(rig).is_file():
        what = "is a folder, not" if Path(rig).is_dir() else "does not exist: it names"
        raise InputError(f"configuration key rig: {rig!r} {what} a rig parameter file (null = config/rig.yaml)")
    reuse = settings.get("reuse_archive")
    if not settings.get("simulate", True) and reuse and Path(reuse).exists() and not Path(reuse).is_dir():
        raise InputError(f"configuration key reuse_archive: {reuse!r} is a file, not an archive folder")
    export = settings.get("identification_csv")
    if export and Path(export).is_dir():
        raise InputError(f"configuration key identification_csv: {export!r} is a folder, not a CSV file")


def trial_pick_problem(base: str, configuration: int, gain: str, speed: float, repeat: int, *,
                       sweeps: Mapping[str, Mapping[str, Any]], key: str, held: Sequence[tuple] = ()) -> str:
    """Why the trial a figure shows (configuration key ``key``: ``figures.fig5``) is not one
    of the campaign's, or "". ``configuration`` is the arm configuration's number; ``sweeps``
    as :func:`check_workflow_config`; ``held`` are the cells (base, configuration, gain) the
    campaign holds."""
    if (base, configuration, gain) not in held:
        return (f"configuration key {key} needs cell {base}/config{configuration}/{gain}, "
                f"which bases.{base} does not list")
    sweep = sweeps[base]
    if float(speed) not in [float(s) for s in sweep["speeds"]]:
        return (f"configuration key {key}.speed: {speed:g} m/s is not one of the {base}-base speeds "
                f"{[float(s) for s in sweep['speeds']]}")
    if not 0 <= int(repeat) < int(sweep["repeats"]):
        return f"configuration key {key}.repeat: {repeat} but the {base} base runs {sweep['repeats']} repeat(s)"
    return ""


def check_products(settings: Mapping[str, Any], *, sweeps: Mapping[str, Mapping[str, Any]],
                   held: Mapping[str, Sequence[tuple]], wanted: Mapping[str, bool]) -> None:
    """The configuration of the products, at start-up (one line naming the key): the trial
    each single-trial figure shows (``figures.fig5``, ``figures.fig9``, for a figure the
    campaign makes: ``wanted``), and the planner's maps (``plan_maps.config`` a paper
    configuration, ``plan_maps.resolution`` a grid the map can sample)."""
    # the paper's tables and the map's grid limit: standard library and PyYAML only
    from ..core.yamlfile import config_file, read_yaml
    from ..plan.grid import grid_points

    figures = settings.get("figures") or {}
    for name in ("fig5", "fig9"):
        cells = figure_cells(name)
        base = cells[0][0]
        if not wanted.get(name) or base not in sweeps:
            continue
        pick = figures.get(name) or {}
        speed = float(pick.get("speed", max(sweeps[base]["speeds"])))
        repeat = int(pick.get("repeat", 0))
        for _, c, g in cells:
            why = trial_pick_problem(base, c, g, speed, repeat, sweeps=sweeps, key=f"figures.{name}",
                                     held=held.get(base, ()))
            if why:
                raise InputError(why)
    maps = settings.get("plan_maps") or {}
    known = sorted(int(c) for c in read_yaml(config_file("paper.yaml"))["configurations"])
    if "config" in maps and maps["config"] not in known:
        raise InputError(f"configuration key plan_maps.config: {maps['config']!r} is not a paper configuration "
                         f"(known: {', '.join(map(str, known))})")
    if wanted.get("plan_maps") and "resolution" in maps:
        grid_points(maps["resolution"], key="configuration key plan_maps.resolution")
