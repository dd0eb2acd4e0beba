"""Snakemake script of rule flexible_base: Table 4 and the calibration report, each product
with its own log."""

from campaign.pipeline import job_log

p, inp, out, log = snakemake.params, snakemake.input, snakemake.output, snakemake.log  # noqa: F821
with job_log(log.job, job="flexible_base", exit_process=True) as timer:
    with timer.imports():
        import csv
        import io

        from campaign.core import write_atomic
        from campaign.pipeline import campaign_report, make_table
        from campaign.report import markdown_page
    if "table4" in p.products:
        with job_log(log.table4, job="table4", part_of="flexible_base") as part:
            make_table("table4", out.table4_csv, out.table4_md, ident_tables=list(inp.tables),
                       fits={k: inp[k] for k in p.classes}, out_html=out.table4_html, structure=p.structure,
                       model=inp.model, timer=part)
    if "calibration" in p.products:
        with job_log(log.calibration, job="calibration_report", part_of="flexible_base") as part, part("report"):
            text, rows = campaign_report(rig=inp.rig, table4_csv=out.table4_csv, fig9_trials=dict(p.fig9_trials))
            write_atomic(out.calibration_md, text)
            write_atomic(out.calibration_html, markdown_page(text, title="Calibration report"))
            buf = io.StringIO()
            writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
            write_atomic(out.calibration_csv, buf.getvalue())
            print(text)
