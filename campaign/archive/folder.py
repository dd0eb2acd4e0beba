"""Campaign folders: trial records, listing and filtering, and whole-campaign datasets."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import h5py
import numpy as np

from ..core.errors import InputError, TrialFileError
from ..core.files import check_regular_file, not_regular, open_regular
from ..core.lazy import LazyModule
from ..core.progress import progress
from ..core.vocabulary import bases, gain_sets
from ..model.paper import impact_direction
from ..scene.schema import MEASURED, SCHEMA_VERSION, TRUTH
from .decode import open_trial, plain_value
from .fileformat import (
    CELL_KEYS,
    FILTER_KEYS,
    GROUPS,
    INDEX,
    INDEX_COLUMNS,
    JOBS,
    MANIFEST,
    README,
    STRUCTURAL_ATTRS,
    TEMP_FILE_RE,
    TRIAL_SUFFIX,
)
from .machine import NOT_RECORDED, platform_summary
from .read import inspect_trial

#: xarray, imported on first use (:mod:`campaign.core.lazy`): jobs that only check or index
#: trial files (``finalize_archive``, ``verify``) never need it
xr: Any = LazyModule("xarray")


# ---------------------------------------------------------------------------------------
# campaign folders
# ---------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class TrialRecord:
    """One trial of a campaign folder, as listed by :func:`list_trials` and ``index.csv``.

    Attributes
    ----------
    path : str
        Trial file relative to the campaign folder (``fixed/config1/zero/v1.500/r00.nc``).
    file : pathlib.Path
        The trial file itself.
    base, config, gain, speed, repeat, seed
        The scene's cell and RNG seed.
    scene : str
        Scene preset name (``default``, ``ideal``).
    scene_sha256, robot, schema_version : str
    scene_json : str
        The full scene (``Scene.from_json``).
    computing_platform : str
        The platform that computed the trial
        (:func:`campaign.archive.machine.platform_summary`; ``"platform not recorded"`` in
        files written before trials recorded it).
    """

    path: str
    file: Path
    base: str
    config: int
    gain: str
    speed: float
    repeat: int
    seed: int
    scene: str
    scene_sha256: str
    robot: str
    schema_version: str
    scene_json: str = dataclasses.field(repr=False)
    computing_platform: str = dataclasses.field(default=NOT_RECORDED, repr=False)

    @property
    def q_paper_deg(self) -> str:
        """The arm pose in the paper's joint angles [deg], space-separated."""
        return " ".join(f"{float(x):g}" for x in json.loads(self.scene_json)["q_paper_deg"])

    @property
    def direction(self) -> str:
        """The unit impact direction n (base frame), space-separated; the paper's when the
        scene names none."""
        n = json.loads(self.scene_json).get("direction")
        if n is None:
            n = impact_direction()
        return " ".join(f"{float(x):.9g}" for x in n)

    def row(self) -> dict[str, Any]:
        """The ``index.csv`` row."""
        return {k: getattr(self, k) for k in INDEX_COLUMNS}


def campaign_folder(campaign_dir: str | os.PathLike) -> Path:
    path = Path(campaign_dir)
    if not path.is_dir():
        raise InputError(f"{path} is not a campaign folder: no such directory")
    if not (path / MANIFEST).is_file() and not any(layout_trial_files(path)):
        raise InputError(f"{path} is not a campaign folder: it has no {MANIFEST} and no trial files "
                         f"(<base>/config<N>/<gain>/v<speed>/r<NN>{TRIAL_SUFFIX})")
    return path


def layout_trial_files(campaign: Path) -> Iterator[Path]:
    """Trial files at the Scene.cell layout (``<base>/<pose>/<gain>/v<speed>/<file>.nc``), sorted."""
    for base in bases():
        yield from sorted((campaign / base).glob(f"*/*/*/*{TRIAL_SUFFIX}"))


def is_campaign_file(rel: str) -> bool:
    """A file of a campaign folder's own: its index, README or manifest, or a job manifest
    of the workflow (:mod:`campaign.archive.jobs`)."""
    parts = rel.split("/")
    return rel in (INDEX, README, MANIFEST) or (parts[0] == JOBS and rel.endswith(".json"))


def outside_layout(campaign_dir: str | os.PathLike) -> list[str]:
    """Files of a campaign folder that are neither a trial at the cell layout nor one of the
    folder's own files (:data:`INDEX`, :data:`README`, :data:`MANIFEST`, ``.jobs/*.json``), nor
    a temporary file of an interrupted write: a copy in a folder of its own, notes, anything
    a reader would not count. Relative paths, sorted."""
    campaign = Path(campaign_dir)
    trials = {relative_name(campaign, f) for f in layout_trial_files(campaign)}
    out = []
    for file in sorted(campaign.rglob("*")):
        if file.is_dir():
            continue
        rel = relative_name(campaign, file)
        if rel not in trials and not is_campaign_file(rel) and not TEMP_FILE_RE.match(file.name):
            out.append(rel)
    return out


def trial_files(campaign_dir: str | os.PathLike) -> list[Path]:
    """The trials of a folder, as every reader takes them (identification, the lambda fits,
    the tables, ``archive ls``, the workflow's reuse), so that they all count the same:

    * a finalized campaign folder: the trials its ``index.csv`` lists, in its order;
    * a campaign folder not finalized: its trial files at the cell layout, sorted;
    * any other folder: every ``*.nc`` file under it, sorted (loose trial files).

    A file outside the layout is never a trial of a campaign folder: ``archive finalize``
    refuses it and ``archive verify`` names it.

    Raises
    ------
    TrialFileError
        The folder does not exist, or an ``index.csv`` without a ``path`` column.
    """
    root = Path(campaign_dir)
    if not root.is_dir():
        raise TrialFileError(f"{root}: not an archive folder")
    index = root / INDEX
    kind = not_regular(index)
    if kind and kind != "does not exist":     # never taken for "not finalized": say what it is
        raise TrialFileError(f"{index}: {kind}; a campaign's index must be a regular file")
    if not kind:
        try:
            with open_regular(index, "r", error=TrialFileError, newline="", encoding="utf-8") as fh:
                return _readable_trials([root / row["path"] for row in csv.DictReader(fh)], listed=True)
        except (KeyError, csv.Error, UnicodeDecodeError) as exc:
            raise TrialFileError(f"{index}: unreadable ({exc})") from None
    at_layout = list(layout_trial_files(root))
    if at_layout:
        return _readable_trials(at_layout)
    return _readable_trials(sorted(p for p in root.rglob(f"*{TRIAL_SUFFIX}") if not p.is_dir()))


def _readable_trials(files: list[Path], *, listed: bool = False) -> list[Path]:
    """``files``, each a regular file (a FIFO, socket or device is never opened: that would
    wait for a writer) that is not a symbolic link out of its own folder (a trial that
    points at another cell's file would be counted twice).

    Raises
    ------
    TrialFileError
        Naming the first file that is not so; with ``listed`` (the index's trials) a missing
        file passes here and is reported by the reader that opens it.
    """
    for file in files:
        check_regular_file(file, error=TrialFileError, missing_ok=listed)
        if file.is_symlink() and file.resolve().parent != file.parent.resolve():
            raise TrialFileError(f"{file}: is a symbolic link to {file.resolve()}, outside its own folder; "
                                 "a trial is a file of its own cell (replace the link by the trial)")
    return files


def relative_name(campaign: Path, file: Path) -> str:
    return file.relative_to(campaign).as_posix()


def read_record(campaign: Path, file: Path) -> TrialRecord:
    """A trial's record from its root attributes (h5py: a few ms, no data read)."""
    check_regular_file(file, error=TrialFileError)
    try:
        with h5py.File(file, "r") as f:
            attrs = {k: plain_value(f.attrs[k]) for k in f.attrs.keys() if k not in STRUCTURAL_ATTRS}
    except Exception as exc:  # noqa: BLE001 - see _CORRUPT
        raise TrialFileError(f"{file}: not a readable HDF5 file (truncated or corrupt): {exc}") from exc
    return record_from_attrs(campaign, file, attrs)


def record_from_attrs(campaign: Path, file: Path, attrs: Mapping[str, Any]) -> TrialRecord:
    """A trial's record from root attributes (as stored, or as the writer is about to store them)."""
    try:
        scene = json.loads(attrs["scene_json"])
        return TrialRecord(
            path=relative_name(campaign, file), file=file, base=str(attrs["base"]), config=int(attrs["config"]),
            gain=str(attrs["gain"]), speed=float(attrs["speed"]), repeat=int(attrs["repeat"]),
            seed=int(attrs["seed"]), scene=str(scene["name"]), scene_sha256=str(attrs["scene_sha256"]),
            robot=str(attrs["robot"]), schema_version=str(attrs["schema_version"]),
            scene_json=str(attrs["scene_json"]), computing_platform=platform_summary(attrs))
    except (KeyError, TypeError, ValueError) as exc:
        raise TrialFileError(f"{file}: not a campaign trial file (root attribute {exc} missing or malformed)") from exc


def _filter_values(key: str, value: Any) -> set:
    """A filter's accepted values, read as the key's type (a list, or "a,b" from the CLI)."""
    kind = FILTER_KEYS[key]
    items = value.split(",") if isinstance(value, str) else (
        list(value) if isinstance(value, (list, tuple, set, frozenset)) else [value])
    out = set()
    for item in items:
        try:
            v = kind(item.strip() if isinstance(item, str) else item)
        except (TypeError, ValueError):
            raise InputError(f"filter {key}={item!r}: expected {kind.__name__}") from None
        # speeds are matched at the precision of the cell path (v1.500)
        out.add(f"{v:.3f}" if key == "speed" else v)
    return out


def list_trials(campaign_dir: str | os.PathLike, **filters: Any) -> list[TrialRecord]:
    """The trials of a campaign folder (:func:`trial_files`: the ones its ``index.csv`` lists
    once it is finalized, else the files at the cell layout), optionally filtered, in path order.

    Parameters
    ----------
    campaign_dir : path-like
        A campaign folder (``archive/<name>/``).
    **filters
        ``key=value`` with a key of :data:`FILTER_KEYS` (base, config, gain, speed, repeat,
        seed, scene, scene_sha256, robot). A value may be a list (any of) or a
        comma-separated string; speeds match to 1 mm/s (the cell path's precision).

    Returns
    -------
    list of TrialRecord

    Raises
    ------
    InputError
        Not a campaign folder, or an unknown filter key or unreadable filter value.
    TrialFileError
        A trial file whose root attributes cannot be read (named).
    """
    unknown = sorted(set(filters) - set(FILTER_KEYS))
    if unknown:
        raise InputError(f"unknown filter key(s) {', '.join(map(repr, unknown))}; known keys: {', '.join(FILTER_KEYS)}")
    wanted = {k: _filter_values(k, v) for k, v in filters.items()}
    campaign = campaign_folder(campaign_dir)
    out = []
    for file in progress(trial_files(campaign), desc="read"):
        rec = read_record(campaign, file)
        if all((f"{rec.speed:.3f}" if k == "speed" else getattr(rec, k)) in vals for k, vals in wanted.items()):
            out.append(rec)
    return out


def _resolve_scalar(spec: str) -> tuple[str, Any]:
    """``"truth/v_a_pre"`` or ``"hammer_mass_eff"`` -> (group, schema Var) of a scalar variable."""
    if "/" in spec:
        group, name = spec.split("/", 1)
        if group not in GROUPS:
            raise InputError(f"variable {spec!r}: unknown group {group!r}; expected one of {list(GROUPS)}")
        table = {"measured": MEASURED, "truth": TRUTH}[group]
        found = [(group, v) for v in table if v.name == name]
    else:
        found = [(g, v) for g, table in (("measured", MEASURED), ("truth", TRUTH)) for v in table if v.name == spec]
    if not found:
        raise InputError(f"variable {spec!r} is not in schema {SCHEMA_VERSION}")
    if len(found) > 1:
        raise InputError(f"variable {spec!r} is in both groups; write measured/{spec} or truth/{spec}")
    group, var = found[0]
    if var.dims:
        raise InputError(f"open_campaign collects scalar per-trial variables; {group}/{var.name} has dims "
                         f"{var.dims}: open it per trial with open_trial")
    return group, var


def open_campaign(campaign_dir: str | os.PathLike, *, variables: Sequence[str] = (),
                  func: Callable[[xr.Dataset], Mapping[str, Any]] | None = None, group: str = "measured",
                  **filters: Any) -> xr.Dataset:
    """Per-trial results of a campaign as one labelled Dataset over (base, config, gain, speed, repeat).

    Parameters
    ----------
    campaign_dir : path-like
        A campaign folder.
    variables : sequence of str
        Scalar schema variables to collect, ``"group/name"`` or a bare name found in one
        group (``"hammer_mass_eff"``, ``"truth/v_a_pre"``, ``"truth/impulse"``). Read with
        h5py and checked against each group's ``content_sha256``.
    func : callable, optional
        Called with each trial's ``group`` Dataset (:func:`open_trial`); returns a mapping of
        result name to a scalar (number or str) or a 0-d DataArray (its attributes, e.g.
        units, are kept). This is how identification reruns on an archive without
        re-simulating.
    group : {"measured", "truth"}
        The group ``func`` receives.
    **filters
        As :func:`list_trials`.

    Returns
    -------
    xarray.Dataset
        Dims (base, config, gain, speed, repeat) over the values present; cells without a
        trial hold NaN (numbers) or "" (strings). Always has ``path`` (the trial file relative
        to the campaign folder); schema variables carry their units and long_name.
    """
    if group not in GROUPS:
        raise InputError(f"unknown trial group {group!r}; expected one of {list(GROUPS)}")
    if isinstance(variables, str):
        variables = [variables]
    resolved = list(dict.fromkeys(_resolve_scalar(v) for v in variables))
    records = list_trials(campaign_dir, **filters)
    if not records:
        raise InputError(f"{campaign_dir}: no trial matches the filters {filters}")
    want: dict[str, list[str]] = {}
    for g, var in resolved:
        want.setdefault(g, []).append(var.name)
    rows = []
    attrs: dict[str, dict[str, Any]] = {}
    for rec in records:
        row: dict[str, Any] = {k: getattr(rec, k) for k in CELL_KEYS}
        row["path"] = rec.path
        if resolved:
            _, problems, values = inspect_trial(rec.file, groups=tuple(want), want=want)
            if problems:
                raise TrialFileError(f"{rec.file}: {problems[0]}")
            for g, var in resolved:
                # a variable the trial's base does not carry (base_mass of a fixed base) stays NaN
                value = values.get(f"{g}/{var.name}")
                row[var.name] = float(value) if value is not None else math.nan
                attrs[var.name] = {"units": var.units, "long_name": var.long_name}
        if func is not None:
            result = func(open_trial(rec.file, group=group))
            if not isinstance(result, Mapping):
                raise InputError(f"open_campaign func must return a mapping of name to scalar, got "
                                 f"{type(result).__name__} for {rec.path}")
            for key, value in result.items():
                if key in row:
                    raise InputError(f"open_campaign func returned {key!r}, which clashes with a cell key or variable")
                row[key] = value
        rows.append(row)
    ds = to_cell_dataset(rows, attrs=attrs)
    ds.attrs.update(campaign=Path(campaign_dir).resolve().name, schema_version=SCHEMA_VERSION, trials=len(records))
    return ds


_CELL_TYPES = {"base": str, "config": int, "gain": str, "speed": float, "repeat": int}
_CELL_ATTRS = {
    "base": {"long_name": "base of the arm (fixed or flexible)"},
    "config": {"long_name": "arm configuration (paper Table 1; 0 = custom pose)"},
    "gain": {"long_name": "controller gain set (paper Table 1)"},
    "speed": {"units": "m s-1", "long_name": "impact speed of the hammer along n"},
    "repeat": {"long_name": "repeat index"},
}


def _coord_order(key: str, values: set) -> list:
    known = {"base": bases(), "gain": gain_sets()}.get(key)
    if known:
        return [v for v in known if v in values] + sorted(v for v in values if v not in known)
    return sorted(values)


def to_cell_dataset(records: Iterable[Mapping[str, Any]] | str | os.PathLike | Any, *,
                    attrs: Mapping[str, Mapping[str, Any]] | None = None) -> xr.Dataset:
    """Per-trial records -> a labelled Dataset with dims (base, config, gain, speed, repeat).

    Parameters
    ----------
    records : iterable of mapping, pandas.DataFrame, or path to a CSV file
        One record per trial with the cell keys ``base``, ``config``, ``gain``, ``speed``,
        ``repeat`` and any result columns (numbers, strings or 0-d DataArrays), e.g. the
        identified ``m_eff`` and ``e`` of each trial.
    attrs : mapping, optional
        Attributes per result column (``{"m_eff": {"units": "kg", "long_name": ...}}``).

    Returns
    -------
    xarray.Dataset
        Numeric columns as float64 with NaN in cells without a record (int64 if every cell is
        filled), strings with "" there.

    Raises
    ------
    InputError
        A record without a cell key, a cell value of the wrong type, or two records of the
        same cell (named).
    """
    if isinstance(records, (str, os.PathLike)):
        import pandas as pd  # xarray's own dependency; it reads numbers back as numbers

        if not Path(records).is_file():
            raise InputError(f"results table {records} does not exist")
        records = pd.read_csv(records).to_dict("records")
    elif hasattr(records, "to_dict") and hasattr(records, "columns"):
        records = records.to_dict("records")
    rows = list(records)
    if not rows:
        raise InputError("to_cell_dataset needs at least one record")
    cells = []
    columns: dict[str, None] = {}
    col_attrs: dict[str, dict[str, Any]] = {k: dict(v) for k, v in (attrs or {}).items()}
    for i, row in enumerate(rows):
        missing = [k for k in CELL_KEYS if k not in row]
        if missing:
            raise InputError(f"record {i} has no {', '.join(missing)} (each record needs {', '.join(CELL_KEYS)})")
        try:
            cell = tuple(_CELL_TYPES[k](row[k]) for k in CELL_KEYS)
        except (TypeError, ValueError) as exc:
            raise InputError(f"record {i}: bad cell value ({exc})") from None
        cells.append(cell)
        for k in row:
            if k not in CELL_KEYS:
                columns.setdefault(k)
    seen: dict[tuple, int] = {}
    for i, cell in enumerate(cells):
        if cell in seen:
            raise InputError(f"records {seen[cell]} and {i} are the same cell {dict(zip(CELL_KEYS, cell))}")
        seen[cell] = i
    coords = {k: _coord_order(k, {c[j] for c in cells}) for j, k in enumerate(CELL_KEYS)}
    index = [{v: n for n, v in enumerate(coords[k])} for k in CELL_KEYS]
    shape = tuple(len(coords[k]) for k in CELL_KEYS)
    positions = [tuple(index[j][c[j]] for j in range(len(CELL_KEYS))) for c in cells]
    data_vars = {}
    for col in columns:
        values = []
        for row in rows:
            v = row.get(col)
            if isinstance(v, xr.DataArray):
                col_attrs.setdefault(col, dict(v.attrs))
                v = v.item()
            values.append(v)
        present = [v for v in values if v is not None]
        if present and all(isinstance(v, str) for v in present):
            arr = np.full(shape, "", dtype=object)
        elif len(present) == len(cells) == math.prod(shape) and all(
                isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in present):
            arr = np.zeros(shape, dtype=np.int64)
        else:
            arr = np.full(shape, np.nan)
        for i, (pos, v) in enumerate(zip(positions, values)):
            if v is None:
                continue
            try:
                arr[pos] = v
            except (TypeError, ValueError):
                raise InputError(f"column {col!r}: value {v!r} of cell {dict(zip(CELL_KEYS, cells[i]))} "
                                 "is neither a number nor a string (mixed types in one column?)") from None
        if arr.dtype == object:
            arr = arr.astype(str)
        data_vars[col] = xr.Variable(CELL_KEYS, arr, col_attrs.get(col, {}))
    coord_vars = {k: xr.Variable(k, np.asarray(coords[k]), _CELL_ATTRS[k]) for k in CELL_KEYS}
    return xr.Dataset(data_vars, coords=coord_vars)
