# Figures of the paper that need no identification, and the impact planner's maps
# (campaign.report.figures: one module per figure), PNG for the report and PDF beside it:
# Figures 4 and 8 from the robot model and the rig (one job, model_figures, each with its own
# log), Figure 5 from one fixed-base trial and Figure 9 from four flexible-base trials (each
# waits only for the simulation job holding its trials), the planner's maps from the lambda
# fits. Figures 6-7 are made by the fixed_base job (fixed_base.smk); eq 8's validity map,
# drawn from a study's data, is in studies.smk. Each figure is one row of the report with a
# format toggle, which opens the first of its two values in sort order: "PNG" before
# "vector PDF" (a PDF shows as a blank pane in Chromium's report frame).


rule model_figures:
    input:
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        **outputs(PLAN.figure_outputs("fig4", "Fixed base")),
        **outputs(PLAN.figure_outputs("fig8", "Flexible base")),
    params:
        code=[PLAN.figure_code("fig4"), PLAN.figure_code("fig8")],
        rig=config["rig"],
        rig_params=PLAN.sweep_params(PLAN.flexible_base),
    priority: PRIORITY["model_figures"]
    log:
        fig4=PLAN.log_file("fig4"),
        fig8=PLAN.log_file("fig8"),
        job=PLAN.log_file("model_figures"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/model_figures.py"


rule fig5_joint3_motion:
    input:
        trial=lambda wc: PLAN.figure_inputs("fig5")[0],
        paper=PLAN.paper_file,
    output:
        **outputs(PLAN.figure_outputs("fig5", "Fixed base")),
    params:
        code=PLAN.figure_code("fig5"),
        trial=lambda wc: [*PLAN.figure_trials("fig5").values()][0],
        pick=lambda wc: dict(zip(("speed", "repeat"), PLAN.figure_pick("fig5"))),
    priority: PRIORITY["fig5_joint3_motion"]
    log:
        PLAN.log_file("fig5"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig5.py"


rule fig9_base_motion:
    input:
        trials=lambda wc: PLAN.figure_inputs("fig9"),
        paper=PLAN.paper_file,
    output:
        **outputs(PLAN.figure_outputs("fig9", "Flexible base")),
    params:
        code=PLAN.figure_code("fig9"),
        trials=lambda wc: PLAN.figure_trials("fig9"),
        pick=lambda wc: dict(zip(("speed", "repeat"), PLAN.figure_pick("fig9"))),
    priority: PRIORITY["fig9_base_motion"]
    log:
        PLAN.log_file("fig9"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig9.py"


rule planner_maps:
    input:
        unpack(lambda wc: PLAN.fit_jsons()),
        rig=PLAN.rig_file,
        paper=PLAN.paper_file,
    output:
        **outputs(PLAN.planner_map_outputs()),
    params:
        code=PLAN.figure_code("plan_maps"),
        fits=lambda wc: list(PLAN.fit_jsons().values()),
        rig=config["rig"],
        resolution=config.get("plan_maps", {}).get("resolution", 0.05),
        config_=config.get("plan_maps", {}).get("config", 1),
    # scheduling: the longest job after the simulations starts as soon as the fits exist (plan_parts.PRIORITY)
    priority: PRIORITY["planner_maps"]
    log:
        PLAN.log_file("plan_maps"),
    resources:
        runtime=10,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/plan_maps.py"
