"""Snakemake script of rule plan_rig_check_table: the impact planner checked on the rig
(campaign.report.tables.rig_check_table) from the study's CSV."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="plan_rig_check", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.pipeline import make_table
    make_table("plan_rig_check", snakemake.output.csv, snakemake.output.md,  # noqa: F821
                      source=snakemake.input.data, out_html=snakemake.output.html, timer=timer)  # noqa: F821
