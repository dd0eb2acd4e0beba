"""Snakemake script of rule designed_model_shipped: is the fitted model the one the repository ships?"""

from campaign.design import compare_shipped
from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="designed_model_shipped", exit_process=True):  # noqa: F821
    compare_shipped(snakemake.input.fitted, snakemake.output[0], shipped=snakemake.input.shipped)  # noqa: F821
