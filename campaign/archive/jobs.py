"""Job manifests: what one simulation job wrote, with each trial's digests taken as it was written.

The workflow's simulation job writes its trials with :func:`write_trial_entry` and lists
them in one JSON file, its *job manifest*, under the campaign folder's ``.jobs/``
(:data:`JOBS`): each trial's path, the sha256 and size of its file, the content digests of
its groups, its ``index.csv`` row and the clock rates the README lists. That file is the
job's only declared output, so what Snakemake plans grows with the jobs, not with the
trials, and the downstream jobs read their trials from it.

:func:`campaign.archive.finalize_campaign` builds the index, README and manifest from the
job manifests without opening a trial: it hashes each file once (the ``MANIFEST.sha256``
needs the hash anyway) and refuses, naming it, a file whose hash differs from the one
taken when its job wrote it, a trial no job wrote, and two trials of the same cell or
content. ``campaign archive verify`` still checks every file from scratch.

The job manifests are the workflow's bookkeeping, not part of the archive: they are not
listed in ``MANIFEST.sha256``, and an archive without them (the committed reference, a
copy, ``campaign sweep``'s) is finalized and verified from its files.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..core.errors import InputError, TrialFileError
from ..core.files import check_regular_file, not_regular, open_regular, sha256_file
from ..core.tolerance import Difference, worst
from ..core.vocabulary import repeat_file, speed_folder
from ..scene.schema import CLOCKS, TrialArrays
from .fileformat import GROUPS, JOBS, STRUCTURAL_ATTRS, plan_trial
from .filing import group_digests
from .folder import layout_trial_files, outside_layout, record_from_attrs, relative_name
from .read import inspect_isolated_many
from .sametrial import plan_differences, what_it_holds
from .write import replace_campaign_file, write_planned

__all__ = ["JOBS", "JOB_MANIFEST_FORMAT", "TrialEntry", "write_trial_entry", "intact_trials",
           "write_job_manifest", "read_job_manifests", "job_trial_paths", "entry_problems", "outside_problems"]

#: the ``format`` a job manifest states
JOB_MANIFEST_FORMAT = "campaign job manifest 1"
@dataclasses.dataclass(frozen=True)
class TrialEntry:
    """One trial as its simulation job wrote it.

    Attributes
    ----------
    path : str
        The trial file relative to the campaign folder.
    sha256 : str
        sha256 of the file's bytes right after it was written.
    size : int
        The file's size [bytes].
    content : tuple of str
        The stored ``content_sha256`` of each group (``measured``, ``truth``):
        two trials with the same ones hold the same data.
    row : dict
        The trial's ``index.csv`` row (its columns ``INDEX_COLUMNS``).
    rates : dict
        ``{rate key: Hz}`` of the clocks (``campaign.scene.schema.CLOCKS``) in the
        trial's scene, for the README.
    kept : bool
        The file was already there holding the same trial and stays as it was (its
        provenance names the run that first wrote it; ``content`` and ``sha256`` are its).
    compared : list of campaign.core.tolerance.Difference
        How an existing file's channels compared with the trial just computed, when its
        content digests differed (empty otherwise); not part of the job manifest.
    """

    path: str
    sha256: str
    size: int
    content: tuple[str, ...]
    row: dict[str, Any]
    rates: dict[str, float]
    kept: bool = False
    compared: tuple[Difference, ...] = dataclasses.field(default=(), compare=False, repr=False)

    def to_json(self) -> dict[str, Any]:
        return {"path": self.path, "sha256": self.sha256, "size": self.size, "content": list(self.content),
                "row": self.row, "rates": self.rates, "kept": self.kept}

    @classmethod
    def from_json(cls, item: Mapping[str, Any]) -> TrialEntry:
        return cls(path=str(item["path"]), sha256=str(item["sha256"]), size=int(item["size"]),
                   content=tuple(str(c) for c in item["content"]), row=dict(item["row"]),
                   rates={str(k): float(v) for k, v in item["rates"].items()}, kept=bool(item.get("kept", False)))


def intact_trials(paths: Sequence[str | os.PathLike]) -> list[bool]:
    """For each path: an existing trial file that passes every check of ``archive verify``
    (schema, channels, content digests), read in a child process (a corrupt file may crash
    the HDF5 library). A missing file is False."""
    present = [Path(p) for p in paths if not not_regular(p)]
    found = dict(zip(present, inspect_isolated_many(present), strict=True))
    return [Path(p) in found and not found[Path(p)] for p in paths]


def _stored_content(path: Path) -> tuple[dict[str, Any], tuple[str, ...]]:
    """Root attributes and the groups' stored content digests of an intact trial file."""
    import h5py  # the writer has loaded it already; here only for the attributes

    check_regular_file(path, error=TrialFileError)
    with h5py.File(path, "r") as f:
        root = {k: f.attrs[k] for k in f.attrs.keys() if k not in STRUCTURAL_ATTRS}
        content = tuple(str(f[g].attrs["content_sha256"]) for g in GROUPS)
    return root, content


def write_trial_entry(tree: Any | TrialArrays, path: str | os.PathLike, *, campaign_dir: str | os.PathLike,
                      keep_same: bool = False, fsync: bool = True) -> TrialEntry:
    """Write one trial like :func:`campaign.archive.write_trial` and return its entry for the job manifest.

    Parameters
    ----------
    tree : xarray.DataTree or TrialArrays
        The trial as the rig returns it.
    path : path-like
        Its file, inside ``campaign_dir``.
    campaign_dir : path-like
        The campaign folder the entry's path is relative to.
    keep_same : bool
        When ``path`` holds an intact trial (checked beforehand with :func:`intact_trials`)
        that is the same trial as ``tree`` (:mod:`campaign.archive.sametrial`: the same
        root attributes but for when and with what it was written, and every channel
        within the tolerance policy's cross-machine tolerance), keep that file as it is: a
        rerun that reproduces a trial, on this machine or another, leaves its file, and so
        the archive's manifest, unchanged. The channels are read and compared only when
        the groups' content digests differ.
    fsync : bool
        As :func:`campaign.archive.write_trial`.

    Returns
    -------
    TrialEntry
    """
    path = Path(path)
    root, groups = plan_trial(tree)
    content = tuple(str(groups[g].attrs["content_sha256"]) for g in GROUPS)
    kept, compared, old_root = False, [], root
    if keep_same:
        old_root, old_content = _stored_content(path)
        if old_content == content and what_it_holds(old_root) == what_it_holds(root):
            kept = True
        else:   # another machine's roundoff, or another trial: channel by channel
            compared = plan_differences(path, root, groups)
            kept = worst(compared).ok
        if kept:
            content = old_content
    if not kept:
        write_planned((root, groups), path, fsync=fsync)
    rec = record_from_attrs(Path(campaign_dir), path, old_root if kept else root)
    params = json.loads(rec.scene_json).get("params", {})
    rates = {c.rate_key: float(params[c.rate_key]) for c in CLOCKS.values() if c.rate_key in params}
    return TrialEntry(path=rec.path, sha256=sha256_file(path), size=path.stat().st_size, content=content,
                      row=rec.row(), rates=rates, kept=kept, compared=tuple(compared))


def write_job_manifest(path: str | os.PathLike, entries: Iterable[TrialEntry], *, job: str) -> Path:
    """Write a job manifest (JSON, atomically): the job's name and its trials' entries."""
    body = {"format": JOB_MANIFEST_FORMAT, "job": job, "trials": [e.to_json() for e in entries]}
    text = json.dumps(body, indent=0, sort_keys=True) + "\n"

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)

    return replace_campaign_file(Path(path), write)


def read_job_manifests(paths: Iterable[str | os.PathLike]) -> list[TrialEntry]:
    """The trial entries of job manifests, in the order given.

    Raises
    ------
    TrialFileError
        A manifest that is missing, not JSON or not a job manifest (named).
    """
    out: list[TrialEntry] = []
    for p in paths:
        try:
            with open_regular(p, "r", encoding="utf-8", error=TrialFileError) as fh:
                body = json.load(fh)
            if body.get("format") != JOB_MANIFEST_FORMAT:
                raise ValueError(f"format {body.get('format')!r}, expected {JOB_MANIFEST_FORMAT!r}")
            out += [TrialEntry.from_json(item) for item in body["trials"]]
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise TrialFileError(f"{p}: not a readable job manifest ({exc})") from None
    return out


def job_trial_paths(campaign_dir: str | os.PathLike, manifests: Iterable[str | os.PathLike]) -> list[str]:
    """The trial files job manifests list, as paths under ``campaign_dir`` (``<campaign_dir>/<path>``,
    joined as strings so they read as the workflow names them), in the order listed."""
    root = str(campaign_dir).rstrip("/") or "/"
    manifests = list(manifests)
    entries = read_job_manifests(manifests)
    if not entries:
        raise InputError(f"the job manifests {', '.join(map(str, manifests))} list no trial")
    return [f"{root}/{e.path}" for e in entries]


#: what a campaign folder holds besides its trials at the cell layout
_LAYOUT = "trials at <base>/<pose>/<gain>/v<speed>/r<NN>.nc, index.csv, README.md, MANIFEST.sha256"


def outside_problems(campaign: Path, known: Mapping[tuple[str, ...] | None, str]) -> list[tuple[str, str]]:
    """Every file of a campaign folder outside the archive layout (:func:`campaign.archive.folder.outside_layout`),
    with the trial it copies when it is a trial file with the content digests of one in
    ``known`` (``{group digests: relative path}``). ``(relative path, message)`` pairs."""
    out = []
    for rel in outside_layout(campaign):
        message = f"outside the archive layout ({_LAYOUT}): no reader counts it; move it out of the campaign folder"
        twin = known.get(group_digests(campaign / rel)) if rel.endswith(".nc") else None
        if twin is not None:
            message += f"; same content (group digests) as {twin}: a duplicate trial"
        out.append((rel, message))
    return out


def entry_problems(campaign: Path, entries: Sequence[TrialEntry], *,
                   hashes: dict[str, str] | None = None) -> list[tuple[str, str]]:
    """What keeps a campaign folder written by the jobs of ``entries`` from being finalized.

    Each trial file is hashed once (into ``hashes``, ``{relative path: sha256}``, for the
    manifest) and must have the sha256 its job took; every trial file at the cell layout
    must be one a job wrote; no two entries may hold the same path, cell or content; an
    entry's path must be the one its row's cell gives; and no file may lie outside the
    layout. ``(relative path, message)`` pairs, in path order.
    """
    hashes = {} if hashes is None else hashes
    problems: list[tuple[str, str]] = []
    by_path: dict[str, TrialEntry] = {}
    by_content: dict[tuple[str, ...], str] = {}
    for e in sorted(entries, key=lambda e: e.path):
        row = e.row
        parts = e.path.split("/")
        want = [str(row["base"]), None, str(row["gain"]), speed_folder(row["speed"]), repeat_file(row["repeat"])]
        if len(parts) != 5 or any(w is not None and w != p for w, p in zip(want, parts, strict=True)):
            problems.append((e.path, f"its job manifest row places it elsewhere ({row['base']}, config {row['config']}, "
                                     f"{row['gain']}, {row['speed']} m/s, repeat {row['repeat']})"))
        if e.path in by_path:
            problems.append((e.path, "written by two simulation jobs (their job manifests both list it)"))
            continue
        by_path[e.path] = e
        if e.content in by_content:
            problems.append((e.path, f"same content (group digests) as {by_content[e.content]}: a duplicate trial"))
        else:
            by_content.setdefault(e.content, e.path)
        file = campaign / e.path
        kind = not_regular(file)
        if kind:
            problems.append((e.path, "missing: its simulation job wrote it, and it was deleted since"
                             if kind == "does not exist" else kind))
            continue
        hashes[e.path] = sha256_file(file)
        if hashes[e.path] != e.sha256:
            problems.append((e.path, "changed since its simulation job wrote it (its sha256 differs from the one "
                                     "in the job manifest): rerun that job, or check it with campaign archive verify"))
    for file in layout_trial_files(campaign):
        rel = relative_name(campaign, file)
        if rel not in by_path:
            twin = by_content.get(group_digests(file))
            problems.append((rel, "no simulation job of this campaign wrote it (a copy, or a trial of an earlier "
                                  "sweep): delete it or move it out of the campaign folder"
                             + (f"; same content (group digests) as {twin}: a duplicate trial" if twin else "")))
    problems += outside_problems(campaign, by_content)
    return sorted(problems)
