"""The campaign's vocabulary: bases, gain sets and classes, and where a trial lives in an archive.

The names come from ``config/paper.yaml`` (its ``bases``, the gain sets of its Table 1 and
the gain classes of its Tables 2-3) and ``config/rig.yaml`` (its ``structures``); code names
one of them through the constants below, never by a string of its own (``tests/project/test_layout.py``
finds such strings, ``tests/core/test_vocabulary.py`` checks the constants against the files). The
archive layout is spelled here once:

    <base>/<pose>/<gain>/v<speed m/s, 3 decimals>/r<repeat, 2 digits>.nc

with ``<pose>`` ``config<N>`` for a paper configuration struck along the paper's direction,
else ``pose-<q1>_<q2>_<q3>-n<azimuth>``. The scene, the archive, the pipeline and the
workflow's plan all build and read paths with these functions (:func:`trial_pattern` gives
the workflow's output pattern, :func:`parse_trial_relpath` reads a path back). Standard library and
PyYAML only: the workflow imports this module while Snakemake builds the DAG.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .errors import InputError
from .yamlfile import config_dir, read_yaml

__all__ = [
    "FIXED", "FLEXIBLE", "ZERO", "LOW", "HIGH", "ZERO_LOW", "STIFF_MAST", "SPACE_CLASS", "NAMES", "TRIAL_SUFFIX", "SPEED_DECIMALS", "bases", "gain_sets", "gain_classes", "check_cell", "speed_folder",
    "repeat_file", "config_folder", "layout", "custom_pose_folder", "direction_azimuth", "pose_folder", "cell_dir",
    "trial_relpath", "trial_pattern", "trial_wildcards", "parse_trial_relpath", "misfiled", "table2_columns",
    "table2_column", "figure_cells",
]

#: the bases (``config/paper.yaml`` ``bases``)
FIXED, FLEXIBLE = "fixed", "flexible"
#: the gain sets of the paper's Table 1 (``config/paper.yaml`` ``gains``)
ZERO, LOW, HIGH = "zero", "low", "high"
#: the gain class pooling Zero and Low (``config/paper.yaml`` ``gain_classes``); the other
#: class holds High alone and is named :data:`HIGH`
ZERO_LOW = "zero_low"
#: the structures a flexible base emulates (``config/rig.yaml`` ``structures``)
STIFF_MAST, SPACE_CLASS = "stiff_mast", "space_class"
#: every name above: code spells none of them as a string of its own
NAMES = frozenset({FIXED, FLEXIBLE, ZERO, LOW, HIGH, ZERO_LOW, STIFF_MAST, SPACE_CLASS})

#: suffix of a trial file
TRIAL_SUFFIX = ".nc"
#: decimals of a speed in a trial's path (``v1.500``); speeds must differ at this precision
SPEED_DECIMALS = 3
# the first letters of a speed folder, a repeat file and a paper configuration's pose folder,
# and the digits of a repeat
_SPEED_PREFIX, _REPEAT_PREFIX, _CONFIG_PREFIX = "v", "r", "config"
_REPEAT_DIGITS = 2


def _paper() -> dict:
    return read_yaml(config_dir() / "paper.yaml", copy=False)


def bases() -> tuple[str, ...]:
    """The experiment's bases, in the paper's order (``fixed``, ``flexible``)."""
    return tuple(str(b) for b in _paper()["bases"])


def gain_sets() -> tuple[str, ...]:
    """The gain sets of the paper's Table 1, in its order (``zero``, ``low``, ``high``)."""
    return tuple(str(g) for g in _paper()["gains"])


def gain_classes() -> dict[str, tuple[str, ...]]:
    """The paper's gain classes (Tables 2-3 pool Zero and Low): ``{class: gain sets}``."""
    return {str(k): tuple(str(g) for g in v) for k, v in _paper()["gain_classes"].items()}


def table2_columns() -> dict[str, str]:
    """The experiment columns of the paper's Table 2 and the gain class whose trials each
    averages: ``{column: class}`` (``m2``: ``zero_low``, ``m3``: ``high``)."""
    classes = gain_classes()
    out = {str(k): str(v) for k, v in _paper()["table2_columns"].items()}
    for name in out.values():
        if name not in classes:
            raise InputError(f"paper.yaml table2_columns: unknown gain class {name!r}; expected one of {tuple(classes)}")
    return out


def table2_column(gain: str) -> str:
    """The Table 2 column that averages the trials of gain set ``gain`` (``m2`` for ``zero``
    and ``low``, ``m3`` for ``high``)."""
    classes = gain_classes()
    for column, name in table2_columns().items():
        if gain in classes[name]:
            return column
    raise InputError(f"gain set {gain!r} is in no column of Table 2; expected one of {gain_sets()}")


def figure_cells(figure: str) -> tuple[tuple[str, int, str], ...]:
    """The sweep cells (base, configuration, gain) whose trials a single-trial figure of the
    paper shows (``fig5``, ``fig9``), configuration-major, in drawing order."""
    table = _paper()["figure_cells"]
    if figure not in table:
        raise InputError(f"unknown single-trial figure {figure!r}; expected one of {tuple(table)}")
    spec = table[figure]
    cells = tuple((str(spec["base"]), int(c), str(g)) for c in spec["configurations"] for g in spec["gains"])
    for cell in cells:
        check_cell(*cell)
    return cells


def check_cell(base: str, config: int, gain: str) -> None:
    """A sweep cell's base, paper configuration and gain set, or InputError naming the bad one."""
    if base not in bases():
        raise InputError(f"unknown base {base!r}; expected one of {bases()}")
    if gain not in gain_sets():
        raise InputError(f"unknown gain set {gain!r}; expected one of {gain_sets()}")
    if isinstance(config, bool) or not isinstance(config, int) or config < 1:
        raise InputError(f"configuration must be a paper configuration number >= 1, got {config!r}")


def speed_folder(speed: float) -> str:
    """``v<speed>``: the folder of an impact speed [m/s] (:data:`SPEED_DECIMALS` decimals)."""
    return f"{_SPEED_PREFIX}{float(speed):.{SPEED_DECIMALS}f}"


def repeat_file(repeat: int) -> str:
    """``r<NN>.nc``: the file of a repeat."""
    return f"{_REPEAT_PREFIX}{int(repeat):0{_REPEAT_DIGITS}d}{TRIAL_SUFFIX}"


def config_folder(config) -> str:
    """``config<N>``: the folder of a paper configuration struck along the paper's direction
    (``config`` may also be a wildcard such as ``"{config}"``)."""
    return f"{_CONFIG_PREFIX}{config}"


def layout(base: str, pose: str, gain: str, speed: float, repeat: int) -> tuple[str, str, str, str, str]:
    """The five parts of a trial's relative path: base, pose folder, gain set, speed folder
    and repeat file (``gain`` may be a wildcard such as ``"{gain}"``)."""
    return (str(base), str(pose), str(gain), speed_folder(speed), repeat_file(repeat))


def direction_azimuth(n) -> float:
    """Angle of a horizontal direction from -x about +z [deg, (-180, 180]] (the paper's n is 0)."""
    return math.degrees(math.atan2(-float(n[1]), -float(n[0])))


def custom_pose_folder(q_paper_deg, n) -> str:
    """``pose-<q1>_<q2>_<q3>-n<azimuth>``: a custom pose's folder (paper degrees, 3 decimals)."""
    q = "_".join(f"{float(x):.3f}" for x in q_paper_deg)
    return f"pose-{q}-n{direction_azimuth(n):.3f}"


def pose_folder(config: int, scene_json) -> str:
    """The pose folder of a stored trial, from its ``config`` and ``scene_json`` attributes:
    :func:`config_folder` for a paper configuration struck along the paper's direction, else
    :func:`custom_pose_folder` (``config-custom`` when the file states neither)."""
    scene: dict = {}
    if scene_json:
        try:
            scene = json.loads(scene_json if isinstance(scene_json, str) else bytes(scene_json).decode())
        except (ValueError, TypeError):
            scene = {}
    n = scene.get("direction")
    if config >= 1 and n is None:
        return config_folder(config)
    q = scene.get("q_paper_deg")
    if q is None:
        return "config-custom"
    return custom_pose_folder(q, _paper()["impact_direction"] if n is None else n)


def cell_dir(base: str, config: int, gain: str) -> str:
    """Relative folder of a sweep cell in an archive: ``<base>/config<N>/<gain>``."""
    check_cell(base, config, gain)
    return f"{base}/{config_folder(config)}/{gain}"


def trial_relpath(base: str, config: int, gain: str, speed: float, repeat: int) -> str:
    """Relative path of one trial of a paper configuration in an archive.

    Examples
    --------
    >>> trial_relpath("fixed", 1, "zero", 2.5, 0)
    'fixed/config1/zero/v2.500/r00.nc'
    """
    speed = float(speed)
    if not (math.isfinite(speed) and speed > 0):
        raise InputError(f"impact speed must be a finite number > 0 m/s, got {speed!r}")
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 0:
        raise InputError(f"repeat must be an integer >= 0, got {repeat!r}")
    check_cell(base, config, gain)
    return "/".join(layout(base, config_folder(config), gain, speed, repeat))


def trial_pattern() -> str:
    """:func:`trial_relpath` with a Snakemake wildcard for each part, ``{base}``, ``{config}``,
    ``{gain}``, ``{speed}`` and ``{repeat}`` (their values: :func:`trial_wildcards`)."""
    return "/".join(("{base}", config_folder("{config}"), "{gain}", _SPEED_PREFIX + "{speed}",
                     f"{_REPEAT_PREFIX}{{repeat}}{TRIAL_SUFFIX}"))


def trial_wildcards() -> dict[str, str]:
    """Regular expressions of the base, speed and repeat of :func:`trial_pattern`, as
    :func:`trial_relpath` writes them."""
    return {"base": "|".join(bases()), "speed": rf"[0-9]+\.[0-9]{{{SPEED_DECIMALS}}}",
            "repeat": f"[0-9]{{{_REPEAT_DIGITS}}}"}


def parse_trial_relpath(path: str | os.PathLike) -> dict[str, Any]:
    """The cell, speed and repeat a trial's path names (its last five parts).

    Returns ``{"base", "pose", "config", "gain", "speed", "repeat"}``: ``config`` is the
    paper configuration of a ``config<N>`` pose folder, else None. A path that is not in the
    layout as :func:`layout` writes it raises InputError naming it.

    Examples
    --------
    >>> parse_trial_relpath("archive/ci/fixed/config1/zero/v2.500/r00.nc")["speed"]
    2.5
    """
    parts = Path(path).parts[-5:]
    try:
        base, pose, gain, speed_part, repeat_part = parts
        speed = float(speed_part.removeprefix(_SPEED_PREFIX))
        repeat = int(repeat_part.removeprefix(_REPEAT_PREFIX).removesuffix(TRIAL_SUFFIX))
        exact = (layout(base, pose, gain, speed, repeat) == parts and base in bases() and gain in gain_sets()
                 and math.isfinite(speed) and speed > 0 and repeat >= 0)
    except ValueError:
        exact = False
    if not exact:
        raise InputError(f"{path}: not a trial path <base>/<pose>/<gain>/{_SPEED_PREFIX}<speed>/"
                         f"{_REPEAT_PREFIX}<repeat>{TRIAL_SUFFIX}")
    number = pose.removeprefix(_CONFIG_PREFIX)
    config = int(number) if pose.startswith(_CONFIG_PREFIX) and number.isdigit() else None
    return {"base": base, "pose": pose, "config": config, "gain": gain, "speed": speed, "repeat": repeat}


#: the attributes that place a trial in an archive, in path order
_CELL_KEYS = ("base", "config", "gain", "speed", "repeat")


def misfiled(path: str | os.PathLike, attrs: Mapping[str, Any]) -> str | None:
    """Why a trial file is not where its own attributes place it, or None.

    A file at ``.../<base>/<pose>/<gain>/v<speed>/r<NN>.nc`` must hold that cell: its
    root attributes ``base``, ``config``, ``gain``, ``speed`` (to the path's 3 decimals)
    and ``repeat``, with the pose from :func:`pose_folder`, give the same relative path. A
    file outside that layout is not checked here. The message names the file and the path
    its attributes claim, and which attributes disagree.
    """
    p = Path(path)
    tail = p.parts[-5:]
    if len(tail) < 5 or tail[0] not in bases():
        return None
    try:
        base, config, gain = str(attrs["base"]), int(attrs["config"]), str(attrs["gain"])
        speed, repeat = float(attrs["speed"]), int(attrs["repeat"])
    except (KeyError, TypeError, ValueError) as exc:
        return f"{path}: root attributes {', '.join(_CELL_KEYS)} missing or malformed ({exc})"
    folder = pose_folder(config, attrs.get("scene_json"))
    claimed = layout(base, folder, gain, speed, repeat)
    if tuple(tail) == claimed:
        return None
    differ = [f"{key}: {want.removesuffix(TRIAL_SUFFIX)} in the path, {got.removesuffix(TRIAL_SUFFIX)} in the file"
              for key, want, got in zip(_CELL_KEYS, tail, claimed, strict=True) if want != got]
    where = Path(*p.parts[:-5], *claimed)
    return f"{path}: misfiled: its attributes place it at {where} ({'; '.join(differ)})"
