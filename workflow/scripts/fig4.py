"""Snakemake script of rule fig4_arm_configurations: Figure 4 from the robot model."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job="fig4", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.report.figures import fig4
    with timer("figure"):
        print(fig4.make(snakemake.output.png, snakemake.output.pdf))  # noqa: F821
