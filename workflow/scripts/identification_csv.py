"""Snakemake script of rule identification_csv: the campaign's identification tables joined into one CSV."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="identification_csv", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.pipeline import export_identification
    with timer("table"):
        print(f"wrote {export_identification(list(snakemake.input), snakemake.output[0])}")  # noqa: F821
