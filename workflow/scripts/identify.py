"""Snakemake script of the identify_<base> rules: m* and e of every trial of one base, one CSV
row each, one table (and one log) per simulation job."""

from campaign.pipeline import job_log

p = snakemake.params  # noqa: F821 - provided by Snakemake
with job_log(snakemake.log[0], job=snakemake.rule, exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.identify import identify_trials
        from campaign.pipeline import trial_paths
    for unit in p.units:
        with job_log(unit["log"], job=f"{snakemake.rule} {unit['name']}", part_of=snakemake.rule) as part:  # noqa: F821
            identify_trials(trial_paths(unit["sources"], archive_dir=p.archive), unit["csv"], options=p.options,
                            timer=part)
