"""Snakemake script of rule verify_archive: check a reused archive (manifest, schema, digests).

Writes the verdict; a damaged archive fails the job, listing every problem in the log.
"""

from campaign import runner

with runner.job_log(snakemake.log[0], job="verify_archive") as timer:  # noqa: F821
    with timer("imports"):
        from campaign.archive import verify
    with timer("verify"):
        problems = verify(snakemake.params.archive)  # noqa: F821
    for problem in problems:
        print(problem)
    if problems:
        raise SystemExit(f"archive {snakemake.params.archive} has {len(problems)} problem(s), listed above")  # noqa: F821
    text = f"archive {snakemake.params.archive}: intact ({len(snakemake.input)} trials checked)\n"  # noqa: F821
    with open(snakemake.output[0], "w", encoding="utf-8") as fh:  # noqa: F821
        fh.write(text)
    print(text, end="")
