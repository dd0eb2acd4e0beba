# Simulation: one job per unit of the sweep (job_unit sweep: base x gain set; cell: base x
# configuration x gain set), writing one trial file per speed x repeat (atomically, through
# campaign.archive.write_trial). A job integrates its trials together, in lock-step, through
# Pinocchio's batched ABA (campaign.rig.batch); `threads:` is the OpenMP threads of those
# calls: one, since Snakemake already runs jobs side by side (a profile giving a job more
# cores may raise it; docs/benchmarks.rst, batched rig, measures 1 against 2). Absent when
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
                simulate_outputs(_base),
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
            # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
            priority: 2
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
                "../scripts/simulate.py"
