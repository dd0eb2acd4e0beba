"""Snakemake script of rule designed_plan: design the poses and draw the held-out set."""

from campaign.design import designed_campaign as designed
from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="designed_plan", exit_process=True):  # noqa: F821
    designed.plan(snakemake.params.settings, snakemake.output.plan, snakemake.output.md)  # noqa: F821
