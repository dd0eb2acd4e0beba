"""Snakemake script of the table rules: Table 2, 3 or 4 (campaign.report.tables) as CSV, Markdown and HTML.

The table is named by the rule (``table2_...``); Tables 3-4 read the lambda fits of the
gain classes in ``params.classes`` (named inputs), Tables 2 and 4 the identification tables
in ``input.tables``; Table 4 names its trials' structure (``params.structure``).
"""

from campaign.pipeline.joblog import job_log

name = snakemake.rule.split("_")[0]  # noqa: F821
with job_log(snakemake.log[0], job=name, exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.pipeline.tabulate import make_table
    classes = getattr(snakemake.params, "classes", [])  # noqa: F821
    make_table(
        name, snakemake.output.csv, snakemake.output.md,  # noqa: F821
        ident_tables=list(getattr(snakemake.input, "tables", [])),  # noqa: F821
        fits={k: snakemake.input[k] for k in classes},  # noqa: F821
        out_html=snakemake.output.html,  # noqa: F821
        structure=getattr(snakemake.params, "structure", None),  # noqa: F821
        model=getattr(snakemake.input, "model", None),  # noqa: F821
        timer=timer,
    )
