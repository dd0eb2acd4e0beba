"""Snakemake script of rule designed_model: fit the response model on the designed trials and save it."""

from campaign.design import fit_model
from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="designed_model", exit_process=True):  # noqa: F821
    tables = list(snakemake.input.flexible)  # noqa: F821
    flexible = {s: [t for t in tables if t.rsplit("/", 1)[-1].startswith(f"{s}_")]
                for s in snakemake.params.structures}  # noqa: F821
    fit_model(snakemake.input.plan, list(snakemake.input.fixed), flexible,  # noqa: F821
              archive=snakemake.params.archive, out_json=snakemake.output.json,  # noqa: F821
              out_md=snakemake.output.md, check_tables=list(snakemake.input.checks))  # noqa: F821
