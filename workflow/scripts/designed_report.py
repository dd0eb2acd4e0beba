"""Snakemake script of rule designed_report: paper design vs designed, held-out prediction, lambda per speed."""

from campaign.design import designed_campaign as designed
from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="designed_report", exit_process=True):  # noqa: F821
    designed.report(snakemake.input.plan, {role: list(getattr(snakemake.input, role))  # noqa: F821
                                           for role in designed.ROLES},
                    snakemake.output.json, snakemake.output.md, model_json=snakemake.input.model)  # noqa: F821
