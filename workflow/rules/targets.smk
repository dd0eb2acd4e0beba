# Named targets. `snakemake` makes everything the configuration can make (rule all, in the
# root Snakefile); `snakemake <product>` (fig4 ... fig9, plan_maps, table2 ... table4, and the
# studies' table4_structures, eq8_validity, plan_rig_check when the configuration lists their
# study under `studies:`) makes the product with the jobs it needs (table2 alone runs no
# flexible-base trial; fig5 runs the one simulation job holding its trial); `trials` and
# `identification` stop after those stages; `archive` makes the finalized archive (and the
# identification CSV when identification_csv is set). `study_<name>` and `studies`: studies.smk.


rule trials:
    input:
        all_job_manifests(),


if SIMULATE:

    rule archive:
        input:
            f"{ARCHIVE}/MANIFEST.sha256",
            [config["identification_csv"]] if config.get("identification_csv") else [],


rule identification:
    input:
        [t for base in SWEEPS for t in ident_tables(base)],


rule fig4:
    input:
        lambda wc: requires("fig4"),


rule fig5:
    input:
        lambda wc: requires("fig5"),


rule fig6:
    input:
        lambda wc: requires("fig6"),


rule fig7:
    input:
        lambda wc: requires("fig7"),


rule fig8:
    input:
        lambda wc: requires("fig8"),


rule fig9:
    input:
        lambda wc: requires("fig9"),


rule plan_maps:
    input:
        lambda wc: requires("plan_maps"),


rule table2:
    input:
        lambda wc: requires("table2"),


rule table3:
    input:
        lambda wc: requires("table3"),


rule table4:
    input:
        lambda wc: requires("table4"),


rule eq8_validity:
    input:
        lambda wc: requires("eq8_validity"),


rule table4_structures:
    input:
        lambda wc: requires("table4_structures"),


rule plan_rig_check:
    input:
        lambda wc: requires("plan_rig_check"),
