"""Snakemake script of rule calibration_report: the calibration report of the campaign."""

from campaign import runner

with runner.job_log(snakemake.log[0], job="calibration_report", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        import csv

        from campaign.calibrate import campaign_report
    with timer("report"):
        trials = {f"{c}-{g}": snakemake.input[f"c{c}_{g}"] for c in (1, 2) for g in ("low", "high")}  # noqa: F821
        text, rows = campaign_report(rig=snakemake.input.rig, table4_csv=snakemake.input.table4,  # noqa: F821
                                     fig9_trials=trials)
        with open(snakemake.output.md, "w") as fh:  # noqa: F821
            fh.write(text)
        with open(snakemake.output.csv, "w", newline="") as fh:  # noqa: F821
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        print(text)
