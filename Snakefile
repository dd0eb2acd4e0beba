# The campaign: Yoshida, Mavroidis & Dubowsky's impact experiments re-done on a simulated
# VES-II. Configuration: config/config.yaml (full) or --configfile config/tests/ci.yaml (reduced),
# checked against workflow/schemas/config.schema.yaml. Stage flow:
#
#   simulate -> identify -> fit -> tables, figures -> report
#
# in one job per simulation unit, then one job per base and stage family: identify_<base>
# (every trial of the base), fixed_base (the lambda fits, Tables 2-3, Figures 6-7),
# flexible_base (Table 4, the calibration report), model_figures (Figures 4, 8), the single-
# trial Figures 5 and 9, the planner's maps, and the archive's finalisation;
# beside them, the studies (workflow/rules/studies.smk: not per campaign; the report shows
# those the configuration lists under `studies:`).
#
# This file only includes the rules (wiring: workflow/rules/common.smk; the campaign's plan:
# campaign.pipeline.campaign_plan) and names the
# default target: Snakemake takes the default target from the root Snakefile only (a rule
# in an included file, even with `default_target: True`, cannot be it).

include: "workflow/rules/common.smk"
include: "workflow/rules/targets.smk"
include: "workflow/rules/sweep.smk"
include: "workflow/rules/identify.smk"
include: "workflow/rules/fixed_base.smk"
include: "workflow/rules/flexible_base.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/archive.smk"
include: "workflow/rules/calibration.smk"
include: "workflow/rules/designed.smk"
include: "workflow/rules/studies.smk"


rule all:
    input:
        all_targets(),
    default_target: True
