# Identification: per trial m* (eq 10) and e (eq 12) from the measured channels only, one
# CSV row per trial, one table per simulation job (the same unit). One job per base identifies
# every trial of the base (one interpreter and one set of imports for all its tables), each
# table with its own log; it reads its trials from the simulation jobs' manifests, or from
# `reuse_archive` when nothing is simulated.

for _base in PLAN.sweeps:

    rule:
        name:
            f"identify_{_base}"
        input:
            PLAN.base_sources(_base),
        output:
            PLAN.ident_tables(_base),
        params:
            code=PLAN.stage_code("identify"),
            options=config["identify"],
            archive=lambda wc: PLAN.trial_root,
            units=PLAN.identify_units(_base),
        # scheduling: the fixed base's identification leads to the fits and the maps (plan_parts.PRIORITY)
        priority: PRIORITY[f"identify_{_base}"]
        log:
            # the job's own (start-up, imports), then one per table
            PLAN.identify_logs(_base),
        benchmark:
            PLAN.bench_file(f"identify_{_base}")
        threads: 1
        resources:
            runtime=20,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/identify.py"
