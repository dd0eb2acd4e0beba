# The archive folder: once every simulation job is done, index.csv, README.md and
# MANIFEST.sha256 (campaign.archive.finalize_campaign). Finalize opens no trial: it reads the
# job manifests, hashes each file once (the manifest needs the hash) and refuses, naming it, a
# file changed since its job wrote it, a trial no job wrote, a file outside the archive layout
# and two trials of the same cell or content; `campaign archive verify` checks every file from
# scratch. When the campaign reuses an archive, that archive is verified instead (manifest,
# schema, content digests, filing).

if PLAN.simulate:

    rule finalize_archive:
        input:
            PLAN.all_job_manifests(),
        output:
            **PLAN.archive_files(),
        params:
            archive=lambda wc: PLAN.archive,
        priority: PRIORITY["finalize_archive"]
        log:
            PLAN.log_file("finalize_archive"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/finalize_archive.py"

    # the campaign's identification as one CSV, every trial in path order: where the
    # configuration key identification_csv says (then part of `all`; config/tests/reference.yaml:
    # archive/reference.identification.csv), else results/<campaign>/identification.csv on demand.
    # update(): Snakemake leaves the existing file in place for the job, which keeps each row
    # the tolerance policy calls the same identification (campaign.pipeline.stages.export_identification)
    rule identification_csv:
        input:
            PLAN.all_ident_tables(),
        output:
            update(PLAN.identification_csv),
        priority: PRIORITY["identification_csv"]
        log:
            PLAN.log_file("identification_csv"),
        resources:
            runtime=5,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/identification_csv.py"

else:

    rule verify_archive:
        input:
            [t for ts in PLAN.reused.values() for t in ts],
        output:
            PLAN.verify_file,
        params:
            archive=lambda wc: PLAN.trial_root,
        priority: PRIORITY["verify_archive"]
        log:
            PLAN.log_file("verify_archive"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/verify_archive.py"
