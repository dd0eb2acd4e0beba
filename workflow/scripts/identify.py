"""Snakemake script of the identify_<base> rules: m* and e of one job unit's trials, one CSV row each."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job=f"{snakemake.rule} {dict(snakemake.wildcards)}",  # noqa: F821
                    exit_process=True) as timer:
    with timer.imports():
        from campaign.identify.table import identify_trials
    identify_trials(list(snakemake.input.trials), snakemake.output[0],  # noqa: F821
                           options=snakemake.params.options, timer=timer)  # noqa: F821
