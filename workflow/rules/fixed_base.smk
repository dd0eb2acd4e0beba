# The fixed base after identification, one job (rule fixed_base): the Virtual Rotor Inertia
# lambda (eq 11, 15) per gain class of the paper (zero_low, high) from the fixed-base trials of
# every configuration, with bootstrap intervals and the identifiability findings
# (campaign.joints.lambda_fit.LambdaFit); Table 2 (effective masses) and Table 3 (lambda), each
# CSV (full precision), Markdown and HTML (shown in the report), the paper's values beside
# ours; Figures 6 and 7 (effective mass, restitution), PNG and PDF. Everything here needs only
# the fixed base's identification, so one interpreter makes it all, each product with its own
# log; `snakemake table2` still runs no flexible-base trial.


if "fixed" in SWEEPS and fixed_base_products():

    rule fixed_base:
        input:
            tables=ident_tables("fixed"),
            paper=PAPER_FILE,
        output:
            **fixed_base_outputs(),
        params:
            code=[CODE_FIT, CODE_TABLES, figure_code("fig6"), figure_code("fig7")],
            products=fixed_base_products(),
            gains=fit_classes(),
            options=config["fit"],
            seed=config["campaign_seed"],
        # scheduling: the fits lead to the planner's maps, the longest job after them (common.smk: PRIORITY)
        priority: PRIORITY["fixed_base"]
        log:
            **fixed_base_logs(),
        benchmark:
            bench_file("fixed_base")
        resources:
            runtime=15,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/fixed_base.py"
