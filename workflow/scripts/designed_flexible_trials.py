"""Snakemake script of rule designed_flexible_trials: the plan's held-out poses on the flexible base under one structure."""

from campaign.design import designed_campaign as designed
from campaign.pipeline import job_log

w = snakemake.wildcards  # noqa: F821
with job_log(snakemake.log[0], job=f"designed_flexible_trials {w.structure} {w.gain}",  # noqa: F821
             exit_process=True) as timer:
    designed.run_trials(snakemake.input.plan, "heldout", w.gain, archive_dir=snakemake.params.archive,  # noqa: F821
                        out_csv=snakemake.output.csv, timer=timer, structure=w.structure)  # noqa: F821
