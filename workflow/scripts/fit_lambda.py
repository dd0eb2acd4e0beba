"""Snakemake script of rule fit_lambda: lambda of one gain class from the fixed-base identification."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job=f"fit_lambda {snakemake.wildcards.gain_class}",  # noqa: F821
                    exit_process=True) as timer:
    with timer.imports():
        from campaign.pipeline.fit import fit_lambda
    fit_lambda(list(snakemake.input.tables), snakemake.output.json,  # noqa: F821
                      gain_class=snakemake.wildcards.gain_class, gains=snakemake.params.gains,  # noqa: F821
                      options=snakemake.params.options, seed=snakemake.params.seed, timer=timer)  # noqa: F821
