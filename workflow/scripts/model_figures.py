"""Snakemake script of rule model_figures: Figure 4 from the robot model and Figure 8 from the
rig parameters and the robot model, each with its own log."""

from campaign.pipeline import job_log

p, out, log = snakemake.params, snakemake.output, snakemake.log  # noqa: F821 - provided by Snakemake
with job_log(log.job, job="model_figures", exit_process=True) as timer:
    with timer.imports():
        from campaign.report.figures import fig4, fig8
    with job_log(log.fig4, job="fig4", part_of="model_figures") as part, part("figure"):
        print(fig4.make(out.fig4_png, out.fig4_pdf))
    with job_log(log.fig8, job="fig8", part_of="model_figures") as part, part("figure"):
        print(fig8.make(out.fig8_png, out.fig8_pdf, rig=p.rig, params=p.rig_params))
