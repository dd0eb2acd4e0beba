"""Snakemake script of rule plan_maps: the impact planner's workspace and direction maps with the campaign's lambda."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="plan_maps", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.plan import planner_lambdas
        from campaign.report.figures import plan_maps
    with timer("maps"):
        out, p = snakemake.output, snakemake.params  # noqa: F821
        lambdas = planner_lambdas(fits=p.fits)
        print(plan_maps.make_workspace(out.workspace, out.workspace_pdf, lambdas=lambdas, rig=p.rig,
                                       resolution=p.resolution))
        print(plan_maps.make_directions(out.directions, out.directions_pdf, lambdas=lambdas, rig=p.rig,
                                        config=p.config_))
