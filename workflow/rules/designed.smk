# The designed campaign (config/designed.yaml): the paper's three configurations, poses and
# impact directions chosen by `campaign design`, and held-out poses, on the fixed base for
# every gain set; lambda fitted on each design and checked on the held-out poses
# (campaign.design.designed_campaign). `snakemake designed` makes its report. The rules exist when the
# settings file does (common.smk: DESIGNED).


if DESIGNED:

    rule designed_plan:
        input:
            settings=DESIGNED_FILE,
            rig=RIG_FILE,
            paper=PAPER_FILE,
        output:
            plan=f"{DESIGNED_RESULTS}/plan.json",
            md=f"{DESIGNED_RESULTS}/design.md",
        params:
            code=CODE_DESIGNED,
            settings=DESIGNED,
        log:
            designed_log("designed_plan"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_plan.py"


    rule designed_trials:
        input:
            plan=f"{DESIGNED_RESULTS}/plan.json",
        output:
            csv=f"{DESIGNED_RESULTS}/identification/{{role}}_{{gain}}.csv",
        params:
            code=CODE_DESIGNED,
            archive=DESIGNED_ARCHIVE,
        wildcard_constraints:
            role="|".join(DESIGNED_ROLES),
        # the designed trials are the most: start them first
        priority: lambda wc: 1 if wc.role == "designed" else 0
        log:
            designed_log("designed_trials", "{role}_{gain}"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_trials.py"


    rule designed_report:
        input:
            plan=f"{DESIGNED_RESULTS}/plan.json",
            paper=designed_tables("paper"),
            designed=designed_tables("designed"),
            heldout=designed_tables("heldout"),
            model=f"{DESIGNED_RESULTS}/model/response_model.json",
        output:
            json=f"{DESIGNED_RESULTS}/report.json",
            md=report(f"{DESIGNED_RESULTS}/report.md", caption="../report/designed.rst", category="Designed campaign",
                      labels={"report": "Lambda from the designed poses, checked on held-out poses"}),
        params:
            code=CODE_DESIGNED,
        log:
            designed_log("designed_report"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_report.py"


    rule designed:
        input:
            f"{DESIGNED_RESULTS}/report.md",
            f"{DESIGNED_RESULTS}/design.md",
            f"{DESIGNED_RESULTS}/model/response_model.md",
            f"{DESIGNED_RESULTS}/model/shipped.txt",


    # ------------------------------------------------------------------------------------
    # the response model (campaign.design.designed_model): fitted on the designed trials, its
    # scatter on the flexible base measured on the plan's held-out (random) poses struck there
    # under each named structure, saved, and compared with the one the repository ships
    # (config/response_model.json)
    # ------------------------------------------------------------------------------------
    rule designed_flexible_trials:
        input:
            plan=f"{DESIGNED_RESULTS}/plan.json",
        output:
            csv=f"{DESIGNED_RESULTS}/identification/flexible/{{structure}}_{{gain}}.csv",
        params:
            code=CODE_DESIGNED,
            archive=lambda wc: f"{DESIGNED_ARCHIVE}/structures/{wc.structure}",
        wildcard_constraints:
            structure="|".join(DESIGNED_STRUCTURES),
        log:
            designed_log("designed_flexible_trials", "{structure}_{gain}"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_flexible_trials.py"


    rule designed_model:
        input:
            plan=f"{DESIGNED_RESULTS}/plan.json",
            fixed=designed_tables("designed"),
            flexible=designed_flexible_tables(),
            rig=RIG_FILE,
            paper=PAPER_FILE,
        output:
            json=f"{DESIGNED_RESULTS}/model/response_model.json",
            md=report(f"{DESIGNED_RESULTS}/model/response_model.md", caption="../report/designed.rst",
                      category="Designed campaign"),
        params:
            code=CODE_DESIGNED_MODEL,
            archive=DESIGNED_ARCHIVE,
            structures=DESIGNED_STRUCTURES,
        log:
            designed_log("designed_model"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_model.py"


    rule designed_model_shipped:
        input:
            fitted=f"{DESIGNED_RESULTS}/model/response_model.json",
            shipped=str(Path(PAPER_FILE).parent / "response_model.json"),
        output:
            f"{DESIGNED_RESULTS}/model/shipped.txt",
        log:
            designed_log("designed_model_shipped"),
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/designed_model_shipped.py"
