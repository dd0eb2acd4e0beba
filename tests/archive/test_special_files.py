"""A FIFO, a socket or a symbolic link to another cell's trial inside an archive.

Opening a FIFO waits for a writer, so a reader that opens one hangs; a link to another cell's
trial counts that trial twice. Every reader must look before it opens: each command below
runs in-process under an alarm, so a regression fails in seconds instead of hanging, and must
name the file in one line, exit with its documented status and count nothing.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
from pathlib import Path

import pytest

from campaign.cli.main import main
from campaign.core.errors import InputError, TrialFileError
from campaign.core.files import check_regular_file, not_regular, open_regular, sha256_file
from campaign.core.yamlfile import read_yaml
from campaign.joints.modelfile import ModelFileError, load_model

import special_nodes

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "archive" / "reference"
#: the trial each case replaces, and the one its symbolic link points at (another speed cell)
VICTIM = Path("fixed/config1/zero/v2.500/r00.nc")
TWIN = Path("fixed/config1/zero/v1.500/r00.nc")


class Hung(Exception):
    pass


@pytest.fixture
def alarm():
    """Fail (rather than hang) a call that is still running after 60 s."""
    def ring(signum, frame):
        raise Hung("the reader blocked: it opened a FIFO or a socket")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def make_special(path: Path, kind: str) -> None:
    """Put a FIFO, a bound Unix socket or a link to :data:`TWIN`'s file at ``path``."""
    special_nodes.make_special(path, kind, twin=TWIN)


@pytest.fixture(params=["fifo", "socket", "symlink"])
def archive(request, tmp_path, monkeypatch):
    """A copy of the reference archive (finalized) with one trial replaced by ``kind``."""
    root = tmp_path / "arch"
    shutil.copytree(REFERENCE, root)
    make_special(root / VICTIM, request.param)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    return request.param, Path("arch")


def _run(argv, capsys):
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return status, out, err


EXPECTED = {"fifo": "is a FIFO, not a regular file", "socket": "is a socket, not a regular file",
            "symlink": ""}


def test_verify_names_the_file(archive, capsys, alarm):
    kind, root = archive
    status, out, err = _run(["archive", "verify", root], capsys)
    assert status == 1
    named = [line for line in out.splitlines() if line.startswith(str(root / VICTIM))]
    assert named, out
    assert any(EXPECTED[kind] in line for line in named), out
    assert len(named) == len(set(named)), out           # each problem named once
    if kind == "symlink":
        assert any(f"same content (group digests) as {TWIN}" in line for line in named), out
    else:
        # listed in the manifest and a trial path, yet one problem: nothing counted twice
        assert named == [f"{root / VICTIM}: {EXPECTED[kind]}"], out
        assert out.splitlines() == named and "1 problem(s) in 1 file(s)" in err, (out, err)


def test_finalize_refuses_and_writes_nothing(archive, capsys, alarm):
    kind, root = archive
    (root / "MANIFEST.sha256").unlink()       # a campaign not finalized yet
    (root / "index.csv").unlink()
    status, out, err = _run(["archive", "finalize", root], capsys)
    assert status == 2
    assert len(err.splitlines()) == 1 and str(root / VICTIM) in err, err
    assert EXPECTED[kind] in err
    if kind == "symlink":
        assert "misfiled" in err and "duplicate trial" in err
    assert not (root / "MANIFEST.sha256").exists() and not (root / "index.csv").exists()


@pytest.mark.parametrize("command", [["fit-lambda", "--bootstrap", "2"],
                                     ["tables", "--bootstrap", "2", "--out", "tables"]])
def test_archive_readers_refuse_and_count_nothing(archive, capsys, alarm, command):
    kind, root = archive
    status, out, err = _run([*command, root], capsys)
    assert status == 2, (out, err)
    assert out == "" and len(err.splitlines()) == 1, err
    assert str(root / VICTIM) in err
    assert (EXPECTED[kind] or "is a symbolic link to") in err
    assert not Path("tables").exists()


def test_identify_refuses_the_file_itself(archive, capsys, alarm):
    kind, root = archive
    status, out, err = _run(["identify", root / VICTIM], capsys)
    assert status == 2, (out, err)
    assert out == "" and len(err.splitlines()) == 1, err
    # the link itself opens fine: its content names another cell, so it is misfiled
    assert (EXPECTED[kind] or f"misfiled: its attributes place it at {root / TWIN}") in err, err


def test_a_loose_folder_with_a_fifo_is_refused(tmp_path, monkeypatch, capsys, alarm):
    """A folder that is no campaign: every ``*.nc`` under it, and a FIFO among them is named."""
    monkeypatch.chdir(tmp_path)
    Path("loose").mkdir()
    shutil.copy(REFERENCE / TWIN, "loose/a.nc")
    os.mkfifo("loose/b.nc")
    status, out, err = _run(["fit-lambda", "loose"], capsys)
    assert status == 2 and "loose/b.nc: is a FIFO, not a regular file" in err, err


# -------------------------------------------------------------------------------------------
# the one check every reader goes through
# -------------------------------------------------------------------------------------------
def test_the_check_names_what_a_path_is(tmp_path, alarm):
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "file").write_text("x")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    (tmp_path / "link").symlink_to(tmp_path / "file")
    assert not_regular(tmp_path / "file") is None
    assert not_regular(tmp_path / "link") is None                    # a link is followed
    assert not_regular(tmp_path / "fifo") == "is a FIFO, not a regular file"
    assert not_regular(tmp_path) == "is a folder, not a regular file"
    assert not_regular(tmp_path / "dangling") == "does not exist"
    with pytest.raises(InputError, match=r"^model file .*fifo: is a FIFO, not a regular file$"):
        check_regular_file(tmp_path / "fifo", what="model file")
    assert check_regular_file(tmp_path / "nowhere", missing_ok=True) == tmp_path / "nowhere"
    with pytest.raises(InputError, match="does not exist"):
        check_regular_file(tmp_path / "nowhere")
    with open_regular(tmp_path / "file") as fh:
        assert fh.read() == b"x"
    with pytest.raises(TrialFileError, match="fifo: is a FIFO"):
        sha256_file(tmp_path / "fifo")


def test_yaml_and_model_readers_refuse_a_fifo(tmp_path, alarm):
    os.mkfifo(tmp_path / "x.yaml")
    with pytest.raises(InputError, match=r"x\.yaml: is a FIFO, not a regular file"):
        read_yaml(tmp_path / "x.yaml")
    with pytest.raises(FileNotFoundError):                # missing: as open() says it
        read_yaml(tmp_path / "missing.yaml")
    with pytest.raises(ModelFileError, match=r"model file .*x\.yaml: is a FIFO, not a regular file"):
        load_model(tmp_path / "x.yaml")


# -------------------------------------------------------------------------------------------
# the campaign folder's own files: the manifest and the index
# -------------------------------------------------------------------------------------------
@pytest.fixture(params=[("MANIFEST.sha256", "fifo"), ("MANIFEST.sha256", "socket"), ("index.csv", "fifo"),
                        ("index.csv", "socket")], ids=lambda p: f"{p[0]}-{p[1]}")
def own_file(request, tmp_path, monkeypatch):
    """A copy of the reference archive with its manifest or index replaced by a FIFO or a socket."""
    name, kind = request.param
    root = tmp_path / "arch"
    shutil.copytree(REFERENCE, root)
    make_special(root / name, kind)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    return name, kind, Path("arch")


def test_verify_says_what_stands_in_place_of_the_manifest_or_index(own_file, capsys, alarm):
    name, kind, root = own_file
    status, out, err = _run(["archive", "verify", root], capsys)
    assert status == 1, (out, err)
    named = [line for line in out.splitlines() if line.startswith(f"{root / name}:")]
    assert len(named) == 1, out                          # once, though the manifest lists the index
    assert named[0].startswith(f"{root / name}: {EXPECTED[kind]}"), named
    assert "missing" not in out, out
    if name == "index.csv":                              # the rest of the archive is intact
        assert out.splitlines() == named and "1 problem(s) in 1 file(s)" in err, (out, err)


def test_finalize_refuses_a_node_where_it_writes_before_writing(own_file, capsys, alarm):
    name, kind, root = own_file
    others = [f for f in ("MANIFEST.sha256", "index.csv") if f != name]
    for other in others:                                 # not finalized yet
        (root / other).unlink()
    readme = (root / "README.md").stat().st_mtime_ns
    status, out, err = _run(["archive", "finalize", root], capsys)
    assert status == 2, (out, err)
    assert err.splitlines() == [f"campaign archive: error: {root / name}: {EXPECTED[kind]}; "
                                "finalizing writes a file there"], err
    assert all(not (root / other).exists() for other in others)
    assert (root / "README.md").stat().st_mtime_ns == readme
    assert not_regular(root / name) == EXPECTED[kind]   # left as it was


@pytest.mark.parametrize("command", [["fit-lambda", "--bootstrap", "2"], ["tables", "--bootstrap", "2", "--out", "t"],
                                     ["archive", "ls"]])
@pytest.mark.parametrize("kind", ["fifo", "socket"])
def test_a_node_in_place_of_the_index_is_named_by_every_reader(tmp_path, monkeypatch, capsys, alarm, command, kind):
    """Not taken for a campaign not finalized (whose trials would then be read at the layout)."""
    name, root = "index.csv", Path("arch")
    shutil.copytree(REFERENCE, tmp_path / root)
    make_special(tmp_path / root / name, kind)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    status, out, err = _run([*command, root], capsys)
    assert status == 2 and out == "", (out, err)
    assert err.splitlines() == [f"campaign {command[0]}: error: {root / name}: {EXPECTED[kind]}; "
                                "a campaign's index must be a regular file"], err
    assert not Path("t").exists()


@pytest.mark.parametrize("command", [["fit-lambda", "--bootstrap", "2"], ["tables", "--bootstrap", "2", "--out", "t"]])
def test_a_linked_speed_folder_is_not_counted_twice(tmp_path, monkeypatch, capsys, alarm, command):
    """``v2.500`` a link to the ``v1.500`` folder: its trial is the other speed's, misfiled."""
    root = tmp_path / "arch"
    shutil.copytree(REFERENCE, root)
    shutil.rmtree(root / VICTIM.parent)
    (root / VICTIM.parent).symlink_to(TWIN.parent.name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    status, out, err = _run([*command, "arch"], capsys)
    assert status == 2 and out == "", (out, err)
    assert err.splitlines() == [f"campaign {command[0]}: error: arch/{VICTIM}: misfiled: its attributes place it "
                                f"at arch/{TWIN} (speed: v2.500 in the path, v1.500 in the file)"], err
    assert not Path("t").exists()
