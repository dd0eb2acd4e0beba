# Studies (campaign.studies): experiments on the simulated rig whose results the user guide
# and the report show. They do not depend on a campaign's trials, so their files go to
# <results_root>/studies/<study>/ (…/quick/ with studies_quick: true), whatever the campaign.
# `snakemake study_<name>` runs one, `snakemake studies` all; a campaign's `all` target and
# report include those its configuration lists under `studies:` (campaign.pipeline.plan_parts.StudiesPlan).
# The rendered table and figure the report shows are report() outputs of the rules below.


rule space_structure_study:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("space_structure"),
    params:
        code=PLAN.study_code("space_structure"),
        study="space_structure",
        quick=PLAN.studies.quick,
        options={},
    log:
        PLAN.studies.log("space_structure", "space_structure_study"),
    resources:
        runtime=15,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule flexible_validation_study:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("flexible_validation"),
    params:
        code=PLAN.study_code("flexible_validation"),
        study="flexible_validation",
        quick=PLAN.studies.quick,
        options={},
    log:
        PLAN.studies.log("flexible_validation", "flexible_validation_study"),
    resources:
        runtime=15,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule plan_rig_check_study:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("plan_rig_check"),
    params:
        code=PLAN.study_code("plan_rig_check"),
        study="plan_rig_check",
        quick=PLAN.studies.quick,
        options={},
    log:
        PLAN.studies.log("plan_rig_check", "plan_rig_check_study"),
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule plan_nonlinear_twin_study:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("plan_nonlinear_twin"),
    params:
        code=PLAN.study_code("plan_nonlinear_twin"),
        study="plan_nonlinear_twin",
        quick=PLAN.studies.quick,
        options={},
    log:
        PLAN.studies.log("plan_nonlinear_twin", "plan_nonlinear_twin_study"),
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule identification_accuracy_study:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("identification_accuracy"),
    params:
        code=PLAN.study_code("identification_accuracy"),
        study="identification_accuracy",
        quick=PLAN.studies.quick,
        options={},
    log:
        PLAN.studies.log("identification_accuracy", "identification_accuracy_study"),
    resources:
        runtime=15,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule emulation_error_study:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("emulation_error"),
    params:
        code=PLAN.study_code("emulation_error"),
        study="emulation_error",
        quick=PLAN.studies.quick,
        options={},
    log:
        PLAN.studies.log("emulation_error", "emulation_error_study"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


# on the designed campaign's trials: its identification tables (and the trial files they name)
rule impact_resistance_study:
    input:
        designed=lambda wc: PLAN.designed.study_inputs(),
    output:
        PLAN.studies.outputs("impact_resistance"),
    params:
        code=PLAN.study_code("impact_resistance"),
        study="impact_resistance",
        quick=PLAN.studies.quick,
        options={"designed": PLAN.designed.results if PLAN.designed.settings else None},
    log:
        PLAN.studies.log("impact_resistance", "impact_resistance_study"),
    resources:
        runtime=10,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


# ----------------------------------------------------------------------------------------
# what the report shows of the studies: rendered from their CSVs
# ----------------------------------------------------------------------------------------
rule table4_structures_table:
    input:
        data=PLAN.studies.output("space_structure", "table4_structures.csv"),
        paper=PLAN.paper_file,
    output:
        **outputs(PLAN.studies.report_outputs("table4_structures", caption="table4_structures",
                                              category="Flexible base", subcategory="Tables",
                                              labels={"table": "Table 4, both structures"})),
    params:
        code=PLAN.stage_code("tables"),
    log:
        PLAN.studies.log("space_structure", "table4_structures"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/table4_structures.py"


rule eq8_validity_figure:
    input:
        data=PLAN.studies.output("space_structure", "eq8_validity.csv"),
    output:
        **outputs(PLAN.studies.report_outputs("eq8_validity", caption="eq8_validity", category="Flexible base",
                                              subcategory="Figures", labels={"figure": "eq 8 validity"})),
    params:
        code=PLAN.figure_code("validity"),
    log:
        PLAN.studies.log("space_structure", "eq8_validity"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/eq8_validity.py"


rule plan_rig_check_table:
    input:
        data=PLAN.studies.output("plan_rig_check", "plan_rig_check.csv"),
    output:
        **outputs(PLAN.studies.report_outputs("plan_rig_check", caption="plan_rig_check", category="Impact planner",
                                              subcategory="Rig check",
                                              labels={"table": "The planner checked on the rig"})),
    params:
        code=PLAN.stage_code("tables"),
    log:
        PLAN.studies.log("plan_rig_check", "plan_rig_check"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/plan_rig_check.py"


# the shipped response model on held-out poses drawn with the study's own seeds
rule response_model_study:
    input:
        model=PLAN.response_model,
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        PLAN.studies.outputs("response_model"),
    params:
        code=PLAN.study_code("response_model"),
        study="response_model",
        quick=PLAN.studies.quick,
        options=lambda wc, input: {"model": input.model},
    log:
        PLAN.studies.log("response_model", "response_model_study"),
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


# ----------------------------------------------------------------------------------------
# named targets
# ----------------------------------------------------------------------------------------
# `snakemake study_<name>`: one study's files (with what the report shows of it)
for _name in PLAN.studies.names:

    rule:
        name:
            f"study_{_name}"
        input:
            PLAN.studies.files(_name),


rule studies:
    input:
        PLAN.studies.all_files(),
