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

if PLAN.simulate:
    for _base in PLAN.sweeps:

        rule:
            name:
                f"simulate_{_base}"
            input:
                rig=PLAN.rig_file,
                paper=PLAN.paper_file,
            output:
                PLAN.job_manifest_pattern(_base),
            params:
                code=PLAN.stage_code("simulate"),
                cells=lambda wc, base=_base: [list(c) for c in PLAN.unit_cells(base, wildcard_values(wc))],
                speeds=PLAN.sweeps[_base]["speeds"],
                repeats=PLAN.sweeps[_base]["repeats"],
                campaign_seed=config["campaign_seed"],
                gain_counts=lambda wc: dict(config["gain_counts"].get(wc.gain, {})),
                rig=config["rig"],
                rig_params=PLAN.sweep_params(_base),
                archive=lambda wc: PLAN.archive,
            # scheduling: the fixed base's jobs unlock the longest chain after them (identification,
            # the lambda fits, the planner's maps), so they start first (plan_parts.PRIORITY)
            priority: PRIORITY[f"simulate_{_base}"]
            log:
                PLAN.log_file(f"simulate_{_base}", PLAN.unit_name(_base)),
            benchmark:
                PLAN.bench_file(f"simulate_{_base}", PLAN.unit_name(_base))
            threads: 1
            resources:
                runtime=20 if _base == vocabulary.FIXED else 60,
                mem_mb=1000,
            conda:
                "../envs/campaign.yaml"
            script:
                "../scripts/sweep.py"

    rule simulate_trial:
        input:
            rig=PLAN.rig_file,
            paper=PLAN.paper_file,
        output:
            PLAN.trial_pattern(),
        params:
            code=PLAN.stage_code("simulate"),
            trial=lambda wc: PLAN.single_trial(**wildcard_values(wc)),
            campaign_seed=config["campaign_seed"],
            gain_counts=lambda wc: dict(config["gain_counts"].get(wc.gain, {})),
            rig=config["rig"],
            rig_params=lambda wc: PLAN.sweep_params(wc.base),
            archive=lambda wc: PLAN.archive,
        wildcard_constraints:
            **vocabulary.trial_wildcards(),
        log:
            PLAN.trial_log_pattern(),
        threads: 1
        resources:
            runtime=5,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/sweep.py"
