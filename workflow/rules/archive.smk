# The archive folder: once every trial is written, index.csv, README.md and MANIFEST.sha256
# (campaign.archive.finalize_campaign, which checks every trial first). When the campaign
# reuses an archive, that archive is verified instead (manifest, schema, content digests).

if SIMULATE:

    rule finalize_archive:
        input:
            all_trials(),
        output:
            index=f"{ARCHIVE}/index.csv",
            readme=f"{ARCHIVE}/README.md",
            manifest=f"{ARCHIVE}/MANIFEST.sha256",
        params:
            archive=lambda wc: ARCHIVE,
        # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
        priority: 1
        log:
            log_file("finalize_archive"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/finalize_archive.py"

else:

    rule verify_archive:
        input:
            all_trials(),
        output:
            f"{RESULTS}/archive_verify.txt",
        params:
            archive=lambda wc: TRIAL_ROOT,
        log:
            log_file("verify_archive"),
        resources:
            runtime=10,
            mem_mb=1000,
        conda:
            "../envs/campaign.yaml"
        script:
            "../scripts/verify_archive.py"
