"""Snakemake script of rule calibration_report: the calibration report of the campaign."""

from campaign import runner

with runner.job_log(snakemake.log[0], job="calibration_report", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        import csv
        import io

        from campaign.calibrate import campaign_report
        from campaign.htmlpage import markdown_page
    with timer("report"):
        trials = {f"{c}-{g}": snakemake.input[f"c{c}_{g}"] for c in (1, 2) for g in ("low", "high")}  # noqa: F821
        text, rows = campaign_report(rig=snakemake.input.rig, table4_csv=snakemake.input.table4,  # noqa: F821
                                     fig9_trials=trials)
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        runner.write_atomic(snakemake.output.md, text)  # noqa: F821
        runner.write_atomic(snakemake.output.html, markdown_page(text, title="Calibration report"))  # noqa: F821
        runner.write_atomic(snakemake.output.csv, buf.getvalue())  # noqa: F821
        print(text)
