"""Files the campaign writes: output paths checked before any work, and atomic writes.

Every command and job that writes goes through this module, so the rules hold everywhere:

* **Before the work** (:func:`check_output_file`, :func:`check_output_dir`): a destination
  that exists must be a regular file (a device, a FIFO or a socket is refused, never
  replaced), a file is not a folder and a folder not a file, the nearest existing folder is
  writable, and its file system has the free space the output needs. A refusal is an
  :class:`~campaign.core.errors.InputError` naming the option and the path.
* **While writing** (:func:`write_atomic`, :func:`replace_atomically`): the bytes go to a
  temporary file beside the destination, which is renamed into place, so a reader never sees
  half a file. A failure part-way (a full disk, an I/O error) removes the temporary file and
  raises :class:`~campaign.core.errors.WriteError` naming the destination and the free space
  left; nothing is left under the final or the temporary name.
"""

from __future__ import annotations

import datetime as _dt
import errno
import hashlib
import os
import re
import secrets
import shutil
import stat
from collections.abc import Callable, Iterable
from pathlib import Path

from .errors import InputError, TrialFileError, WriteError

__all__ = ["sha256_file", "not_regular", "check_regular_file", "open_regular", "write_atomic", "replace_atomically", "write_file", "check_output_file", "check_output_dir", "free_bytes",
           "format_bytes", "source_date_epoch", "MIN_FREE_BYTES"]

#: the free space any output needs before work starts (a table, a JSON file, a figure); an
#: output that needs more (trial files) asks for its own estimate
MIN_FREE_BYTES = 64 * 1024

#: errno values of a full file system (disk or quota)
_FULL = (errno.ENOSPC, errno.EDQUOT)


# ---------------------------------------------------------------------------------------
# the state of the file system
# ---------------------------------------------------------------------------------------
def _existing_ancestor(path: Path) -> Path:
    """``path`` or the nearest of its ancestors that exists."""
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def free_bytes(path: str | os.PathLike) -> int | None:
    """Free space [bytes] for an unprivileged user on the file system ``path`` is (or would be) on;
    None when it cannot be told."""
    try:
        return shutil.disk_usage(_existing_ancestor(Path(path).absolute())).free
    except OSError:
        return None


def format_bytes(n: int | None) -> str:
    """``n`` bytes as a short decimal size (``"0 B"``, ``"12.3 kB"``, ``"2.9 MB"``)."""
    if n is None:
        return "unknown"
    value = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if value < 1000 or unit == "TB":
            return f"{int(value)} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1000
    raise AssertionError("unreachable")


def _kind(mode: int) -> str:
    """What a file of mode ``mode`` that is not a regular file or a folder is."""
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _special(path: Path) -> str | None:
    """What ``path`` is when it exists and is neither a regular file nor a folder, else None
    (a symbolic link is followed: the file it names would be the one written over)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return _kind(mode)


def not_regular(path: str | os.PathLike) -> str | None:
    """Why a reader must not open ``path``: ``"is a FIFO, not a regular file"`` (a folder, a
    device, a socket alike), ``"does not exist"``; None for a regular file. A symbolic link is
    followed; nothing is opened (opening a FIFO waits for a writer)."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "does not exist"
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return None
    return f"is {'a folder' if stat.S_ISDIR(mode) else _kind(mode)}, not a regular file"


def check_regular_file(path: str | os.PathLike, *, what: str = "", error: type[Exception] = InputError,
                       missing_ok: bool = False) -> Path:
    """``path`` as a :class:`~pathlib.Path` when it is a regular file a reader may open.

    Raises
    ------
    InputError
        (or ``error``) One line, ``"<what> <path>: is a FIFO, not a regular file"``: a folder,
        FIFO, socket or device, or (unless ``missing_ok``) a missing file.
    """
    problem = not_regular(path)
    if problem and not (missing_ok and problem == "does not exist"):
        raise error(f"{what + ' ' if what else ''}{path}: {problem}")
    return Path(path)


def open_regular(path: str | os.PathLike, mode: str = "rb", *, what: str = "",
                 error: type[Exception] = InputError, missing_ok: bool = False, **kwargs):
    """``open(path, mode)`` for reading, refusing (as :func:`check_regular_file`) anything but
    a regular file without ever blocking: the file is opened non-blocking and its type is
    checked on the open descriptor, so a FIFO put in its place after a check cannot hang it.
    With ``missing_ok`` a missing file raises :class:`FileNotFoundError`, as :func:`open` does."""
    check_regular_file(path, what=what, error=error, missing_ok=missing_ok)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        if missing_ok and isinstance(exc, FileNotFoundError):
            raise
        raise error(f"{what + ' ' if what else ''}{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        st_mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(st_mode):
            raise error(f"{what + ' ' if what else ''}{path}: is {_kind(st_mode)}, not a regular file")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, mode, **kwargs)
    except BaseException:
        os.close(fd)
        raise


# ---------------------------------------------------------------------------------------
# before the work
# ---------------------------------------------------------------------------------------
def check_output_file(path: str | os.PathLike, *, option: str = "--out", need: int = MIN_FREE_BYTES) -> Path:
    """A file that can be written: a regular file or nothing yet, its folder a folder (or
    creatable) and writable, with at least ``need`` bytes free on its file system.

    Raises
    ------
    InputError
        Naming ``option`` and ``path``: a path that names a folder (an existing one, or one
        written with a trailing slash, ``x.nc/``), a device, FIFO or socket, a file in the
        way of its folder, a folder or file that is not writable, too little free space.
    """
    folder = _names_a_folder(path)
    if folder:
        raise InputError(f"{option} {path}: {folder}, which names a folder; name a file")
    out = Path(path)
    if out.is_dir():
        raise InputError(f"{option} {path}: is a folder; name a file")
    special = _special(out)
    if special:
        raise InputError(f"{option} {path}: is {special}, not a regular file; name a file to write")
    _check_parent(out, option=option, path=path)
    if out.exists() and not os.access(out, os.W_OK):
        raise InputError(f"{option} {path}: the file is not writable")
    _check_free(out, need=need, option=option, path=path)
    return out


def check_output_dir(path: str | os.PathLike, *, option: str = "--out", files: Iterable[str] = (),
                     need: int = MIN_FREE_BYTES) -> Path:
    """A folder that can be written into (created if missing): not an existing file, each of
    ``files`` (paths relative to it) a regular file or nothing yet, under folders or nothing
    yet, with at least ``need`` bytes free on its file system.

    Raises
    ------
    InputError
        Naming ``option`` and the path at fault.
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise InputError(f"{option} {path}: is {_special(out) or 'a file'}; name a folder (created if missing)")
    if out.is_dir():
        if not os.access(out, os.W_OK | os.X_OK):
            raise InputError(f"{option} {path}: the folder is not writable")
        for name in files:
            inside = out / name
            if inside.is_dir():
                raise InputError(f"{option} {path}: {inside} is a folder; the command writes a file there")
            special = _special(inside)
            if special:
                raise InputError(f"{option} {path}: {inside} is {special}, not a regular file; "
                                 "the command would write a file there")
            folder = _existing_ancestor(inside.parent)
            if not folder.is_dir():
                raise InputError(f"{option} {path}: {folder} is a file, not a folder")
    else:
        _check_parent(out, option=option, path=path)
    _check_free(out, need=need, option=option, path=path)
    return out


def _names_a_folder(path: str | os.PathLike) -> str:
    """Why ``path``, as typed, names a folder whatever exists: it ends with a path separator
    or in ``.`` or ``..`` (:class:`~pathlib.Path` drops a trailing slash, so the text decides);
    ``""`` when it does not."""
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if text.endswith((os.sep, os.altsep) if os.altsep else os.sep):
        return "ends with a slash"
    last = os.path.basename(text)
    return f"ends in {last!r}" if last in (".", "..") else ""


def _check_parent(out: Path, *, option: str, path) -> None:
    """The nearest existing ancestor of ``out`` is a writable folder."""
    parent = _existing_ancestor(out.parent)
    if not parent.is_dir():
        raise InputError(f"{option} {path}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: the folder {parent} is not writable")


def _check_free(out: Path, *, need: int, option: str, path) -> None:
    free = free_bytes(out)
    if free is not None and free < need:
        raise InputError(f"{option} {path}: {format_bytes(free)} free on its file system, about "
                         f"{format_bytes(need)} needed")


# ---------------------------------------------------------------------------------------
# while writing
# ---------------------------------------------------------------------------------------
def _write_all(fd: int, data: bytes | memoryview) -> None:
    """Write every byte of ``data`` to ``fd`` (``os.write`` may write fewer than asked)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def write_file(path: str | os.PathLike, data: bytes, *, fsync: bool = False) -> None:
    """Write ``data`` into ``path`` (created or emptied first), not atomically: the ``write``
    of :func:`replace_atomically`. ``fsync`` flushes it to the disk before returning."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_CLOEXEC", 0), 0o666)
    try:
        _write_all(fd, data)
        if fsync:
            os.fsync(fd)
    finally:
        os.close(fd)


def _temp_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")


def _glob_escape(name: str) -> str:
    """``name`` with glob metacharacters escaped (``[``, ``*``, ``?``)."""
    return re.sub(r"([\[\]*?])", r"[\1]", name)


def replace_atomically(path: str | os.PathLike, write: Callable[[Path], None], *, clear_stale: bool = False) -> Path:
    """Run ``write(tmp)`` on a new temporary file beside ``path``, then rename it over ``path``.

    Parameters
    ----------
    path : path-like
        The destination; its folder is created.
    write : callable
        Writes the whole content into the path it is given (which does not exist yet).
    clear_stale : bool
        Remove the temporary files an earlier, killed writer of ``path`` left behind first;
        only where there is one writer per file (a campaign's trial files).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    InputError
        ``path`` exists and is not a regular file (a folder, a device, a FIFO): it is left
        as it is.
    WriteError
        Writing or renaming failed (a full disk, an I/O error): the temporary file is removed
        and nothing is left under either name; the message names ``path`` and the free space.
    """
    out = Path(path)
    special = "a folder" if out.is_dir() else _special(out)
    if special:
        raise InputError(f"{path}: is {special}, not a regular file; refusing to replace it")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _write_error(out, exc) from None
    if clear_stale:
        for stale in out.parent.glob(f".{_glob_escape(out.name)}.*.tmp"):
            stale.unlink(missing_ok=True)
    tmp = _temp_name(out)
    try:
        write(tmp)
        os.replace(tmp, out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, WriteError):
            raise
        raise _write_error(out, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out


def _write_error(path: Path, exc: OSError) -> WriteError:
    """The one-line error of a write to ``path`` that failed with ``exc``."""
    free = free_bytes(path)
    if exc.errno in _FULL:
        what = "no space left on device" if exc.errno == errno.ENOSPC else "disk quota exceeded"
        text = f"{path}: {what} while writing it ({format_bytes(free)} free); not written"
    else:
        text = f"{path}: writing it failed: {exc.strerror or exc} ({format_bytes(free)} free); not written"
    return WriteError(exc.errno, text)


def write_atomic(path: str | os.PathLike, data: str | bytes, *, fsync: bool = False,
                 clear_stale: bool = False) -> Path:
    """Write ``data`` (text as UTF-8) to a temporary file beside ``path`` and rename it into place.

    ``fsync`` flushes the file to the disk before the rename, so a power loss cannot leave
    an empty file under the final name. Errors as :func:`replace_atomically`.
    """
    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    return replace_atomically(path, lambda tmp: write_file(tmp, raw, fsync=fsync), clear_stale=clear_stale)


# ---------------------------------------------------------------------------------------
# the time written files carry
# ---------------------------------------------------------------------------------------
def source_date_epoch() -> _dt.datetime | None:
    """``$SOURCE_DATE_EPOCH`` (seconds since 1970-01-01 UTC, the reproducible-builds convention)
    as a UTC time, or None when it is not set; the files written carry it instead of the clock.

    Raises
    ------
    InputError
        The variable is set but is not a whole number of seconds (naming it and its value),
        empty or blank included: NumPy reads it with ``int()`` on import and fails with a
        traceback.
    """
    text = os.environ.get("SOURCE_DATE_EPOCH")
    if text is None:
        return None
    try:
        return _dt.datetime.fromtimestamp(int(text), _dt.UTC)
    except (ValueError, OverflowError, OSError):
        raise InputError(f"SOURCE_DATE_EPOCH = {text!r} is not a whole number of seconds since 1970-01-01 UTC") \
            from None


def sha256_file(path: str | os.PathLike) -> str:
    """sha256 of a file's bytes (hex), read in 1 MiB blocks.

    Raises
    ------
    TrialFileError
        ``path`` is not a regular file (a FIFO, a socket, a device, a folder) or is missing.
    """
    h = hashlib.sha256()
    with open_regular(path, "rb", error=TrialFileError) as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
