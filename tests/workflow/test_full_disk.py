"""A full disk, for every writer: trials (HDF5), tables, JSON, figures, and the workflow.

Detected before the work (too little free space for the outputs): one line naming the
path and the free space, exit status 2, nothing written. Met part-way (the disk fills while
writing): one line naming the file and the free space, exit status 1, nothing left under
the file's final or temporary name (files finished before it stay, complete), no HDF5
traceback and no crash.

The disk is filled two ways: an injected ENOSPC (the low-level write of
:mod:`campaign.core.files`, through which every writer goes, fails once a byte budget is
spent, after writing part of the file, as a full disk does; a job's ``os.write`` in the
workflow), and, where the test may create one without root (a user namespace), a real
tmpfs of a few hundred kB.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

from campaign import archive
from campaign.cli.main import main
from campaign.core import files
from campaign.core.errors import WriteError
from campaign.core.files import write_atomic

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "archive" / "reference"


@pytest.fixture
def disk_full_after(monkeypatch):
    """``disk_full_after(budget)``: from now on the writers' low-level write fails with ENOSPC
    once ``budget`` bytes are written, after writing the part of the buffer that fits."""

    def arm(budget: int) -> None:
        left = [budget]
        real = files._write_all

        def write_all(fd: int, data) -> None:
            view = memoryview(data)
            if len(view) > left[0]:
                os.write(fd, view[:left[0]])
                left[0] = 0
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            left[0] -= len(view)
            real(fd, view)

        monkeypatch.setattr(files, "_write_all", write_all)

    return arm


def _run(argv: list[str], capsys) -> tuple[int, str, list[str]]:
    status = main(argv)
    out, err = capsys.readouterr()
    return status, out, err.splitlines()


def _files(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if not p.is_dir())


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    return tmp_path


def test_trial_on_a_disk_that_fills(scratch, disk_full_after, capsys):
    disk_full_after(100_000)
    status, out, err = _run(["trial", "--speed", "1.5", "--out", "t.nc"], capsys)
    assert status == 1 and out == "" and len(err) == 1, err
    assert err[0].startswith("campaign trial: error: t.nc: no space left on device while writing it (")
    assert " free); not written" in err[0] and "Traceback" not in err[0]
    assert _files(scratch) == []


def test_sweep_on_a_disk_that_fills_keeps_the_finished_trials(scratch, disk_full_after, capsys):
    disk_full_after(400_000)    # two fixed-base trials (~180 kB each), then the third fails
    status, out, err = _run(["sweep", "--configs", "1", "--gains", "zero,low", "--speeds", "1.5,2.5",
                             "--out", "a"], capsys)
    assert status == 1 and len(err) == 1, err
    assert err[0].startswith("campaign sweep: error: a/fixed/config1/low/v1.500/r00.nc: no space left on device")
    written = ["a/fixed/config1/zero/v1.500/r00.nc", "a/fixed/config1/zero/v2.500/r00.nc"]
    assert [line.rsplit(" -> ", 1)[1] for line in out.splitlines()] == written
    assert _files(scratch) == written
    for path in written:     # complete: every group reads back and matches its digest
        archive.open_trial_arrays(path, group="truth")
        archive.open_trial_arrays(path, group="measured")


def test_tables_on_a_disk_that_fills(scratch, disk_full_after, capsys):
    assert main(["tables", str(REFERENCE), "--out", "whole", "--bootstrap", "20"]) == 0
    capsys.readouterr()
    disk_full_after(3000)
    status, out, err = _run(["tables", str(REFERENCE), "--out", "part", "--bootstrap", "20"], capsys)
    assert status == 1 and len(err) == 1 and out == "", err
    assert "no space left on device" in err[0] and "part/table" in err[0]
    done = _files(scratch / "part")
    assert done and len(done) < len(_files(scratch / "whole"))
    for name in done:       # the tables finished before the disk filled, complete
        assert (scratch / "part" / name).read_bytes() == (scratch / "whole" / name).read_bytes()


def test_json_and_figures_on_a_full_disk(tmp_path, disk_full_after):
    from campaign.report.figures import style

    disk_full_after(10)
    with pytest.raises(WriteError, match=r"fit\.json: no space left on device .* free\); not written"):
        write_atomic(tmp_path / "fit.json", '{"lambda": [1, 2, 3]}\n' * 10)
    fig, ax = style.new_figure()
    ax.plot([0, 1], [0, 1])
    with pytest.raises(WriteError, match=r"f\.png: no space left on device"):
        style.save(fig, tmp_path / "f.png", tmp_path / "f.pdf")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv", [
    ["trial", "--speed", "1.5", "--out", "t.nc"],
    ["sweep", "--configs", "1", "--gains", "zero", "--speeds", "1.5", "--out", "a"],
    ["tables", str(REFERENCE), "--out", "t"],
    ["design", "--json", "d.json"],
    ["map", "workspace", "--out", "m.png"],
], ids=lambda a: a[0])
def test_a_full_disk_is_refused_before_the_work(scratch, monkeypatch, capsys, argv):
    monkeypatch.setattr(files, "free_bytes", lambda path: 12_000)
    status, out, err = _run(argv, capsys)
    assert status == 2 and out == "" and len(err) == 1, err
    assert ": 12.0 kB free on its file system, about " in err[0] and " needed" in err[0], err[0]
    assert _files(scratch) == []


# -------------------------------------------------------------------------------------------
# a real, small file system (a tmpfs in a user namespace; skipped where one cannot be made)
# -------------------------------------------------------------------------------------------
def _in_tiny_filesystem(script: str, mount: Path, size: str) -> str:
    """Run ``script`` (sh) with a tmpfs of ``size`` mounted at ``mount``, in a user and mount
    namespace of its own (no root needed); returns its output, or skips the test."""
    unshare = shutil.which("unshare")
    if unshare is None:
        pytest.skip("no unshare")
    mount.mkdir()
    probe = subprocess.run([unshare, "--user", "--map-root-user", "--mount", "sh", "-c",
                            f"mount -t tmpfs -o size=64k tmpfs '{mount}'"], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs in a user namespace here: {probe.stderr.strip()}")
    proc = subprocess.run([unshare, "--user", "--map-root-user", "--mount", "sh", "-c",
                           f"mount -t tmpfs -o size={size} tmpfs '{mount}' && {script}"],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": str(REPO), "CAMPAIGN_PROGRESS": "0"})
    return proc.stdout + proc.stderr


@pytest.mark.slow
def test_sweep_and_trial_on_a_real_small_filesystem(tmp_path):
    disk = tmp_path / "disk"
    campaign = f"'{sys.executable}' -m campaign.cli.main"
    script = textwrap.dedent(f"""\
        cd '{disk}'
        {campaign} sweep --configs 1 --gains zero,low --speeds 1.0,1.5 --out a > sweep.out 2> sweep.err
        echo "sweep $?"; cat sweep.err; rm sweep.out sweep.err
        {campaign} sweep --configs 1,2,3 --speeds 1.0,1.5 --out b 2>&1; echo "big sweep $?"
        {campaign} trial --speed 1.5 --out t.nc 2>&1; echo "trial $?"
        find . -type f | sort
    """)
    lines = _in_tiny_filesystem(script, disk, "600k").splitlines()
    # four trials (~180 kB each) pass the check before the work (150 kB each) and fill the
    # disk at the fourth; nine do not pass it
    assert lines[0] == "sweep 1", lines
    assert lines[1].startswith("campaign sweep: error: a/fixed/config1/low/v1.500/r00.nc: no space left on device")
    assert lines[2].startswith("campaign sweep: error: --out b: ") and " free on its file system, about 2.7 MB " \
        "needed" in lines[2], lines
    assert lines[3] == "big sweep 2"
    assert lines[4].startswith("campaign trial: error: --out t.nc: ") and "free on its file system" in lines[4]
    assert lines[5] == "trial 2"
    assert lines[6:] == ["./a/fixed/config1/low/v1.000/r00.nc", "./a/fixed/config1/zero/v1.000/r00.nc",
                         "./a/fixed/config1/zero/v1.500/r00.nc"], lines
    assert not any("h5py" in line or "Traceback" in line or "Segmentation" in line for line in lines)


# -------------------------------------------------------------------------------------------
# the workflow: a simulation job whose disk fills part-way
# -------------------------------------------------------------------------------------------
#: loaded by every Python process of the run (PYTHONPATH): a write to a file under
#: $FULL_UNDER fails with ENOSPC once $FULL_AFTER bytes are written
SITECUSTOMIZE = '''\
import errno
import os

_under = os.environ.get("FULL_UNDER")
_left = [int(os.environ.get("FULL_AFTER", "0"))]
_write = os.write


def _full_write(fd, data):
    try:
        target = os.readlink(f"/proc/self/fd/{fd}")
    except OSError:
        target = ""
    if _under and target.startswith(_under):
        if len(data) > _left[0]:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        _left[0] -= len(data)
    return _write(fd, data)


os.write = _full_write
'''


@pytest.mark.slow
def test_a_workflow_job_on_a_disk_that_fills_leaves_no_partial_output(tmp_path):
    if not Path("/proc/self/fd").is_dir():
        pytest.skip("the injection reads /proc/self/fd")
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(SITECUSTOMIZE)
    work = tmp_path / "work"
    work.mkdir()
    cfg = yaml.safe_load((REPO / "config" / "tests" / "ci.yaml").read_text())
    cfg.update(campaign="full_disk", bases={"fixed": {"configurations": [1, 2, 3], "gains": ["zero"]}})
    (work / "c.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    archive_dir = work / "archive" / "full_disk"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(hook), str(REPO)]), "FULL_UNDER": str(archive_dir),
           "FULL_AFTER": "400000"}
    snakemake = str(Path(sys.executable).parent / "snakemake")
    target = "archive/full_disk/.jobs/fixed/zero.json"  # the sweep job's manifest: its trials, one after another
    proc = subprocess.run([snakemake, target, "-s", str(REPO / "Snakefile"), "--directory", str(work), "--cores", "1",
                           "--configfile", str(work / "c.yaml")], cwd=work, capture_output=True, text=True,
                          timeout=900, env=env)
    output = proc.stdout + proc.stderr
    assert proc.returncode != 0, output
    logs = list((work / "results" / "full_disk" / "logs").rglob("*.log"))
    log = "\n".join(p.read_text() for p in logs)
    said = [line for line in log.splitlines() if "no space left on device" in line]
    assert said and said[-1].startswith("campaign.core.errors.WriteError: ") and "archive/full_disk/fixed/" in said[-1] \
        and " free); not written" in said[-1], log
    assert "h5py" not in log and "Segmentation" not in output + log
    # the job's manifest (its output) is not written; the trials it finished before the disk
    # filled stay, each complete and intact (a rerun keeps them once checked); nothing partial
    left = sorted(p for p in archive_dir.rglob("*") if not p.is_dir())
    assert left and all(p.suffix == ".nc" and ".jobs" not in p.parts for p in left), left
    assert all(archive.intact_trials(left)), left


@pytest.mark.slow
def test_a_workflow_job_on_a_real_small_filesystem_leaves_no_partial_output(tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    cfg = yaml.safe_load((REPO / "config" / "tests" / "ci.yaml").read_text())
    cfg.update(campaign="full_disk", bases={"fixed": {"configurations": [1, 2, 3], "gains": ["zero"]}})
    (work / "c.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    snakemake = Path(sys.executable).parent / "snakemake"
    script = textwrap.dedent(f"""\
        cd '{work}'
        '{snakemake}' archive/full_disk/.jobs/fixed/zero.json -s '{REPO / "Snakefile"}' \\
            --directory '{work}' --cores 1 --configfile c.yaml > snakemake.out 2>&1
        echo "snakemake $?"
        find archive -type f | sort
        PYTHONPATH='{REPO}' '{sys.executable}' -c 'import sys; from campaign import archive; \
print("intact", all(archive.intact_trials(sys.argv[1:])))' $(find archive -type f -name '*.nc')
        grep -h "no space left on device" results/full_disk/logs/simulate_fixed/fixed/zero.log
        grep -c -e h5py -e Segmentation snakemake.out results/full_disk/logs/simulate_fixed/fixed/zero.log
    """)
    lines = _in_tiny_filesystem(script, work / "archive", "400k").splitlines()
    assert lines[0].startswith("snakemake ") and lines[0] != "snakemake 0", lines
    # the trials finished before the disk filled, complete; no job manifest, nothing under a
    # temporary name
    finished = [line for line in lines[1:] if line.startswith("archive/")]
    assert finished and all(re.fullmatch(r"archive/full_disk/fixed/config\d/zero/v\d\.\d{3}/r\d\d\.nc", f)
                            for f in finished), lines
    rest = lines[1 + len(finished):]
    assert rest.pop(0) == "intact True", lines
    assert rest[0].startswith("campaign.core.errors.WriteError: archive/full_disk/fixed/config") and \
        "no space left on device while writing it" in rest[0], lines
    assert rest[1:] == ["snakemake.out:0", "results/full_disk/logs/simulate_fixed/fixed/zero.log:0"], lines
