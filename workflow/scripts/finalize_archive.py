"""Snakemake script of rule finalize_archive: index, README and manifest of the campaign's archive,
from the simulation jobs' manifests (no trial is opened; each file is hashed once)."""

from campaign.pipeline import job_log

with job_log(snakemake.log[0], job="finalize_archive", exit_process=True) as timer:  # noqa: F821
    with timer.imports():
        from campaign.archive import finalize_campaign
    with timer("finalize"):
        written = finalize_campaign(snakemake.params.archive, job_manifests=list(snakemake.input))  # noqa: F821
    for kind, path in written.items():
        print(f"wrote {kind}: {path}")
