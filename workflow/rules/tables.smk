# Tables 2-4 (campaign.report.tables), each CSV (full precision), Markdown and HTML (shown in the report), the
# paper's values beside ours. Each table needs only its own inputs: Table 2 the fixed-base
# identification, Table 3 the lambda fits, Table 4 the fits and the flexible-base
# identification (so `snakemake table2` runs no flexible-base trial). The studies' tables
# (Table 4 under both structures, the planner's rig check) are in studies.smk.


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
        # the shipped response model (fitted by the designed campaign) fills the model column
        model=str(Path(PAPER_FILE).parent / "response_model.json"),
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
