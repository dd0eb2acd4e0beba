"""A campaign folder's index, README and manifest, finalisation and verification."""

from __future__ import annotations

import collections
import csv
import dataclasses
import io
import json
import os
import re
from pathlib import Path
from typing import Any, Iterable, Sequence

from ..core.errors import InputError, TrialFileError
from ..core.files import not_regular, open_regular, sha256_file
from ..core.progress import progress
from ..core.vocabulary import bases
from ..scene.schema import CLOCKS, COORDS, MEASURED, SCHEMA_VERSION, TRUTH
from .fileformat import (
    CELL_KEYS,
    INDEX,
    INDEX_COLUMNS,
    JOBS,
    LABEL_LONG_NAMES,
    MANIFEST,
    README,
    TEMP_FILE_RE,
    TRIAL_SUFFIX,
)
from .filing import filing_problems, group_digests
from .folder import TrialRecord, campaign_folder, is_campaign_file, layout_trial_files, read_record, relative_name
from .jobs import TrialEntry, entry_problems, outside_problems, read_job_manifests
from .machine import NOT_RECORDED
from .read import inspect_isolated_many
from .write import replace_campaign_file


@dataclasses.dataclass(frozen=True)
class Problem:
    """One problem :func:`verify` found: the file (relative to the campaign) and what is wrong."""

    file: str
    message: str

    def __str__(self) -> str:
        return f"{self.file}: {self.message}"


@dataclasses.dataclass(frozen=True)
class Verification:
    """What :func:`verify_report` found in a campaign folder.

    Attributes
    ----------
    problems : list of Problem
        Empty when the campaign is intact.
    platforms : dict of str to int
        The number of readable trials per platform that computed them
        (:func:`campaign.archive.machine.platform_summary`), most trials first, trials
        that record none last. Trials of several platforms are no problem: a campaign run
        on a cluster spans its nodes.
    """

    problems: list[Problem]
    platforms: dict[str, int]

    def platform_note(self) -> str | None:
        """``trials from 2 platforms: <summary> (40 trials), <summary> (8 trials)``, or None
        when all trials come from one platform."""
        if len(self.platforms) < 2:
            return None
        return f"trials from {len(self.platforms)} platforms: " + ", ".join(
            f"{name} ({n} trial{'s' if n != 1 else ''})" for name, n in self.platforms.items())


# ---------------------------------------------------------------------------------------
# manifest, index, README
# ---------------------------------------------------------------------------------------
def _all_files(campaign: Path) -> list[Path]:
    """Every file the manifest lists: all but the manifest itself and the workflow's job manifests."""
    return sorted(p for p in campaign.rglob("*")
                  if p.is_file() and p.name != MANIFEST and not (is_campaign_file(relative_name(campaign, p))
                                                                 and relative_name(campaign, p).startswith(f"{JOBS}/")))


def _write_text(path: Path, text: str) -> Path:
    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
    return replace_campaign_file(path, write)


def write_manifest(campaign_dir: str | os.PathLike, *, known: dict[str, str] | None = None) -> Path:
    """Write ``MANIFEST.sha256``: the sha256 of every file of the campaign folder.

    The format is ``sha256sum``'s (``<hex>  <relative path>``, sorted), so
    ``cd <campaign_dir> && sha256sum -c MANIFEST.sha256`` checks it without this package.
    ``known`` maps relative paths to a sha256 already taken (finalize hashes the trials
    while it checks them), so no file is read twice. The workflow's job manifests
    (``.jobs/``) are not listed: they are its bookkeeping, not part of the archive.

    Raises
    ------
    InputError
        Not a campaign folder, or it holds a temporary file of an interrupted write (named)
        or a file name ``sha256sum`` cannot list plainly (newline or backslash).
    """
    campaign = campaign_folder(campaign_dir)
    lines = []
    for file in progress(_all_files(campaign), desc="sha256", unit="file"):
        rel = relative_name(campaign, file)
        if TEMP_FILE_RE.match(file.name):
            raise InputError(f"{campaign / rel} is a temporary file of an interrupted write: delete it "
                             "(or rerun that trial) before finalizing")
        if "\n" in rel or "\\" in rel:
            raise InputError(f"{campaign / rel}: file names with newlines or backslashes cannot be listed")
        lines.append(f"{(known or {}).get(rel) or sha256_file(file)}  {rel}\n")
    return _write_text(campaign / MANIFEST, "".join(lines))


def write_index(campaign_dir: str | os.PathLike, *, records: Sequence[TrialRecord] | None = None) -> Path:
    """Write ``index.csv``: one row per trial (:data:`INDEX_COLUMNS`), sorted by path.

    ``records`` are the records of the folder's trial files at the cell layout, when the
    caller has them already."""
    campaign = campaign_folder(campaign_dir)
    return _write_index_rows(campaign, [rec.row() for rec in (_layout_records(campaign) if records is None
                                                                else records)])


def _write_index_rows(campaign: Path, rows: Iterable[dict[str, Any]]) -> Path:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=INDEX_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow(row)
    return _write_text(campaign / INDEX, buf.getvalue())


def _layout_records(campaign: Path) -> list[TrialRecord]:
    """The records of the trial files at the cell layout (what finalize indexes), in path order."""
    return [read_record(campaign, f) for f in progress(list(layout_trial_files(campaign)), desc="read")]


def _md_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _readme_facts(records: Sequence[TrialRecord]) -> tuple[dict[str, int], dict[str, set]]:
    """What the README says of the trials: their count per base and the rates of each clock."""
    rates: dict[str, set] = {dim: set() for dim in CLOCKS}
    for rec in records:
        params = json.loads(rec.scene_json)["params"]
        for dim, clock in CLOCKS.items():
            if clock.rate_key in params:
                rates[dim].add(float(params[clock.rate_key]))
    return {b: sum(r.base == b for r in records) for b in bases()}, rates


def _entry_facts(entries: Sequence[TrialEntry]) -> tuple[dict[str, int], dict[str, set]]:
    """:func:`_readme_facts` of the trials of job manifests."""
    rates: dict[str, set] = {dim: set() for dim in CLOCKS}
    for e in entries:
        for dim, clock in CLOCKS.items():
            if clock.rate_key in e.rates:
                rates[dim].add(e.rates[clock.rate_key])
    return {b: sum(e.row["base"] == b for e in entries) for b in bases()}, rates


def _readme_text(name: str, counts: dict[str, int], rates: dict[str, set]) -> str:
    clock_rows = [(f"`{dim}`", c.long_name, f"`{c.rate_key}`",
                   ", ".join(f"{r:g}" for r in sorted(rates[dim])) or "-") for dim, c in CLOCKS.items()]

    def var_rows(table):
        return [(f"`{v.name}`", "(" + ", ".join(v.dims) + ")" if v.dims else "scalar", f"`{v.units}`",
                 v.long_name, ", ".join(v.bases)) for v in table]

    label_rows = [(f"`{d}`", LABEL_LONG_NAMES[d], ", ".join(COORDS[d]) if COORDS[d] else "the robot's active joints")
                  for d in COORDS]
    header = ("variable", "dims", "units", "long_name", "bases")
    parts = [
        f"# Campaign archive `{name}`",
        "",
        f"Generated from `campaign/scene/schema.py` (schema {SCHEMA_VERSION}) by `campaign archive finalize`; "
        "do not edit, regenerate it.",
        "",
        f"{sum(counts.values())} trials: " + ", ".join(f"{counts[b]} {b}-base" for b in bases()) + ".",
        "",
        "## Files",
        "",
        f"- `<base>/config<N>/<gain>/v<speed m/s>/r<repeat>{TRIAL_SUFFIX}`: one trial, NetCDF4/HDF5 "
        "(`pose-<q1>_<q2>_<q3>-n<azimuth of n from -x, deg>` for another pose or impact direction).",
        f"- `{INDEX}`: one row per trial: " + ", ".join(f"`{c}`" for c in INDEX_COLUMNS) + ".",
        f"- `{MANIFEST}`: sha256 of every other file; check with `sha256sum -c {MANIFEST}` in this folder, "
        "or `campaign archive verify <folder>` (also checks every trial against the schema).",
        "",
        "## Opening a trial",
        "",
        "```python",
        "import xarray as xr",
        f'with xr.open_dataset("fixed/config1/zero/v1.500/r00{TRIAL_SUFFIX}", engine="h5netcdf", group="measured") as ds:',
        "    ds.load()",
        "```",
        "",
        "Group `measured` holds what a real VES-II records (noisy, quantised, each channel on its own "
        "clock) plus the instrument constants an experimenter knows; group `truth` holds the simulator's "
        "exact states, kept apart (identification never reads it). The root group holds the global "
        "attributes: ACDD-1.3 (`title`, `summary`, `keywords`, `Conventions`, `id`, `date_created`, "
        "`creator_name`, `project`, `references`, `license`, `processing_level`), `schema_version`, the "
        "full scene as `scene_json` with its `scene_sha256`, the RNG `seed`, the cell (`base`, `config`, "
        "`gain`, `speed`, `repeat`, `robot`) and provenance (`campaign_version`, `git_commit`, library "
        "versions). Each group also stores `content_sha256`, a digest of its attributes and data that "
        "`campaign` checks on every read.",
        "",
        "## Clocks (time dimensions)",
        "",
        "Each time coordinate is float64 seconds from the start of the recording (`units = \"s\"`; no "
        "`standard_name`, which CF keeps for times with a `since` epoch); the contact happens at a seeded, "
        "jittered instant inside it.",
        "",
        _md_table(("dimension", "clock", "rate key (scene parameter)", "rate in this campaign [Hz]"), clock_rows),
        "",
        "## Label dimensions",
        "",
        _md_table(("dimension", "long_name", "values"), label_rows),
        "",
        "## Group `/measured`",
        "",
        _md_table(header, var_rows(MEASURED)),
        "",
        "## Group `/truth`",
        "",
        _md_table(header, var_rows(TRUTH)),
        "",
    ]
    return "\n".join(parts)


def write_readme(campaign_dir: str | os.PathLike, *, records: Sequence[TrialRecord] | None = None) -> Path:
    """Write ``README.md``: every variable, unit, dims and clock of the schema, and the rates used.

    Generated from :mod:`campaign.scene.schema` and the trials' scenes, without a date, so the same
    campaign always gets the same README. ``records`` as in :func:`write_index`.
    """
    campaign = campaign_folder(campaign_dir)
    counts, rates = _readme_facts(_layout_records(campaign) if records is None else records)
    return _write_text(campaign / README, _readme_text(campaign.resolve().name, counts, rates))


def finalize_campaign(campaign_dir: str | os.PathLike, *,
                      job_manifests: Sequence[str | os.PathLike] | None = None) -> dict[str, Path]:
    """Check every trial, then write ``index.csv``, ``README.md`` and ``MANIFEST.sha256`` (last).

    Parameters
    ----------
    campaign_dir : path-like
        The campaign folder.
    job_manifests : sequence of path-like, optional
        The job manifests of the simulation jobs that wrote the campaign (the workflow's
        :mod:`campaign.archive.jobs`). With them no trial is opened: each file is hashed
        once (for the manifest) and must have the sha256 its job took when it wrote it;
        every trial file must be one a job wrote. Without them every trial file is read
        and checked from scratch (schema, content digests, filing), as ``archive verify``
        does.

    Returns
    -------
    dict
        ``{"index": path, "readme": path, "manifest": path}``.

    Raises
    ------
    TrialFileError
        Nothing is written when a trial fails its checks, a file lies outside the archive
        layout (a copy in a folder of its own, notes), two trials hold the same cell or the
        same content, or (with job manifests) a file changed since its job wrote it or no
        job wrote it; every such file is named.
    InputError
        Not a campaign folder, a leftover temporary file of an interrupted write, or a
        folder, FIFO, socket or device where the index, README or manifest goes.
    """
    campaign = campaign_folder(campaign_dir)
    for name in (INDEX, README, MANIFEST):
        kind = not_regular(campaign / name)
        if kind and kind != "does not exist":     # refused before any file is written
            raise InputError(f"{campaign / name}: {kind}; finalizing writes a file there")
    for file in _all_files(campaign):
        if TEMP_FILE_RE.match(file.name):
            raise InputError(f"{file} is a temporary file of an interrupted write: delete it "
                             "(or rerun that trial) before finalizing")
    if job_manifests is None:
        rows, (counts, rates), known = _checked_from_files(campaign)
    else:
        entries = read_job_manifests(job_manifests)
        known = {}
        problems = entry_problems(campaign, entries, hashes=known)
        if problems:
            raise TrialFileError("cannot finalize: " + "; ".join(f"{campaign / rel}: {m}" for rel, m in problems))
        entries = sorted(entries, key=lambda e: e.path)
        rows, (counts, rates) = [e.row for e in entries], _entry_facts(entries)
    return {"index": _write_index_rows(campaign, rows),
            "readme": _write_text(campaign / README, _readme_text(campaign.resolve().name, counts, rates)),
            "manifest": write_manifest(campaign, known=known)}


def _checked_from_files(campaign: Path):
    """Every trial file of the folder read and checked: (index rows, README facts, no known hashes)."""
    bad = []
    files = list(layout_trial_files(campaign))
    for file, found in zip(files, inspect_isolated_many(files), strict=True):
        bad += [f"{file}: {p}" for p in found]
    if bad:
        raise TrialFileError("cannot finalize, broken trial files: " + "; ".join(bad))
    # the index and the README describe the same trials: their root attributes are read once
    # (a few ms per file; 216 files in the full campaign)
    records = _layout_records(campaign)
    misfiled = filing_problems(campaign, [_filing_record(r) for r in records])
    misfiled += outside_problems(campaign, {group_digests(r.file): r.path for r in records})
    if misfiled:
        raise TrialFileError("cannot finalize, misfiled or duplicate trials: "
                             + "; ".join(f"{campaign / rel}: {message}" for rel, message in misfiled))
    return [r.row() for r in records], _readme_facts(records), {}


_MANIFEST_LINE = re.compile(r"^([0-9a-f]{64}) [ *](.+)$")


def verify(campaign_dir: str | os.PathLike) -> list[Problem]:
    """The problems :func:`verify_report` finds in a campaign folder (empty when it is intact)."""
    return verify_report(campaign_dir).problems


def verify_report(campaign_dir: str | os.PathLike) -> Verification:
    """Check a campaign folder against its manifest and every trial against the schema.

    Reports, each with the file it concerns: a missing or malformed manifest, a file listed
    but missing, a sha256 mismatch (altered, flipped bytes, truncated), a file not in the
    manifest (including temporary files of interrupted writes), and for every trial file an
    unreadable or truncated file, a schema version of another major, a missing channel or
    group, content that does not match its ``content_sha256``; and an index that disagrees
    with the trial files. Nothing is skipped: every file is looked at. It also counts the
    trials per platform that computed them, from the root attributes it reads anyway.

    Returns
    -------
    Verification
        The problems and the platforms.

    Raises
    ------
    InputError
        Not a campaign folder.
    """
    campaign = campaign_folder(campaign_dir)
    problems, listed = _manifest_problems(campaign)
    finalized = not_regular(campaign / MANIFEST) is None
    on_disk = {relative_name(campaign, f) for f in _all_files(campaign)}
    for rel in sorted(on_disk - set(listed)):
        if TEMP_FILE_RE.match(Path(rel).name):
            problems.append(Problem(rel, "temporary file of an interrupted write (delete it)"))
        elif finalized:
            problems.append(Problem(rel, f"not in {MANIFEST}"))
    trials = [relative_name(campaign, f) for f in layout_trial_files(campaign)]
    for rel, found in zip(trials, inspect_isolated_many([campaign / rel for rel in trials])):
        problems += [Problem(rel, p) for p in found]
    records = []
    for rel in trials:
        try:
            records.append(read_record(campaign, campaign / rel))
        except TrialFileError:
            pass  # reported by the inspection above
    readable = [_filing_record(r) for r in records]
    rows = _index_rows(campaign, trials, problems, finalized=finalized)
    problems += [Problem(rel, message) for rel, message in filing_problems(campaign, readable, rows)]
    known = {group_digests(campaign / r["path"]): r["path"] for r in readable}
    problems += [Problem(rel, message) for rel, message in outside_problems(campaign, known)]
    problems = list(dict.fromkeys(problems))     # a file found twice (listed, and a trial) is named once
    platforms = collections.Counter(r.computing_platform for r in records)
    order = sorted(platforms.items(), key=lambda item: (item[0] == NOT_RECORDED, -item[1], item[0]))
    return Verification(problems, dict(order))


def _manifest_problems(campaign: Path) -> tuple[list[Problem], dict[str, str]]:
    """The problems of the manifest and of the files it lists, and what it lists ``{path: sha256}``."""
    problems: list[Problem] = []
    listed: dict[str, str] = {}
    manifest = campaign / MANIFEST
    kind = not_regular(manifest)
    if kind == "does not exist":
        return [Problem(MANIFEST, "missing: the campaign is not finalized (campaign archive finalize)")], listed
    if kind:
        return [Problem(MANIFEST, f"{kind}; the manifest cannot be read, so no file is checked against it")], listed
    with open_regular(manifest, "r", error=TrialFileError, encoding="utf-8", errors="replace") as fh:
        text = fh.read()
    for n, line in enumerate(text.splitlines(), 1):
        m = _MANIFEST_LINE.match(line)
        if not m:
            problems.append(Problem(MANIFEST, f"line {n} is not '<sha256>  <path>': {line[:80]!r}"))
            continue
        rel = m.group(2)
        if rel.startswith("/") or ".." in Path(rel).parts:
            problems.append(Problem(MANIFEST, f"line {n} names a path outside the campaign: {rel!r}"))
            continue
        listed[rel] = m.group(1)
    for rel, digest in progress(listed.items(), desc="sha256", unit="file"):
        file = campaign / rel
        kind = not_regular(file)
        if kind:
            problems.append(Problem(rel, f"listed in {MANIFEST} but missing" if kind == "does not exist" else kind))
        elif sha256_file(file) != digest:
            problems.append(Problem(rel, f"sha256 differs from {MANIFEST} (altered, corrupt or truncated)"))
    return problems, listed


def _index_rows(campaign: Path, trials: list[str], problems: list[Problem], *, finalized: bool):
    """The rows of the campaign's index (None when it cannot be read); its problems appended to ``problems``."""
    index = campaign / INDEX
    kind = not_regular(index)
    if kind == "does not exist":
        if finalized:
            problems.append(Problem(INDEX, "missing (campaign archive finalize writes it)"))
        return None
    if kind:
        problems.append(Problem(INDEX, kind))     # as the manifest's check names it: once
        return None
    try:
        with open_regular(index, "r", error=TrialFileError, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
        indexed = {row["path"] for row in rows}
    except (KeyError, csv.Error, UnicodeDecodeError, TrialFileError) as exc:
        problems.append(Problem(INDEX, f"unreadable: {exc}"))
        return None
    for rel in sorted(indexed - set(trials)):
        problems.append(Problem(INDEX, f"lists {rel}, which is not a trial file of this campaign"))
    for rel in sorted(set(trials) - indexed):
        problems.append(Problem(rel, f"trial file not listed in {INDEX}"))
    return rows


def _filing_record(rec: TrialRecord) -> dict[str, Any]:
    """What :func:`campaign.archive.filing.filing_problems` reads of a trial."""
    return {"path": rec.path, "base": rec.base, "config": rec.config, "gain": rec.gain, "speed": rec.speed,
            "repeat": rec.repeat, "seed": rec.seed, "scene_json": rec.scene_json}


def _manifest_of(trial: Path) -> Path | None:
    """The manifest of the finalized campaign folder ``trial`` lies in (its nearest ancestor
    with a ``MANIFEST.sha256``, at most as deep as the cell layout), or None."""
    # the layout's folders (<base>/config<N>/<gain>/v<speed>/), then the campaign folder
    for parent in list(trial.absolute().parents)[:len(CELL_KEYS)]:
        if (parent / MANIFEST).is_file():
            return parent / MANIFEST
    return None


def _listed(manifest: Path) -> dict[str, str]:
    """``{relative path: sha256}`` of a manifest's well-formed lines."""
    with open_regular(manifest, "r", encoding="utf-8", errors="replace", error=TrialFileError) as fh:
        return {m.group(2): m.group(1) for m in map(_MANIFEST_LINE.match, fh.read().splitlines()) if m}


def check_listed_digests(paths: Iterable[str | os.PathLike]) -> None:
    """Each trial file of a finalized campaign folder has the sha256 its ``MANIFEST.sha256``
    lists, before a reader uses it: a flipped bit anywhere in the file (also in a group the
    reader does not open) or an added group is caught, at about 1 ms per MB read. Files
    outside a finalized folder, and a path through a symbolic link inside one, pass (their
    readers check the groups' content digests and where the content belongs).

    Raises
    ------
    TrialFileError
        Naming the first file whose sha256 differs or that its folder's manifest does not
        list, and the command that lists every problem of the folder.
    """
    manifests: dict[Path, dict[str, str]] = {}
    for path in map(Path, paths):
        manifest = _manifest_of(path)
        if manifest is None or not_regular(path):
            continue        # not in a finalized folder; a missing file is named by its reader
        campaign = manifest.parent
        rel = relative_name(campaign, path.absolute())
        if Path(os.path.realpath(path)) != Path(os.path.realpath(campaign)) / rel:
            continue        # a link inside the folder: its reader names where it leads
        if manifest not in manifests:
            manifests[manifest] = _listed(manifest)
        hint = f"`campaign archive verify {campaign}` lists every problem"
        digest = manifests[manifest].get(rel)
        if digest is None:
            raise TrialFileError(f"{path}: not in {manifest} (added or renamed after the folder was finalized); {hint}")
        if sha256_file(path) != digest:
            raise TrialFileError(f"{path}: sha256 differs from {manifest} (altered, corrupt or truncated); {hint}")
