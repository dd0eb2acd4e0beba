"""Snakemake script of rule plan_rig_check_table: the impact planner checked on the rig
(campaign.tables.rig_check_table) from the benchmark's CSV."""

from campaign import runner

with runner.job_log(snakemake.log[0], job="plan_rig_check", exit_process=True) as timer:  # noqa: F821
    runner.make_table("plan_rig_check", snakemake.output.csv, snakemake.output.md,  # noqa: F821
                      source=snakemake.input.data, out_html=snakemake.output.html, timer=timer)  # noqa: F821
