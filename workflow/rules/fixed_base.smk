# The fixed base after identification, one job (rule fixed_base): the Virtual Rotor Inertia
# lambda (eq 11, 15) per gain class of the paper (zero_low, high) from the fixed-base trials of
# every configuration, with bootstrap intervals and the identifiability findings
# (campaign.joints.lambda_fit.LambdaFit); Table 2 (effective masses) and Table 3 (lambda), each
# CSV (full precision), Markdown and HTML (shown in the report), the paper's values beside
# ours; Figures 6 and 7 (effective mass, restitution), PNG and PDF. Everything here needs only
# the fixed base's identification, so one interpreter makes it all, each product with its own
# log; `snakemake table2` still runs no flexible-base trial.


if PLAN.fixed_base_products():

    rule fixed_base:
        input:
            tables=PLAN.ident_tables(PLAN.fixed_base),
            paper=PLAN.paper_file,
        output:
            **outputs(PLAN.fixed_base_outputs()),
        params:
            code=[PLAN.stage_code("fit"), PLAN.stage_code("tables"), PLAN.figure_code("fig6"),
                  PLAN.figure_code("fig7")],
            products=PLAN.fixed_base_products(),
            gains=PLAN.fit_classes(),
            options=config["fit"],
            seed=config["campaign_seed"],
        # scheduling: the fits lead to the planner's maps, the longest job after them (plan_parts.PRIORITY)
        priority: PRIORITY["fixed_base"]
        log:
            **PLAN.fixed_base_logs(),
        benchmark:
            PLAN.bench_file("fixed_base")
        resources:
            runtime=15,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/fixed_base.py"
