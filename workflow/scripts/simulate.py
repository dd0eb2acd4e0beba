"""Snakemake script of the simulate_<base> rules: simulate one job's sweep cells, one file per trial."""

from campaign.pipeline.joblog import job_log

p = snakemake.params  # noqa: F821 - provided by Snakemake
with job_log(snakemake.log[0], job=f"{snakemake.rule} {dict(snakemake.wildcards)}",  # noqa: F821
                    exit_process=True) as timer:
    with timer.imports():
        from campaign.pipeline.simulate import run_cells
    run_cells(
        [tuple(c) for c in p.cells],
        archive_dir=p.archive,
        speeds=p.speeds,
        repeats=p.repeats,
        campaign_seed=p.campaign_seed,
        gain_overrides={c[2]: p.gain_counts for c in p.cells},
        rig=p.rig,
        params=p.rig_params,
        timer=timer,
        threads=snakemake.threads,  # noqa: F821
    )
