"""Snakemake script of rule eq8_validity_figure: the validity map of eq 8 from the study's CSV."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="eq8_validity", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.report.figures import validity
    with timer("figure"):
        print(validity.make(snakemake.input.data, snakemake.output.png, snakemake.output.pdf))  # noqa: F821
