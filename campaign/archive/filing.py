"""Cross-checks of how a campaign folder files its trials (``archive verify``, ``finalize``).

Every trial file says in its root attributes which cell it holds (``base``, ``config``,
``gain``, ``speed``, ``repeat``, ``seed``, and the full scene in ``scene_json``), and each
group carries a digest of its content. A file moved or copied to another cell's place
keeps all of them, and re-hashing the manifest does not hide it; this module finds:

* a file whose attributes place it elsewhere (:func:`campaign.core.vocabulary.misfiled`),
* root attributes that contradict the file's own ``scene_json``,
* two files holding the same cell, or the same measured content,
* an ``index.csv`` row that contradicts the file it lists.

Each finding names the file and the other path involved (where the file belongs, the
other copy, the index). The archive turns them into its problems (verify) or refuses to
finalize on them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import h5py

from ..core.files import not_regular
from ..core.vocabulary import misfiled, pose_folder

__all__ = ["CELL_FIELDS", "filing_problems", "group_digests"]

#: root attributes that identify a trial's cell and seed, as index.csv lists them
CELL_FIELDS = ("base", "config", "gain", "speed", "repeat", "seed")
_KINDS = {"base": str, "config": int, "gain": str, "speed": float, "repeat": int, "seed": int}


def _same(key: str, a: Any, b: Any) -> bool:
    """Equal as the key's type (speeds to the trial path's 1 mm/s)."""
    try:
        if key == "speed":
            return f"{float(a):.3f}" == f"{float(b):.3f}"
        return _KINDS.get(key, str)(a) == _KINDS.get(key, str)(b)
    except (TypeError, ValueError):
        return False


def group_digests(file: Path, groups: Sequence[str] = ("measured", "truth")) -> tuple[str, ...] | None:
    """The stored ``content_sha256`` of each group (None if a group or its digest is missing,
    or ``file`` is not a regular file)."""
    if not_regular(file):
        return None
    try:
        with h5py.File(file, "r") as f:
            out = []
            for g in groups:
                value = f[g].attrs["content_sha256"]
                out.append(value.decode() if isinstance(value, bytes) else str(value))
            return tuple(out)
    except (OSError, KeyError):
        return None


def filing_problems(campaign: Path, records: Iterable[Mapping[str, Any]],
                    index_rows: Sequence[Mapping[str, str]] | None = None) -> list[tuple[str, str]]:
    """Misfiled, duplicated and mis-indexed trials of a campaign folder.

    Parameters
    ----------
    campaign : pathlib.Path
        The campaign folder.
    records : iterable of mapping
        One per readable trial file: ``path`` (relative to ``campaign``), the root
        attributes of :data:`CELL_FIELDS` and ``scene_json``.
    index_rows : sequence of mapping, optional
        The rows of the folder's ``index.csv``, to check against the files.

    Returns
    -------
    list of (str, str)
        ``(file relative to the campaign, message)``, in path order.
    """
    records = sorted(records, key=lambda r: r["path"])
    problems: list[tuple[str, str]] = []
    by_cell: dict[tuple, str] = {}
    by_content: dict[tuple[str, ...], str] = {}
    for rec in records:
        rel = rec["path"]
        wrong = misfiled(rel, rec)
        if wrong:
            problems.append((rel, wrong.removeprefix(f"{rel}: ")))
        try:
            scene = json.loads(rec["scene_json"])
        except (TypeError, ValueError, KeyError):
            scene = None
        if isinstance(scene, dict):
            differ = [f"{key} {rec[key]!r} vs {scene.get(key)!r}" for key in CELL_FIELDS
                      if not _same(key, rec[key], scene.get(key))]
            if differ:
                problems.append((rel, "root attributes contradict the file's own scene_json: " + ", ".join(differ)))
        # the pose folder, not the configuration number: every custom pose has config 0
        cell = (str(rec["base"]), pose_folder(int(rec["config"]), rec.get("scene_json")), str(rec["gain"]),
                f"{float(rec['speed']):.3f}", int(rec["repeat"]))
        if cell in by_cell:
            problems.append((rel, f"holds the same cell ({'/'.join(map(str, cell))}) as {by_cell[cell]}: "
                                  "one of the two is a copy"))
        else:
            by_cell[cell] = rel
        digests = group_digests(campaign / rel)
        if digests is not None:
            if digests in by_content:
                problems.append((rel, f"same content (group digests) as {by_content[digests]}: a duplicate trial"))
            else:
                by_content[digests] = rel
    if index_rows is not None:
        files = {r["path"]: r for r in records}
        for n, row in enumerate(index_rows, start=2):
            rec = files.get(row.get("path", ""))
            if rec is None:
                continue  # a row without its file is reported by the manifest and index checks
            differ = [f"{key} {row.get(key)!r} in index.csv, {rec[key]!r} in the file" for key in CELL_FIELDS
                      if key in row and not _same(key, row[key], rec[key])]
            if differ:
                problems.append((rec["path"], f"index.csv line {n} contradicts the file: " + "; ".join(differ)))
    return problems
