"""Special files for the readers' tests: a FIFO, a bound Unix socket or a symbolic link put
where a regular file was (in a scratch folder, never a system path)."""

from __future__ import annotations

import os
import socket
from pathlib import Path


def make_special(path: Path, kind: str, *, twin: Path) -> None:
    """Replace ``path`` by ``kind``: ``"fifo"``, ``"socket"`` or otherwise a relative link to
    the file ``twin`` names (``<speed folder>/<file>``) in a sibling folder."""
    path.unlink(missing_ok=True)
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "socket":
        here = os.getcwd()
        os.chdir(path.parent)        # a relative name: socket paths are limited to ~100 bytes
        sock = socket.socket(socket.AF_UNIX)
        try:
            sock.bind(path.name)
        finally:
            sock.close()
            os.chdir(here)
    else:
        path.symlink_to(Path("..") / twin.parent.name / twin.name)
