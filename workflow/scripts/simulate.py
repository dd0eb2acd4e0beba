"""Snakemake script of the simulate_<base> rules: simulate one job's sweep cells, one file per trial."""

from campaign import runner

p = snakemake.params  # noqa: F821 - provided by Snakemake
with runner.job_log(snakemake.log[0], job=f"{snakemake.rule} {dict(snakemake.wildcards)}",  # noqa: F821
                    exit_process=True) as timer:
    runner.run_cells(
        [tuple(c) for c in p.cells],
        archive_dir=p.archive,
        speeds=p.speeds,
        repeats=p.repeats,
        campaign_seed=p.campaign_seed,
        gain_overrides={c[2]: p.gain_counts for c in p.cells},
        rig=p.rig,
        params=p.rig_params,
        expected=list(snakemake.output),  # noqa: F821
        timer=timer,
        threads=snakemake.threads,  # noqa: F821
    )
