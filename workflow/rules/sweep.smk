# Simulation: one job per unit of the sweep (job_unit sweep: base x gain set; cell: base x
# configuration x gain set), writing one trial file per speed x repeat (atomically, through
# campaign.archive.write_trial) and, as its only declared output, its job manifest
# (campaign.archive.jobs: each trial's path, file sha256, content digests and index row), so
# that what Snakemake plans grows with the jobs, not with the trials. A job checks every
# scene, then integrates its trials one after another with the lean trial loop
# (campaign.rig.batch, campaign.rig.trial_run); one thread, since Snakemake already runs jobs
# side by side. A rerun keeps a trial file that holds the same trial.
#
# One trial alone: `snakemake archive/<campaign>/fixed/config1/zero/v1.000/r00.nc` runs
# simulate_trial, the same trial its sweep's job writes. Both are absent when
# `simulate: false`: the trials then come from `reuse_archive` as plain source files.
#
# A rerun is triggered by the rig or paper file (inputs) and by this unit's gain counts,
# seed, speeds, repeats and rig overrides (params), so editing one gain set's counts reruns
# only that gain set's jobs.

if SIMULATE:
    for _base in SWEEPS:

        rule:
            name:
                f"simulate_{_base}"
            input:
                rig=RIG_FILE,
                paper=PAPER_FILE,
            output:
                job_manifest(_base, {"gain": "{gain}", "config": "{config}"}),
            params:
                code=CODE_SIMULATE,
                cells=lambda wc, base=_base: [list(c) for c in unit_cells(base, wc)],
                speeds=SWEEPS[_base]["speeds"],
                repeats=SWEEPS[_base]["repeats"],
                campaign_seed=config["campaign_seed"],
                gain_counts=lambda wc: dict(config["gain_counts"].get(wc.gain, {})),
                rig=config["rig"],
                rig_params=sweep_params(_base),
                archive=lambda wc: ARCHIVE,
            # scheduling: the fixed base's jobs unlock the longest chain after them (identification,
            # the lambda fits, the planner's maps), so they start first (common.smk: PRIORITY)
            priority: PRIORITY[f"simulate_{_base}"]
            log:
                log_file(f"simulate_{_base}", unit_name(_base)),
            benchmark:
                bench_file(f"simulate_{_base}", unit_name(_base))
            threads: 1
            resources:
                runtime=20 if _base == "fixed" else 60,
                mem_mb=1000,
            conda:
                "../envs/campaign.yaml"
            script:
                "../scripts/sweep.py"

    rule simulate_trial:
        input:
            rig=RIG_FILE,
            paper=PAPER_FILE,
        output:
            f"{ARCHIVE}/{{base}}/config{{config}}/{{gain}}/v{{speed}}/r{{repeat}}.nc",
        params:
            code=CODE_SIMULATE,
            trial=lambda wc: single_trial(wc),
            campaign_seed=config["campaign_seed"],
            gain_counts=lambda wc: dict(config["gain_counts"].get(wc.gain, {})),
            rig=config["rig"],
            rig_params=lambda wc: sweep_params(wc.base),
            archive=lambda wc: ARCHIVE,
        wildcard_constraints:
            base="|".join(vocabulary.bases()),
            speed=r"[0-9]+\.[0-9]{3}",
            repeat=r"[0-9]{2}",
        log:
            log_file("simulate_trial", "{base}/config{config}/{gain}/v{speed}/r{repeat}"),
        threads: 1
        resources:
            runtime=5,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/sweep.py"
