"""Files the campaign writes: atomic writes and output paths checked before any work.

A result is written to a temporary file beside its destination and renamed into place,
so a reader never sees half a file and a failure leaves nothing behind.
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import InputError

__all__ = ["write_atomic", "check_output_file", "check_output_dir"]
# ---------------------------------------------------------------------------------------
# Virtual Rotor Inertia and the tables
# ---------------------------------------------------------------------------------------
def write_atomic(path: str | os.PathLike, data: str | bytes) -> Path:
    """Write ``data`` to a temporary file beside ``path`` and rename it into place."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        if isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data, encoding="utf-8")
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out


def check_output_file(path: str | os.PathLike, *, option: str = "--out") -> Path:
    """A file that can be written: not a folder, its folder a folder (or creatable) and writable."""
    out = Path(path)
    if out.is_dir():
        raise InputError(f"{option} {path}: is a folder; name a file")
    _check_parent(out, option=option, path=path)
    if out.exists() and not os.access(out, os.W_OK):
        raise InputError(f"{option} {path}: the file is not writable")
    return out



def check_output_dir(path: str | os.PathLike, *, option: str = "--out") -> Path:
    """A folder that can be written into (created if missing): not an existing file."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise InputError(f"{option} {path}: is a file; name a folder (created if missing)")
    if out.is_dir():
        if not os.access(out, os.W_OK | os.X_OK):
            raise InputError(f"{option} {path}: the folder is not writable")
        return out
    _check_parent(out, option=option, path=path)
    return out



def _check_parent(out: Path, *, option: str, path) -> None:
    """The nearest existing ancestor of ``out`` is a writable folder."""
    parent = out.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"{option} {path}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: the folder {parent} is not writable")

