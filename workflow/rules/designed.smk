# The designed campaign (config/designed.yaml): the paper's three configurations, poses and
# impact directions chosen by `campaign design`, and held-out poses, on the fixed base for
# every gain set; lambda fitted on each design and checked on the held-out poses
# (campaign.design.designed_campaign). `snakemake designed` makes its report. The rules exist when the
# settings file does (the plan's designed part: campaign.pipeline.plan_parts.DesignedPlan).


if PLAN.designed.settings:

    rule designed_plan:
        input:
            settings=PLAN.designed.file,
            rig=PLAN.rig_file,
            paper=PLAN.paper_file,
        output:
            plan=PLAN.designed.path("plan"),
            md=PLAN.designed.path("design"),
        params:
            code=PLAN.stage_code("designed"),
            settings=PLAN.designed.settings,
        log:
            PLAN.designed.log("designed_plan"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_plan.py"


    rule designed_trials:
        input:
            plan=PLAN.designed.path("plan"),
        output:
            csv=PLAN.designed.table_pattern(),
        params:
            code=PLAN.stage_code("designed"),
            archive=PLAN.designed.archive,
        wildcard_constraints:
            role="|".join(PLAN.designed.roles),
        # the designed trials are the most: start them first
        priority: lambda wc: 1 if wc.role == "designed" else 0
        log:
            PLAN.designed.log("designed_trials", "{role}_{gain}"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_trials.py"


    rule designed_report:
        input:
            plan=PLAN.designed.path("plan"),
            paper=PLAN.designed.tables("paper"),
            designed=PLAN.designed.tables("designed"),
            heldout=PLAN.designed.tables("heldout"),
            model=PLAN.designed.path("model"),
        output:
            json=PLAN.designed.path("report_json"),
            md=report(PLAN.designed.path("report"), caption="../report/designed.rst", category="Designed campaign",
                      labels={"report": "Lambda from the designed poses, checked on held-out poses"}),
        params:
            code=PLAN.stage_code("designed"),
        log:
            PLAN.designed.log("designed_report"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_report.py"


    rule designed:
        input:
            PLAN.designed.path("report"),
            PLAN.designed.path("design"),
            PLAN.designed.path("model_md"),
            PLAN.designed.path("shipped"),


    # ------------------------------------------------------------------------------------
    # the response model (campaign.design.designed_model): fitted on the designed trials, its
    # scatter on the flexible base measured on the plan's held-out (random) poses struck there
    # under each named structure, saved, and compared with the one the repository ships
    # (config/response_model.json)
    # ------------------------------------------------------------------------------------
    rule designed_flexible_trials:
        input:
            plan=PLAN.designed.path("plan"),
        output:
            csv=PLAN.designed.flexible_pattern(),
        params:
            code=PLAN.stage_code("designed"),
            archive=lambda wc: PLAN.designed.structure_archive(wc.structure),
        wildcard_constraints:
            structure="|".join(PLAN.designed.structures),
        log:
            PLAN.designed.log("designed_flexible_trials", "{structure}_{gain}"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_flexible_trials.py"


    rule designed_model:
        input:
            plan=PLAN.designed.path("plan"),
            fixed=PLAN.designed.tables("designed"),
            checks=PLAN.designed.tables("paper") + PLAN.designed.tables("heldout"),
            flexible=PLAN.designed.flexible_tables(),
            rig=PLAN.rig_file,
            paper=PLAN.paper_file,
        output:
            json=PLAN.designed.path("model"),
            md=report(PLAN.designed.path("model_md"), caption="../report/designed.rst",
                      category="Designed campaign"),
        params:
            code=PLAN.stage_code("designed_model"),
            archive=PLAN.designed.archive,
            structures=PLAN.designed.structures,
        log:
            PLAN.designed.log("designed_model"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_model.py"


    rule designed_model_shipped:
        input:
            fitted=PLAN.designed.path("model"),
            shipped=PLAN.response_model,
        output:
            PLAN.designed.path("shipped"),
        log:
            PLAN.designed.log("designed_model_shipped"),
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_model_shipped.py"
