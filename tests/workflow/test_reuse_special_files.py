"""A reuse campaign (``simulate: false``) whose archive holds a FIFO, a socket or a symbolic
link to another cell's trial (or folder) in place of a trial its index lists: the workflow stops at
start-up within seconds, naming the file in one line, before any job, and writes nothing (no
results folder; the archive as it was). A FIFO would hang a reader; the link would count the
other cell's trial twice."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import pytest

import snakemake_forks
from special_nodes import make_special

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "archive" / "reference"
VICTIM = Path("fixed/config1/zero/v2.500/r00.nc")
TWIN = Path("fixed/config1/zero/v1.500/r00.nc")


def _make(path: Path, kind: str) -> None:
    if kind == "linked folder":          # the speed's folder a link to the other speed's
        shutil.rmtree(path.parent)
        path.parent.symlink_to(TWIN.parent.name)
        return
    make_special(path, kind, twin=TWIN)


def _tree(root: Path) -> dict[str, tuple]:
    return {str(p.relative_to(root)): (p.lstat().st_mode, p.lstat().st_size, p.lstat().st_mtime_ns)
            for p in sorted(root.rglob("*"))}


@pytest.mark.parametrize("kind", ["fifo", "socket", "symlink", "linked folder"])
def test_a_reuse_archive_with_a_node_or_a_link_stops_at_start_up(tmp_path, kind):
    (tmp_path / "config").symlink_to(REPO / "config")
    archive = tmp_path / "archive" / "old"
    shutil.copytree(REFERENCE, archive)
    _make(archive / VICTIM, kind)
    before = _tree(tmp_path / "archive")
    t0 = time.perf_counter()
    proc = snakemake_forks.run(["-s", str(REPO / "Snakefile"), "--directory", str(tmp_path), "--cores", "1",
                                "--config", "simulate=false", "reuse_archive=archive/old"], cwd=tmp_path, timeout=120)
    elapsed = time.perf_counter() - t0
    said = proc.stdout + proc.stderr
    assert proc.returncode != 0, said
    assert elapsed < 30, elapsed                          # seconds: nothing opened the FIFO
    victim = f"archive/old/{VICTIM}"
    lines = [line for line in said.splitlines() if line.startswith("configuration key reuse_archive:")]
    assert len(lines) == 1 and victim in lines[0], said
    linked = f"resolves through a symbolic link to {(archive / TWIN).resolve()}, another cell's trial"
    expected = {"fifo": "is a FIFO, not a regular file", "socket": "is a socket, not a regular file",
                "symlink": linked, "linked folder": linked}[kind]
    assert expected in lines[0], lines[0]
    assert "Traceback" not in said and "rule " not in said, said      # before any job
    assert _tree(tmp_path / "archive") == before
    assert not (tmp_path / "results").exists()


