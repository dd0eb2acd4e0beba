# Tables 2-4 (campaign.report.tables), each CSV (full precision), Markdown and HTML (shown in the report), the
# paper's values beside ours. Each table needs only its own inputs: Table 2 the fixed-base
# identification, Table 3 the lambda fits, Table 4 the fits and the flexible-base
# identification (so `snakemake table2` runs no flexible-base trial).


rule table2_effective_mass:
    input:
        tables=lambda wc: ident_tables("fixed"),
        paper=PAPER_FILE,
    output:
        csv=f"{RESULTS}/tables/table2.csv",
        md=f"{RESULTS}/tables/table2.md",
        html=report(f"{RESULTS}/tables/table2.html", caption="../report/table2.rst", category="Fixed base",
                    subcategory="Tables", labels={"table": "Table 2"}),
    params:
        code=CODE_TABLES,
    log:
        log_file("table2"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/table.py"


rule table3_virtual_rotor_inertia:
    input:
        unpack(lambda wc: fit_jsons()),
        paper=PAPER_FILE,
    output:
        csv=f"{RESULTS}/tables/table3.csv",
        md=f"{RESULTS}/tables/table3.md",
        html=report(f"{RESULTS}/tables/table3.html", caption="../report/table3.rst", category="Virtual rotor inertia (lambda)",
                    subcategory="Tables", labels={"table": "Table 3"}),
    params:
        code=CODE_TABLES,
        classes=lambda wc: list(fit_jsons()),
    log:
        log_file("table3"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/table.py"


rule table4_flexible_effective_mass:
    input:
        unpack(lambda wc: fit_jsons()),
        tables=lambda wc: ident_tables("flexible"),
        paper=PAPER_FILE,
    output:
        csv=f"{RESULTS}/tables/table4.csv",
        md=f"{RESULTS}/tables/table4.md",
        html=report(f"{RESULTS}/tables/table4.html", caption="../report/table4.rst", category="Flexible base",
                    subcategory="Tables", labels={"table": "Table 4"}),
    params:
        code=CODE_TABLES,
        classes=lambda wc: list(fit_jsons()),
        structure=FLEX_STRUCTURE,
    log:
        log_file("table4"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/table.py"


# Table 4 and Figure 9 under both named structures: the campaign simulates the one its config
# names, so both come from the benchmark's committed data (benchmarks/space_structure.py)
rule table4_structures_table:
    input:
        data=STRUCTURES_CSV,
        paper=PAPER_FILE,
    output:
        csv=f"{RESULTS}/tables/table4_structures.csv",
        md=f"{RESULTS}/tables/table4_structures.md",
        html=report(f"{RESULTS}/tables/table4_structures.html", caption="../report/table4_structures.rst",
                    category="Flexible base", subcategory="Tables",
                    labels={"table": "Table 4, both structures"}),
    params:
        code=CODE_TABLES,
    log:
        log_file("table4_structures"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/table4_structures.py"


# the impact planner checked on the rig: the candidates' simulations run in the benchmark
# (every branch x gain x direction at two contact points), so the report renders its CSV
rule plan_rig_check_table:
    input:
        data=RIG_CHECK_CSV,
    output:
        csv=f"{RESULTS}/tables/plan_rig_check.csv",
        md=f"{RESULTS}/tables/plan_rig_check.md",
        html=report(f"{RESULTS}/tables/plan_rig_check.html", caption="../report/plan_rig_check.rst",
                    category="Impact planner", subcategory="Rig check",
                    labels={"table": "The planner checked on the rig"}),
    params:
        code=CODE_TABLES,
    log:
        log_file("plan_rig_check"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/plan_rig_check.py"
