"""Snakemake script of rule fig8_flexible_setup: Figure 8 from the rig parameters and the robot model."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job="fig8", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.report.figures import fig8
    with timer("figure"):
        print(fig8.make(snakemake.output.png, snakemake.output.pdf, rig=snakemake.params.rig,  # noqa: F821
                        params=snakemake.params.rig_params))  # noqa: F821
