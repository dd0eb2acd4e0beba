# Figures 4-9 of the paper and the impact planner's maps (campaign.report.figures: one module per
# figure, one thin script each), PNG for the report and PDF beside it. eq 8's validity map,
# drawn from a study's data, is in studies.smk. Each figure is one row of the report with a
# format toggle, which opens the first of its two values in sort order: "PNG" before
# "vector PDF" (a PDF shows as a blank pane in Chromium's report frame).


rule fig4_arm_configurations:
    input:
        paper=PAPER_FILE,
    output:
        png=report(f"{RESULTS}/figures/fig4.png", caption="../report/fig4.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 4", "format": "PNG"}),
        pdf=report(f"{RESULTS}/figures/fig4.pdf", caption="../report/fig4.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 4", "format": "vector PDF"}),
    params:
        code=figure_code("fig4"),
    log:
        log_file("fig4"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig4.py"


rule fig5_joint3_motion:
    input:
        trial=lambda wc: trial_file("fixed", 1, "zero", *figure_pick("fig5"), key="figures.fig5"),
        paper=PAPER_FILE,
    output:
        png=report(f"{RESULTS}/figures/fig5.png", caption="../report/fig5.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 5", "format": "PNG"}),
        pdf=report(f"{RESULTS}/figures/fig5.pdf", caption="../report/fig5.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 5", "format": "vector PDF"}),
    params:
        code=figure_code("fig5"),
        pick=lambda wc: dict(zip(("speed", "repeat"), figure_pick("fig5"))),
    # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
    priority: 1
    log:
        log_file("fig5"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig5.py"


rule fig6_effective_mass:
    input:
        tables=lambda wc: ident_tables("fixed"),
        paper=PAPER_FILE,
    output:
        png=report(f"{RESULTS}/figures/fig6.png", caption="../report/fig6.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 6", "format": "PNG"}),
        pdf=report(f"{RESULTS}/figures/fig6.pdf", caption="../report/fig6.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 6", "format": "vector PDF"}),
    params:
        code=figure_code("fig6"),
    log:
        log_file("fig6"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig6.py"


rule fig7_restitution:
    input:
        tables=lambda wc: ident_tables("fixed"),
        paper=PAPER_FILE,
    output:
        png=report(f"{RESULTS}/figures/fig7.png", caption="../report/fig7.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 7", "format": "PNG"}),
        pdf=report(f"{RESULTS}/figures/fig7.pdf", caption="../report/fig7.rst", category="Fixed base",
                   subcategory="Figures", labels={"figure": "Figure 7", "format": "vector PDF"}),
    params:
        code=figure_code("fig7"),
    log:
        log_file("fig7"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig7.py"


rule fig8_flexible_setup:
    input:
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        png=report(f"{RESULTS}/figures/fig8.png", caption="../report/fig8.rst", category="Flexible base",
                   subcategory="Figures", labels={"figure": "Figure 8", "format": "PNG"}),
        pdf=report(f"{RESULTS}/figures/fig8.pdf", caption="../report/fig8.rst", category="Flexible base",
                   subcategory="Figures", labels={"figure": "Figure 8", "format": "vector PDF"}),
    params:
        code=figure_code("fig8"),
        rig=config["rig"],
        rig_params=sweep_params("flexible"),
    # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
    priority: 1
    log:
        log_file("fig8"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig8.py"


rule fig9_base_motion:
    input:
        unpack(lambda wc: {f"c{c}_{g}": trial_file("flexible", c, g, *figure_pick("fig9"), key="figures.fig9")
                           for c in (1, 2) for g in ("low", "high")}),
        paper=PAPER_FILE,
    output:
        png=report(f"{RESULTS}/figures/fig9.png", caption="../report/fig9.rst", category="Flexible base",
                   subcategory="Figures", labels={"figure": "Figure 9", "format": "PNG"}),
        pdf=report(f"{RESULTS}/figures/fig9.pdf", caption="../report/fig9.rst", category="Flexible base",
                   subcategory="Figures", labels={"figure": "Figure 9", "format": "vector PDF"}),
    params:
        code=figure_code("fig9"),
        pick=lambda wc: dict(zip(("speed", "repeat"), figure_pick("fig9"))),
    # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
    priority: 1
    log:
        log_file("fig9"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fig9.py"


rule planner_maps:
    input:
        unpack(lambda wc: fit_jsons()),
        rig=RIG_FILE,
        paper=PAPER_FILE,
    output:
        workspace=report(f"{RESULTS}/figures/plan_workspace.png", caption="../report/plan_workspace.rst",
                         category="Impact planner", subcategory="Maps",
                         labels={"map": "workspace", "format": "PNG"}),
        workspace_pdf=report(f"{RESULTS}/figures/plan_workspace.pdf", caption="../report/plan_workspace.rst",
                             category="Impact planner", subcategory="Maps",
                             labels={"map": "workspace", "format": "vector PDF"}),
        directions=report(f"{RESULTS}/figures/plan_directions.png", caption="../report/plan_directions.rst",
                          category="Impact planner", subcategory="Maps",
                          labels={"map": "directions", "format": "PNG"}),
        directions_pdf=report(f"{RESULTS}/figures/plan_directions.pdf", caption="../report/plan_directions.rst",
                              category="Impact planner", subcategory="Maps",
                              labels={"map": "directions", "format": "vector PDF"}),
    params:
        code=figure_code("plan_maps"),
        fits=lambda wc: list(fit_jsons().values()),
        rig=config["rig"],
        resolution=config.get("plan_maps", {}).get("resolution", 0.05),
        config_=config.get("plan_maps", {}).get("config", 1),
    log:
        log_file("plan_maps"),
    resources:
        runtime=10,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/plan_maps.py"
