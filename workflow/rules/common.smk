# The workflow's wiring: the configuration, loaded and checked at start-up; the campaign's plan
# (campaign.pipeline.campaign_plan: sweeps, cells, job units, where every file lives, which
# products the configuration can make and what each needs), which every rule asks; and the
# adapters from the plan to Snakemake (its refusals as WorkflowError, report() outputs).
#
# Only the standard library, PyYAML and the package's start-up modules (standard library and
# PyYAML at import) are imported here: Snakemake evaluates this file every time it starts, a
# dry run included, so the heavy stages (numpy, pinocchio, xarray, matplotlib) load in the jobs
# only.
#
# What Snakemake plans grows with the jobs, not with the trials: a simulation job's only
# declared output is its job manifest (campaign.archive.jobs), which lists the trial files it
# wrote; the jobs downstream take the manifests as input and read their trials from them.

import os
import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version, validate

from campaign.core import vocabulary
from campaign.core.errors import InputError
from campaign.core.yamlfile import read_yaml
from campaign.pipeline import config as config_checks
from campaign.pipeline.campaign_plan import CampaignPlan
from campaign.pipeline.plan_parts import PRIORITY

min_version("9.0")

# Every job imports the campaign package of this workflow's own source tree, whatever
# environment runs it (.venv with the editable install, or a conda env of workflow/envs).
os.environ.update(PYTHONPATH=os.pathsep.join(p for p in (workflow.basedir, os.environ.get("PYTHONPATH")) if p))


configfile: "config/config.yaml"


# --config values arrive as strings unless Snakemake recognises them (simulate=false,
# speeds=[1.0,2.5]): read the command line's (not a file's) as the schema's types, then validate
# (one line naming the key), then let Snakemake's validate fill in the schema's defaults
_schema = read_yaml(Path(workflow.basedir, "workflow", "schemas", "config.schema.yaml"))
try:
    # the files as this project reads YAML: a key given twice is refused, not resolved to its last value
    config_checks.check_config_files(workflow.configfiles)
    config_checks.parse_typed_strings(config, _schema, given=workflow.config_settings.config)
    config_checks.check_environment()
    config_checks.check_schema(config, _schema)
    # the folders and files the configuration names, before anything reads them
    config_checks.check_paths(config)
except InputError as _exc:
    raise WorkflowError(str(_exc)) from None
validate(config, schema="../schemas/config.schema.yaml")


report: "../report/workflow.rst"


wildcard_constraints:
    gain="|".join(vocabulary.gain_sets()),
    config="[0-9]+",


class Refusing:
    """The plan (or a part of it) with its refusals, InputError, raised as Snakemake's
    WorkflowError: one line naming the configuration key, no traceback."""

    def __init__(self, plan):
        self._plan = plan

    def __getattr__(self, name):
        value = self._ask(getattr, self._plan, name)
        if type(value).__module__.startswith("campaign.pipeline."):     # a part of the plan
            return Refusing(value)
        return (lambda *args, **kwargs: self._ask(value, *args, **kwargs)) if callable(value) else value

    @staticmethod
    def _ask(function, *args, **kwargs):
        try:
            return function(*args, **kwargs)
        except InputError as exc:
            raise WorkflowError(str(exc)) from None


try:
    # a reused archive's files checked against its manifest once, in the main process (not per job)
    PLAN = Refusing(CampaignPlan.from_config(config, check_reuse=workflow.is_main_process))
except InputError as _exc:
    raise WorkflowError(str(_exc)) from None
for _note in PLAN.notes:
    print(_note, file=sys.stderr)
# the designed campaign's settings (the designed rules exist when its file does)
if PLAN.designed.settings:
    try:
        config_checks.check_schema(PLAN.designed.settings, read_yaml(Path(workflow.basedir, "workflow", "schemas",
                                   "designed.schema.yaml")), where=f"designed campaign file {PLAN.designed.file}: key")
    except InputError as _exc:
        raise WorkflowError(str(_exc)) from None
    validate(PLAN.designed.settings, schema="../schemas/designed.schema.yaml")


def all_targets():
    """What `snakemake` alone makes (rule all), naming on stderr the products it cannot make."""
    for line in PLAN.skipped():
        print(line, file=sys.stderr)
    return PLAN.default_targets() + PLAN.calibration_targets()


def outputs(items):
    """Snakemake outputs of the plan's (path, report) items: report() for those the report shows."""
    return {name: report(path, **{**shown, "caption": f"../report/{shown['caption']}.rst"}) if shown else path
            for name, (path, shown) in items.items()}


def wildcard_values(wildcards):
    """A job's wildcards as a plain mapping (the plan's methods take plain values)."""
    return dict(wildcards.items())
