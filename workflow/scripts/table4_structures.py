"""Snakemake script of rule table4_structures_table: Table 4 and Figure 9 under both named
structures (campaign.report.tables.structures_table) from the study's CSV."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="table4_structures", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.pipeline import make_table
    make_table("table4_structures", snakemake.output.csv, snakemake.output.md,  # noqa: F821
                      source=snakemake.input.data, out_html=snakemake.output.html, timer=timer)  # noqa: F821
