# Named targets. `snakemake` makes everything the configuration can make (rule all, in the
# root Snakefile); `snakemake <product>` (fig4 ... fig9, plan_maps, table2 ... table4, and the
# studies' table4_structures, eq8_validity, plan_rig_check when the configuration lists their
# study under `studies:`) makes the product with the jobs it needs (table2 alone runs no
# flexible-base trial; fig5 runs the one simulation job holding its trial); `trials` and
# `identification` stop after those stages; `archive` makes the finalized archive (and the
# identification CSV when identification_csv is set). `study_<name>` and `studies`: studies.smk.


rule trials:
    input:
        PLAN.all_job_manifests(),


if PLAN.simulate:

    rule archive:
        input:
            PLAN.archive_files()["manifest"],
            [config["identification_csv"]] if config.get("identification_csv") else [],


rule identification:
    input:
        PLAN.all_ident_tables(),


rule fig4:
    input:
        lambda wc: PLAN.requires("fig4"),


rule fig5:
    input:
        lambda wc: PLAN.requires("fig5"),


rule fig6:
    input:
        lambda wc: PLAN.requires("fig6"),


rule fig7:
    input:
        lambda wc: PLAN.requires("fig7"),


rule fig8:
    input:
        lambda wc: PLAN.requires("fig8"),


rule fig9:
    input:
        lambda wc: PLAN.requires("fig9"),


rule plan_maps:
    input:
        lambda wc: PLAN.requires("plan_maps"),


rule table2:
    input:
        lambda wc: PLAN.requires("table2"),


rule table3:
    input:
        lambda wc: PLAN.requires("table3"),


rule table4:
    input:
        lambda wc: PLAN.requires("table4"),


rule eq8_validity:
    input:
        lambda wc: PLAN.requires("eq8_validity"),


rule table4_structures:
    input:
        lambda wc: PLAN.requires("table4_structures"),


rule plan_rig_check:
    input:
        lambda wc: PLAN.requires("plan_rig_check"),
