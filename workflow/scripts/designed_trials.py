"""Snakemake script of rule designed_trials: simulate and identify one role x gain set of the plan."""

from campaign.design import designed_campaign as designed
from campaign.pipeline import job_log

w = snakemake.wildcards  # noqa: F821
with job_log(snakemake.log[0], job=f"designed_trials {w.role} {w.gain}", exit_process=True) as timer:  # noqa: F821
    designed.run_trials(snakemake.input.plan, w.role, w.gain, archive_dir=snakemake.params.archive,  # noqa: F821
                        out_csv=snakemake.output.csv, timer=timer)  # noqa: F821
