"""Snakemake script of rule fig9_base_motion: Figure 9 from four flexible-base trials."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="fig9", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.model import load_paper
        from campaign.report.figures import fig9
    with timer("figure"):
        out = snakemake.output  # noqa: F821
        print(fig9.make(dict(snakemake.params.trials), out.fig9_png, out.fig9_pdf, paper=load_paper()))  # noqa: F821
