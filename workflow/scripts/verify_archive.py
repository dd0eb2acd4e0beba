"""Snakemake script of rule verify_archive: check a reused archive (manifest, schema, digests).

Every trial file is checked against the schema and its content digests; a finalized archive
also against its manifest and index. A damaged archive fails the job, listing every problem
in the log; an archive that was never finalized (no ``MANIFEST.sha256``) passes with a note.
"""

import os

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="verify_archive", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.archive import MANIFEST, verify_report
    archive = snakemake.params.archive  # noqa: F821
    with timer("verify"):
        report = verify_report(archive)
    problems = report.problems
    unfinalized = [p for p in problems if p.file == MANIFEST and p.message.startswith("missing")]
    problems = [p for p in problems if p not in unfinalized]
    for problem in problems:
        print(problem)
    if report.platform_note():
        print(f"archive {archive}: {report.platform_note()}")  # information, not a problem
    if problems:
        raise SystemExit(f"archive {archive} has {len(problems)} problem(s), listed above")
    note = " (not finalized: no manifest to check the files against)" if unfinalized else ""
    # the archive's absolute path: the workflow refuses to mix another archive's results into this folder
    text = f"archive {os.path.abspath(archive)}: intact, {len(snakemake.input)} trials checked{note}\n"  # noqa: F821
    with open(snakemake.output[0], "w", encoding="utf-8") as fh:  # noqa: F821
        fh.write(text)
    print(text, end="")
