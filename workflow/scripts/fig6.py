"""Snakemake script of rule fig6_effective_mass: Figure 6 from the fixed-base identification."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job="fig6", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.model.paper import load_paper
        from campaign.report.figures import fig6
    with timer("figure"):
        print(fig6.make(list(snakemake.input.tables), snakemake.output.png, snakemake.output.pdf,
                        paper=load_paper()))  # noqa: F821
