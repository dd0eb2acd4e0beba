"""Snakemake script of the simulate_<base> rules (one job's sweep cells, one file per trial and
the job manifest listing them) and of simulate_trial (one trial of the sweep)."""

from campaign.pipeline import job_log

p = snakemake.params  # noqa: F821 - provided by Snakemake
with job_log(snakemake.log[0], job=f"{snakemake.rule} {dict(snakemake.wildcards)}",  # noqa: F821
             exit_process=True) as timer:
    with timer.imports():
        from campaign.pipeline import run_cells, run_trial
    options = dict(campaign_seed=p.campaign_seed, rig=p.rig, params=p.rig_params, timer=timer)
    if snakemake.rule == "simulate_trial":  # noqa: F821
        t = p.trial
        run_trial(t["base"], t["config"], t["gain"], t["speed"], t["repeat"], archive_dir=p.archive,
                  repeats=t["repeats"], gain_overrides={t["gain"]: p.gain_counts}, **options)
    else:
        run_cells([tuple(c) for c in p.cells], archive_dir=p.archive, speeds=p.speeds, repeats=p.repeats,
                  gain_overrides={c[2]: p.gain_counts for c in p.cells}, job_manifest=snakemake.output[0],  # noqa: F821
                  job=f"{snakemake.rule} {dict(snakemake.wildcards)}", **options)  # noqa: F821
