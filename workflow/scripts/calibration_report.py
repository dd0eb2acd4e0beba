"""Snakemake script of rule calibration_report: the calibration report of the campaign."""

from campaign.pipeline.joblog import job_log

with job_log(snakemake.log[0], job="calibration_report", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        import csv
        import io

        from campaign.core.files import write_atomic
        from campaign.pipeline.calibration_report import campaign_report
        from campaign.report.html import markdown_page
    with timer("report"):
        trials = {f"{c}-{g}": snakemake.input[f"c{c}_{g}"] for c in (1, 2) for g in ("low", "high")}  # noqa: F821
        text, rows = campaign_report(rig=snakemake.input.rig, table4_csv=snakemake.input.table4,  # noqa: F821
                                     fig9_trials=trials)
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        write_atomic(snakemake.output.md, text)  # noqa: F821
        write_atomic(snakemake.output.html, markdown_page(text, title="Calibration report"))  # noqa: F821
        write_atomic(snakemake.output.csv, buf.getvalue())  # noqa: F821
        print(text)
