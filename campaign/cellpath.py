"""Where a trial belongs in an archive, from its own attributes (standard library only).

A campaign folder files each trial at ``<base>/<pose>/<gain>/v<speed>/r<NN>.nc``
(:attr:`campaign.scene.Scene.cell`). A file copied or moved to another cell's place still
says in its root attributes which cell it holds; identification, ``archive verify`` and
``archive finalize`` compare the two with :func:`misfiled`, so a High trial filed under
Low cannot enter the Low results. Imported by the workflow's helpers while Snakemake
builds the DAG, and by the archive: it imports nothing of the package.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Mapping

__all__ = ["misfiled", "pose_folder"]

#: bases of the archive layout (campaign.scene.BASES)
BASES = ("fixed", "flexible")
#: suffix of a trial file (campaign.runner.TRIAL_SUFFIX)
SUFFIX = ".nc"


#: the attributes that place a trial in an archive, in path order
_CELL_KEYS = ("base", "config", "gain", "speed", "repeat")


def misfiled(path: str | os.PathLike, attrs: Mapping[str, Any]) -> str | None:
    """Why a trial file is not where its own attributes place it, or None.

    A file at ``.../<base>/<pose>/<gain>/v<speed>/r<NN>.nc`` must hold that cell: its
    root attributes ``base``, ``config``, ``gain``, ``speed`` (to the path's 3 decimals)
    and ``repeat`` give the same relative path; a pose that is not a paper configuration
    with the paper's direction is filed under ``pose-<q1>_<q2>_<q3>-n<azimuth>``
    (:attr:`campaign.scene.Scene.pose_tag`), read from the ``scene_json`` attribute. A file
    outside that layout is not checked. The message names the file and the path its
    attributes claim, and which attributes disagree.
    """
    p = Path(path)
    tail = p.parts[-5:]
    if len(tail) < 5 or tail[0] not in BASES:
        return None
    try:
        base, config, gain = str(attrs["base"]), int(attrs["config"]), str(attrs["gain"])
        speed, repeat = float(attrs["speed"]), int(attrs["repeat"])
    except (KeyError, TypeError, ValueError) as exc:
        return f"{path}: root attributes {', '.join(_CELL_KEYS)} missing or malformed ({exc})"
    folder = pose_folder(config, attrs.get("scene_json"))
    claimed = (base, folder, gain, f"v{speed:.3f}", f"r{repeat:02d}{SUFFIX}")
    if tuple(tail) == claimed:
        return None
    differ = [f"{key}: {want.removesuffix(SUFFIX)} in the path, {got.removesuffix(SUFFIX)} in the file"
              for key, want, got in zip(_CELL_KEYS, tail, claimed) if want != got]
    where = Path(*p.parts[:-5], *claimed)
    return f"{path}: misfiled: its attributes place it at {where} ({'; '.join(differ)})"


def pose_folder(config: int, scene_json) -> str:
    """The pose's folder, as :attr:`campaign.scene.Scene.pose_tag` names it: ``config<N>``
    for a paper configuration struck along the paper's direction, else the pose and the
    direction's azimuth from -x about +z (``config-custom`` when the file states neither)."""
    scene: dict = {}
    if scene_json:
        try:
            scene = json.loads(scene_json if isinstance(scene_json, str) else bytes(scene_json).decode())
        except (ValueError, TypeError):
            scene = {}
    n = scene.get("direction")
    if config >= 1 and n is None:
        return f"config{config}"
    q = scene.get("q_paper_deg")
    if q is None:
        return "config-custom"
    n = (-1.0, 0.0, 0.0) if n is None else n
    azimuth = math.degrees(math.atan2(-float(n[1]), -float(n[0])))
    return "pose-" + "_".join(f"{float(x):.3f}" for x in q) + f"-n{azimuth:.3f}"
