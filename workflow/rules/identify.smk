# Identification: per trial m* (eq 10) and e (eq 12) from the measured channels only, one
# CSV row per trial, one table per job unit (the same unit as the simulation). The trials
# come from this campaign's archive, or from `reuse_archive` when nothing is simulated.

for _base in SWEEPS:

    rule:
        name:
            f"identify_{_base}"
        input:
            trials=lambda wc, base=_base: unit_trials(base, wc),
        output:
            f"{RESULTS}/identify/{unit_name(_base)}.csv",
        params:
            code=CODE_IDENTIFY,
            options=config["identify"],
        # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
        priority: 1
        log:
            log_file(f"identify_{_base}", unit_name(_base)),
        benchmark:
            bench_file(f"identify_{_base}", unit_name(_base))
        threads: 1
        resources:
            runtime=20,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/identify.py"
