"""Snakemake script of rule plan_maps: the impact planner's workspace and direction maps with the campaign's lambda."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="plan_maps", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.plan import planner_lambdas
        from campaign.report.figures import plan_maps, style
    out, p = snakemake.output, snakemake.params  # noqa: F821
    with timer("maps"):          # the numbers of both maps
        lambdas = planner_lambdas(fits=p.fits)
        ws, marks, ws_line = plan_maps.workspace_figure(lambdas=lambdas, rig=p.rig, resolution=p.resolution)
        dirs, title, dirs_line = plan_maps.directions_figure(lambdas=lambdas, rig=p.rig, config=p.config_)
    with timer("figure"):        # each drawn once, saved as PNG and PDF
        style.save(plan_maps.draw_workspace(ws, marks=marks), out.workspace, out.workspace_pdf)
        style.save(plan_maps.draw_directions(dirs, title=title), out.directions, out.directions_pdf)
    print(ws_line)
    print(dirs_line)
