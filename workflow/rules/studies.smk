# Studies (campaign.studies): experiments on the simulated rig whose results the user guide
# and the report show. They do not depend on a campaign's trials, so their files go to
# <results_root>/studies/<study>/ (…/quick/ with studies_quick: true), whatever the campaign.
# `snakemake study_<name>` runs one, `snakemake studies` all; a campaign's `all` target and
# report include those its configuration lists under `studies:` (common.smk: study_targets).
# The rendered table and figure the report shows are report() outputs of the rules below.


rule space_structure_study:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("space_structure"),
    params:
        code=code_digest("studies/space_structure.py", "model/robot/*/*"),
        study="space_structure",
        quick=STUDIES_QUICK,
        options={},
    log:
        log_file("space_structure_study", root=study_dir("space_structure")),
    resources:
        runtime=15,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule flexible_validation_study:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("flexible_validation"),
    params:
        code=code_digest("studies/flexible_validation.py", "model/robot/*/*"),
        study="flexible_validation",
        quick=STUDIES_QUICK,
        options={},
    log:
        log_file("flexible_validation_study", root=study_dir("flexible_validation")),
    resources:
        runtime=15,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule plan_rig_check_study:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("plan_rig_check"),
    params:
        code=code_digest("studies/plan_rig_check.py", "model/robot/*/*"),
        study="plan_rig_check",
        quick=STUDIES_QUICK,
        options={},
    log:
        log_file("plan_rig_check_study", root=study_dir("plan_rig_check")),
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule plan_nonlinear_twin_study:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("plan_nonlinear_twin"),
    params:
        code=code_digest("studies/plan_nonlinear_twin.py", "model/robot/*/*"),
        study="plan_nonlinear_twin",
        quick=STUDIES_QUICK,
        options={},
    log:
        log_file("plan_nonlinear_twin_study", root=study_dir("plan_nonlinear_twin")),
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule identification_accuracy_study:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("identification_accuracy"),
    params:
        code=code_digest("studies/identification_accuracy.py", "model/robot/*/*"),
        study="identification_accuracy",
        quick=STUDIES_QUICK,
        options={},
    log:
        log_file("identification_accuracy_study", root=study_dir("identification_accuracy")),
    resources:
        runtime=15,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/study.py"


rule emulation_error_study:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("emulation_error"),
    params:
        code=code_digest("studies/emulation_error.py", "model/robot/*/*"),
        study="emulation_error",
        quick=STUDIES_QUICK,
        options={},
    log:
        log_file("emulation_error_study", root=study_dir("emulation_error")),
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
        designed=lambda wc: designed_study_inputs(),
    output:
        study_outputs("impact_resistance"),
    params:
        code=code_digest("studies/impact_resistance.py", "model/robot/*/*"),
        study="impact_resistance",
        quick=STUDIES_QUICK,
        options={"designed": DESIGNED_RESULTS},
    log:
        log_file("impact_resistance_study", root=study_dir("impact_resistance")),
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
        data=f"{study_dir('space_structure')}/table4_structures.csv",
        paper=PAPER_FILE,
    output:
        csv=study_report_files("table4_structures")[0],
        md=study_report_files("table4_structures")[1],
        html=report(study_report_files("table4_structures")[2],
                    caption="../report/table4_structures.rst", category="Flexible base", subcategory="Tables",
                    labels={"table": "Table 4, both structures"}),
    params:
        code=CODE_TABLES,
    log:
        log_file("table4_structures", root=study_dir("space_structure")),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/table4_structures.py"


rule eq8_validity_figure:
    input:
        data=f"{study_dir('space_structure')}/eq8_validity.csv",
    output:
        png=report(study_report_files("eq8_validity")[0], caption="../report/eq8_validity.rst",
                   category="Flexible base", subcategory="Figures", labels={"figure": "eq 8 validity", "format": "PNG"}),
        pdf=report(study_report_files("eq8_validity")[1], caption="../report/eq8_validity.rst",
                   category="Flexible base", subcategory="Figures",
                   labels={"figure": "eq 8 validity", "format": "vector PDF"}),
    params:
        code=figure_code("validity"),
    log:
        log_file("eq8_validity", root=study_dir("space_structure")),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/eq8_validity.py"


rule plan_rig_check_table:
    input:
        data=f"{study_dir('plan_rig_check')}/plan_rig_check.csv",
    output:
        csv=study_report_files("plan_rig_check")[0],
        md=study_report_files("plan_rig_check")[1],
        html=report(study_report_files("plan_rig_check")[2], caption="../report/plan_rig_check.rst",
                    category="Impact planner", subcategory="Rig check",
                    labels={"table": "The planner checked on the rig"}),
    params:
        code=CODE_TABLES,
    log:
        log_file("plan_rig_check", root=study_dir("plan_rig_check")),
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
        model=str(Path(PAPER_FILE).parent / "response_model.json"),
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        study_outputs("response_model"),
    params:
        code=code_digest("studies/response_model.py", "model/robot/*/*"),
        study="response_model",
        quick=STUDIES_QUICK,
        options=lambda wc, input: {"model": input.model},
    log:
        log_file("response_model_study", root=study_dir("response_model")),
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
for _name in STUDY_NAMES:

    rule:
        name:
            f"study_{_name}"
        input:
            study_files(_name),


rule studies:
    input:
        [f for name in STUDY_NAMES for f in study_files(name)],
