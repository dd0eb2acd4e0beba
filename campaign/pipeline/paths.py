"""Where a campaign's trials and results are: the trials of a sweep cell, declared or found
in an archive, and the results folder of a re-analysed archive.

Standard library only: the campaign's plan calls these while Snakemake builds the DAG.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence
from pathlib import Path

from ..core.errors import InputError
from ..core.files import not_regular, open_regular, sha256_file
from ..core.vocabulary import TRIAL_SUFFIX, cell_dir, trial_relpath

__all__ = ["cell_trials", "find_cell_trials", "index_cells", "check_manifest", "REUSE_PREFIX", "VERIFY_FILE", "reuse_results",
           "check_reuse_results"]

#: results of re-analysing the archive ``<x>`` go to ``<results_root>/reuse-<x>``
REUSE_PREFIX = "reuse-"
#: the re-analysed archive's verification, in its results folder: it names the archive
VERIFY_FILE = "archive_verify.txt"
def cell_trials(archive_dir: str | os.PathLike, base: str, config: int, gain: str,
                speeds: Sequence[float], repeats: int) -> list[str]:
    """Paths of every trial of a cell: each speed x repeat ``0 .. repeats-1``, speed-major."""
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1, got {repeats!r}")
    return [str(Path(archive_dir) / trial_relpath(base, config, gain, s, r)) for s in speeds for r in range(repeats)]



def find_cell_trials(archive_dir: str | os.PathLike, base: str, config: int, gain: str) -> list[str]:
    """The trial files of a cell already in an archive folder, sorted (empty if none).

    Used when a campaign is re-analysed without simulating: the trials are whatever the
    archive holds for the cell, whichever speeds and repeats it was run with.
    """
    folder = Path(archive_dir) / cell_dir(base, config, gain)
    if not folder.is_dir():
        return []
    return sorted(str(p) for p in folder.glob(f"v*/r*{TRIAL_SUFFIX}") if p.is_file() and not p.name.startswith("."))



def index_cells(archive_dir: str | os.PathLike) -> dict[tuple[str, int, str], list[str]]:
    """The trials of a finalized archive by cell, from its own ``index.csv``.

    ``{(base, configuration, gain): [trial path, ...]}``, each list speed-major as
    :func:`cell_trials` orders it. Re-analysing an archive takes its cells from here, so
    the workflow asks for what the archive holds, whatever campaign configuration made it.

    Raises
    ------
    FileNotFoundError
        The folder has no ``index.csv`` (not finalized).
    ValueError
        A row whose path is not the one its base, configuration, gain, speed and repeat
        give (named), or an index without trials.
    """
    index = Path(archive_dir) / "index.csv"
    if not_regular(index) == "does not exist":
        raise FileNotFoundError(f"{archive_dir}: no index.csv (finalize it first: campaign archive finalize {archive_dir})")
    cells: dict[tuple[str, int, str], list[tuple[float, int, str]]] = {}
    with open_regular(index, "r", error=ValueError, newline="", encoding="utf-8") as fh:
        for n, row in enumerate(csv.DictReader(fh), start=2):
            try:
                base, config, gain = row["base"], int(row["config"]), row["gain"]
                speed, repeat = float(row["speed"]), int(row["repeat"])
                expected = trial_relpath(base, config, gain, speed, repeat)
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"{index}, line {n}: unreadable row ({exc})") from None
            if row["path"] != expected:
                raise ValueError(f"{index}, line {n}: path {row['path']} contradicts its row "
                                 f"(base, config, gain, speed, repeat give {expected})")
            _check_listed_trial(Path(archive_dir) / expected, expected, index)
            cells.setdefault((base, config, gain), []).append((speed, repeat, str(Path(archive_dir) / expected)))
    if not cells:
        raise ValueError(f"{index}: lists no trial")
    return {cell: [p for _, _, p in sorted(rows)] for cell, rows in sorted(cells.items())}


#: the archive's manifest (campaign.archive.MANIFEST, which loads h5py; the plan's tests check both agree)
_MANIFEST = "MANIFEST.sha256"


def check_manifest(archive_dir: str | os.PathLike, trials: Sequence[str] = ()) -> None:
    """A finalized archive's files against its manifest, before a re-analysis reads them:
    every file it lists is a regular file with the sha256 it lists, and every trial of
    ``trials`` (paths under ``archive_dir``) is listed. Reads each file once (about 1 s per
    GB); the trials' schema and content are ``campaign archive verify``'s. An archive
    without a manifest (never finalized) is not checked here.

    Raises
    ------
    InputError
        One line naming the first file that fails, what is wrong, and the command that
        lists every problem.
    """
    root = Path(archive_dir)
    manifest = root / _MANIFEST
    if not manifest.is_file():
        return
    hint = f"`campaign archive verify {archive_dir}` lists every problem"
    listed = set()
    with open_regular(manifest, "r", encoding="utf-8", errors="replace") as fh:
        lines = fh.read().splitlines()
    for n, line in enumerate(lines, 1):
        digest, sep, rel = line.partition("  ")
        if not sep or len(digest) != 64 or rel.startswith("/") or ".." in Path(rel).parts:
            raise InputError(f"{manifest}, line {n}: not '<sha256>  <path>' inside the archive; {hint}")
        listed.add(rel)
        file = root / rel
        problem = not_regular(file)
        if problem:
            raise InputError(f"{file}: listed in {_MANIFEST} but {problem}; {hint}")
        if sha256_file(file) != digest:
            raise InputError(f"{file}: sha256 differs from {_MANIFEST} (altered, corrupt or truncated); {hint}")
    for trial in trials:
        if os.path.relpath(trial, root) not in listed:
            raise InputError(f"{trial}: not in {_MANIFEST} (added after the archive was finalized); {hint}")


def _check_listed_trial(path: Path, relpath: str, index: Path) -> None:
    """A trial ``index`` lists must be a regular file of its own cell: ValueError naming a FIFO,
    socket, device or folder, or a link to another cell's trial (which would be counted
    twice). Nothing is opened; a missing file is left to the archive's verification."""
    kind = not_regular(path)
    if kind and kind != "does not exist":
        raise ValueError(f"{path}: {kind} ({index} lists it as a trial)")
    target = Path(os.path.realpath(path))     # the file itself or a folder above it may be a link
    if not kind and target.parts[-len(Path(relpath).parts):] != Path(relpath).parts:
        raise ValueError(f"{path}: resolves through a symbolic link to {target}, another cell's trial "
                         f"({index} lists it as {relpath})")


def reuse_results(results_root: str | os.PathLike, archive_dir: str | os.PathLike) -> str:
    """The results folder of re-analysing ``archive_dir``: ``<results_root>/reuse-<its folder name>``,
    never a simulated campaign's ``<results_root>/<campaign>``."""
    name = Path(os.path.abspath(archive_dir)).name
    return f"{str(results_root).rstrip('/')}/{REUSE_PREFIX}{name}"


def check_reuse_results(results_dir: str | os.PathLike, archive_dir: str | os.PathLike) -> None:
    """Refuse to mix: the results folder of a re-analysis may hold only products of the same
    archive. Its verification file (:data:`VERIFY_FILE`, written by the re-analysis) names the
    archive it checked; another archive's (two archives of the same folder name) raises
    InputError naming both. A folder without it holds nothing yet, or only an interrupted
    re-analysis's jobs of the same name."""
    stamp = Path(results_dir) / VERIFY_FILE
    if not stamp.is_file():
        return
    first = stamp.read_text(encoding="utf-8", errors="replace").split("\n", 1)[0]
    mine = os.path.abspath(archive_dir)
    if not first.startswith(f"archive {mine}:"):
        raise InputError(f"{results_dir} holds the results of re-analysing another archive ({first.split(':')[0]}), "
                         f"not {mine}: remove {results_dir} or reuse under another results_root")
