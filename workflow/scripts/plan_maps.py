"""Snakemake script of rule plan_maps: the impact planner's workspace and direction maps with the campaign's lambda."""

from campaign import runner

with runner.job_log(snakemake.log[0], job="plan_maps", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.figures import plan_maps
    with timer("figure"):
        out, p = snakemake.output, snakemake.params  # noqa: F821
        print(plan_maps.make_workspace(out.workspace, out.workspace_pdf, fits=p.fits, rig=p.rig,
                                       resolution=p.resolution))
        print(plan_maps.make_directions(out.directions, out.directions_pdf, fits=p.fits, rig=p.rig,
                                        config=p.config_))
