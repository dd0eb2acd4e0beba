# The flexible base after identification, one job (rule flexible_base): Table 4 (eq 8 with
# the fitted lambda against the identified flexible-base m*; CSV, Markdown and HTML, naming the
# structure its trials emulate) and the calibration report (the fit's record read from the rig
# file, the held-out flexible-base results of this campaign beside the paper's). Each product
# with its own log.


if PLAN.flexible_base_products():

    rule flexible_base:
        input:
            **PLAN.flexible_base_inputs(),
        output:
            **outputs(PLAN.flexible_base_outputs()),
        params:
            code=[PLAN.stage_code("tables"), PLAN.stage_code("calibration_report")],
            products=PLAN.flexible_base_products(),
            classes=list(PLAN.fit_jsons()),
            structure=PLAN.shown_structure,
            fig9_trials=lambda wc: PLAN.figure_trials("fig9") if "calibration" in PLAN.flexible_base_products() else {},
        priority: PRIORITY["flexible_base"]
        log:
            **PLAN.flexible_base_logs(),
        benchmark:
            PLAN.bench_file("flexible_base")
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/flexible_base.py"
