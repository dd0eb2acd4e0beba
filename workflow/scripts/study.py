"""Snakemake script of the study rules (workflow/rules/studies.smk): one study of
campaign.studies (``params.study``) run into its folder, reduced with ``params.quick``;
``params.options`` are the study's own keyword arguments."""

import importlib
from pathlib import Path

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job=snakemake.rule, exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        study = importlib.import_module(f"campaign.studies.{snakemake.params.study}")  # noqa: F821
    with timer("study"):
        study.run(Path(snakemake.output[0]).parent, quick=bool(snakemake.params.quick),  # noqa: F821
                  log=lambda line: print(line, flush=True), **dict(snakemake.params.options))  # noqa: F821
