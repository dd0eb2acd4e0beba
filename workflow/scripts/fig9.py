"""Snakemake script of rule fig9_base_motion: Figure 9 from four flexible-base trials."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job="fig9", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.model.paper import load_paper
        from campaign.report.figures import fig9
    with timer("figure"):
        trials = {f"{c}-{g}": snakemake.input[f"c{c}_{g}"] for c in (1, 2) for g in ("low", "high")}  # noqa: F821
        print(fig9.make(trials, snakemake.output.png, snakemake.output.pdf, paper=load_paper()))  # noqa: F821
