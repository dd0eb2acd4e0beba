"""Trial files in, identifications out: :func:`load_trial`, :func:`identify_file`, :func:`identify_files`, :func:`find_trials`."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from ..archive import trial_files
from ..core.errors import InputError, TrialFileError
from ..core.files import not_regular
from ..core.lazy import LazyModule
from ..core.vocabulary import misfiled
from ..model.robot import load_robot
from ..scene.schema import GroupArrays
from .options import IdentifyOptions
from .results import TrialIdentification
from .trial import identify_trial

#: imported on first use: the campaign's identification jobs read trials as plain arrays
#: (``load_trial(path, arrays=True)``) and so never pay ~0.6 s for xarray and pandas
xr = LazyModule("xarray")


# ----------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------
def _open_group(path: Path, group: str | None) -> xr.Dataset:
    try:
        with xr.open_dataset(path, engine="h5netcdf", group=group) as ds:
            return ds.load()
    except FileNotFoundError:
        raise TrialFileError(f"{path}: no such trial file") from None
    except OSError as exc:
        if group is not None and ("group" in str(exc).lower() or "not found" in str(exc).lower()):
            raise TrialFileError(f"{path}: not a trial file (no {group!r} group)") from None
        raise TrialFileError(f"{path}: not a trial file (cannot read it as NetCDF4/HDF5: {exc})") from None
    except (ValueError, KeyError, TypeError) as exc:
        raise TrialFileError(f"{path}: not a trial file ({exc})") from None


def load_trial(path, *, arrays: bool = False) -> tuple[xr.Dataset | GroupArrays, dict]:
    """Read a trial file: (its ``measured`` group, its root attributes).

    Uses :func:`campaign.archive.open_trial` (which checks the schema version, the
    channels and the content digest) when the archive module is installed, else xarray
    with the h5netcdf engine. With ``arrays=True`` the group comes as plain arrays
    (:func:`campaign.archive.open_trial_arrays`: the same values, no xarray import and
    ~10 ms less per trial), which :func:`identify_trial` takes as well.

    Raises
    ------
    TrialFileError
        The file is missing, is not a trial (not NetCDF4/HDF5, no ``measured`` group, a
        missing channel, a corrupt group), naming the file.
    """
    path = Path(path)
    kind = not_regular(path)  # a FIFO is never opened: that would wait for a writer
    if kind:
        raise TrialFileError(f"{path}: no such trial file" if kind == "does not exist" else f"{path}: {kind}")
    try:
        from ..archive import open_trial, open_trial_arrays
    except ImportError:  # pragma: no cover - the archive stage is part of the package
        open_trial = open_trial_arrays = None
    if open_trial is not None:
        try:
            measured = (open_trial_arrays if arrays else open_trial)(path, group="measured")
        except TrialFileError:
            raise
        except (OSError, ValueError, KeyError) as exc:
            raise TrialFileError(f"{path}: not a trial file ({exc})") from None
        wrong_cell = misfiled(path, measured.attrs)  # e.g. a link to another cell's trial: counted twice
        if wrong_cell:
            raise TrialFileError(wrong_cell)
        return measured, dict(measured.attrs)
    measured = _open_group(path, "measured")
    attrs = dict(_open_group(path, None).attrs)
    return measured, attrs


def identify_file(path, *, options: IdentifyOptions | None = None, robot=None) -> TrialIdentification:
    """Identify one trial file (see :func:`identify_trial`).

    Raises
    ------
    TrialFileError
        The file is not a trial or lacks a required channel (the message names both).
    """
    measured, attrs = load_trial(path, arrays=True)
    meta = dict(attrs)
    meta["path"] = str(path)
    try:
        return identify_trial(measured, robot=robot, meta=meta, options=options, where=str(path))
    except InputError as exc:
        raise TrialFileError(str(exc)) from None


def identify_files(paths: Iterable, *, options: IdentifyOptions | None = None) -> list[TrialIdentification]:
    """Identify many trial files, one robot model loaded per robot name."""

    robots: dict[str, object] = {}
    out = []
    for p in paths:
        measured, attrs = load_trial(p, arrays=True)
        name = str(attrs.get("robot") or measured.attrs.get("robot") or "")
        if not name:
            raise TrialFileError(f"{p}: no 'robot' attribute in the trial")
        if name not in robots:
            try:
                robots[name] = load_robot(name)
            except ValueError as exc:
                raise TrialFileError(f"{p}: {exc}") from None
        meta = dict(attrs)
        meta["path"] = str(p)
        try:
            out.append(identify_trial(measured, robot=robots[name], meta=meta, options=options, where=str(p)))
        except InputError as exc:
            raise TrialFileError(str(exc)) from None
    return out


def find_trials(archive) -> list[Path]:
    """The trial files of an archive folder, as every reader counts them
    (:func:`campaign.archive.trial_files`): a finalized campaign's ``index.csv``, else its
    files at the cell layout, else (a folder of loose trial files) every ``*.nc`` under it.

    Raises
    ------
    TrialFileError
        The folder does not exist or holds no trial file.
    """
    root = Path(archive)
    files = trial_files(root)
    if not files:
        raise TrialFileError(f"{root}: no trial files (*.nc) found")
    return files
