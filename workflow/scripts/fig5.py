"""Snakemake script of rule fig5_joint3_motion: Figure 5 from one fixed-base trial."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="fig5", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.model import load_paper
        from campaign.report.figures import fig5
    with timer("figure"):
        out = snakemake.output  # noqa: F821
        print(fig5.make(snakemake.params.trial, out.fig5_png, out.fig5_pdf, paper=load_paper()))  # noqa: F821
