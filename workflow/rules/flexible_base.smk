# The flexible base after identification, one job (rule flexible_base): Table 4 (eq 8 with
# the fitted lambda against the identified flexible-base m*; CSV, Markdown and HTML, naming the
# structure its trials emulate) and the calibration report (the fit's record read from the rig
# file, the held-out flexible-base results of this campaign beside the paper's). Each product
# with its own log.


if flexible_base_products():

    rule flexible_base:
        input:
            **flexible_base_inputs(),
        output:
            **flexible_base_outputs(),
        params:
            code=[CODE_TABLES, code_digest("pipeline/calibration_report.py", "model/robot/*/*")],
            products=flexible_base_products(),
            classes=list(fit_jsons()),
            structure=FLEX_STRUCTURE,
            fig9_trials=lambda wc: {key.replace("_", "-")[1:]: path for key, (_, path) in fig9_sources().items()}
            if "calibration" in flexible_base_products() else {},
        priority: PRIORITY["flexible_base"]
        log:
            **{p: log_file("calibration_report" if p == "calibration" else p) for p in flexible_base_products()},
            job=log_file("flexible_base"),
        benchmark:
            bench_file("flexible_base")
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/flexible_base.py"
