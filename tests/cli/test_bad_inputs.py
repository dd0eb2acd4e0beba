"""Bad input, as a new user types it, across the CLI, the Python API and the workflow config.

Each CLI row is one command and a string its error line must contain (the value, option or
path at fault). :func:`refused` asserts the four things every refusal must show: exactly one
line ``campaign <cmd>: error: ...`` on stderr naming it (nothing on stdout), the documented
exit status (2: bad input or usage, before any work), nothing written or changed in the
scratch folder (FIFOs and device nodes included), and nothing left under a temporary name.
The API must raise ``InputError`` (a ``ValueError``) naming the value; the workflow must fail
its dry run naming it, before any job, without a traceback and without creating an archive
or results folder. Full disks: ``tests/workflow/test_full_disk.py``.
"""

from __future__ import annotations

import os
import re
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.core.files import check_output_dir, check_output_file, write_atomic
from campaign.identify.options import check_identify_options
from campaign.identify.table import identify_trials
from campaign.pipeline.config import check_schema, parse_typed_strings
from campaign.pipeline.fit import fit_lambda
from campaign.pipeline.sweep import run_cells
from campaign.scene.checks import check_speeds, pendulum_reach

import snakemake_forks

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "archive" / "reference"
TRIAL = REFERENCE / "fixed" / "config1" / "zero" / "v1.500" / "r00.nc"
REF = str(REFERENCE)


def make_node(path: Path, kind: str) -> None:
    """A FIFO, or a character device node with /dev/null's numbers, at ``path`` (a scratch
    folder, never a real system node). Without the right to make device nodes a Unix socket
    stands in: like a device, a file that exists and is neither a regular file nor a folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "fifo":
        os.mkfifo(path)
        return
    try:
        os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 3))
    except PermissionError:
        sock = socket.socket(socket.AF_UNIX)
        here = os.getcwd()
        os.chdir(path.parent)           # a relative name: socket paths are limited to ~100 bytes
        try:
            sock.bind(path.name)
        finally:
            os.chdir(here)
            sock.close()


def _inputs(tmp: Path) -> None:
    """The files the rows name: malformed YAML, YAML of the wrong shape, a non-trial, folders
    and files in the way of outputs, a FIFO and a device node where outputs would go."""
    (tmp / "folder").mkdir()
    (tmp / "a_file").write_text("x\n")
    (tmp / "broken.yaml").write_text("contact: [1,\n")
    (tmp / "list.yaml").write_text("- 1\n- 2\n")
    (tmp / "nobounds.yaml").write_text("sweep: {}\nparameters: {a: {x: 1}}\nobservations: {}\noptimizer: {}\n")
    (tmp / "junk.nc").write_text("not a trial file\n")
    (tmp / "ws.pdf").mkdir()                              # beside map's ws.png
    (tmp / "tables_in_the_way" / "table3.md").mkdir(parents=True)
    (tmp / "bench_in_the_way" / "work_precision.png").mkdir(parents=True)
    (tmp / "sweep_in_the_way").mkdir()
    (tmp / "sweep_in_the_way" / "fixed").write_text("a file where the base's folder goes\n")
    make_node(tmp / "fifo", "fifo")
    make_node(tmp / "fifo.png", "fifo")
    make_node(tmp / "device", "device")
    make_node(tmp / "report" / "calibration.md", "fifo")


def snapshot(root: Path) -> dict[str, tuple]:
    """Every entry under ``root`` (links not followed): its type and permissions, and for a
    file its size, modification time and device number, so any write or replacement shows."""
    out = {}
    for path in sorted(root.rglob("*")):
        st = path.lstat()
        out[str(path.relative_to(root))] = ((st.st_mode,) if stat.S_ISDIR(st.st_mode)
                                            else (st.st_mode, st.st_size, st.st_mtime_ns, st.st_rdev))
    return out


def temporary_names(root: Path) -> list[str]:
    """Files under ``root`` named as the campaign's writers name their temporary files."""
    return [str(p) for p in root.rglob(".*.tmp")]


@pytest.fixture
def refused(tmp_path, monkeypatch, capsys):
    """``refused(argv, names, status=2)``: run ``campaign ARGV`` in a scratch folder holding
    :func:`_inputs` and assert one error line naming ``names``, exit ``status``, nothing
    written and nothing under a temporary name; returns the line."""
    _inputs(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")

    def check(argv: list[str], names: str, *, status: int = 2, env: dict | None = None) -> str:
        for key, value in (env or {}).items():
            monkeypatch.setenv(key, value)
        before = snapshot(tmp_path)
        try:
            got = main(argv)
        except SystemExit as exc:          # argparse's usage errors end the process
            got = exc.code
        out, err = capsys.readouterr()
        lines = err.splitlines()
        assert got == status, (out, err)
        assert out == "" and len(lines) == 1, (out, err)
        assert lines[0].startswith("campaign") and ": error: " in lines[0], lines[0]
        assert names in lines[0], lines[0]
        assert "Traceback" not in err
        assert snapshot(tmp_path) == before    # nothing written or replaced, nodes intact
        assert temporary_names(tmp_path) == []
        return lines[0]

    return check


#: rows for the destructive and double-counting inputs, each (argv, text the error line must contain)
ITEM_CASES = [
    # 1: a device or FIFO as the destination is refused before work, and left as it is
    (["trial", "--speed", "1.5", "--out", "fifo"], "--out fifo: is a FIFO"),
    (["trial", "--speed", "1.5", "--out", "device"], "--out device: is a"),
    (["design", "--json", "fifo"], "--json fifo: is a FIFO"),
    (["design", "--md", "device"], "--md device"),
    (["sweep", "--speeds", "1.5", "--out", "fifo"], "--out fifo: is a FIFO"),
    (["tables", REF, "--out", "device"], "--out device"),
    (["map", "workspace", "--out", "fifo.png"], "--out fifo.png: is a FIFO"),
    (["calibrate", "--report", "report", "--no-write"], "report/calibration.md is a FIFO"),
    (["calibrate", "--rig", "fifo"], "--rig fifo: is a FIFO"),
    # 7: output paths checked before the work, naming the path
    (["map", "workspace", "--out", "ws.png"], "ws.pdf: is a folder"),
    (["design", "--json", "folder"], "--json folder: is a folder"),
    (["design", "--md", "folder"], "--md folder: is a folder"),
    (["sweep", "--speeds", "1.5", "--out", "a_file"], "--out a_file: is a file"),
    # 8: inputs accepted before, now refused
    (["sweep", "--speeds", "1.0,,1.5", "--out", "s"], "--speeds 1.0,,1.5: item 2 is empty"),
    (["sweep", "--speeds", "1.5", "--configs", "1,1", "--out", "s"], "--configs 1,1: 1 is given twice"),
    (["sweep", "--speeds", "1.5", "--configs", "", "--out", "s"], "--configs '': expected at least one"),
    (["trial", "--speed", "0.0004", "--out", "t.nc"], "0.0004 m/s would be stored as v0.000"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--count", "5"], "--count 5: counts the directions of --cone"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--lambda", "a=1,2,3", "--lambda", "a=4,5,6"],
     "gain class 'a' is given twice"),
    (["map", "directions", "--out", "d.png", "--lambda", "a=1,2,3", "--lambda", "a=1,2,3"],
     "gain class 'a' is given twice"),
    # 9: usage errors are one line with a hint to --help, as every other error
    (["trial", "--speed", "1.5"], "the following arguments are required: --out; see 'campaign trial --help'"),
    (["bogus"], "invalid choice: 'bogus'"),
]

#: rows for the earlier bad inputs
EARLIER_CASES = [
    (["trial", "--speed", "1.5", "--out", "folder"], "--out folder"),
    (["trial", "--speed", "1.5", "--out", "a_file/t.nc"], "a_file"),
    (["trial", "--speed", "9", "--out", "t.nc"], "9.0 m/s"),
    (["trial", "--speed", "-1", "--out", "t.nc"], "-1"),
    (["trial", "--speed", "1.5", "--seed", str(2**64), "--out", "t.nc"], str(2**64)),
    (["trial", "--speed", "1.5", "--seed", "-1", "--out", "t.nc"], "-1"),
    (["trial", "--speed", "1.5", "--set", "contact.stifness=2000", "--out", "t.nc"], "contact.stifness"),
    (["trial", "--speed", "1.5", "--set", "contact.restitution=2", "--out", "t.nc"], "contact.restitution"),
    (["trial", "--speed", "1.5", "--rig", "broken.yaml", "--out", "t.nc"], "broken.yaml"),
    (["trial", "--speed", "1.5", "--rig", "list.yaml", "--out", "t.nc"], "list.yaml"),
    (["trial", "--speed", "1.5", "--rig", "missing.yaml", "--out", "t.nc"], "missing.yaml"),
    (["trial", "--config", "7", "--speed", "1.5", "--out", "t.nc"], "7"),
    (["tables", REF, "--out", "a_file"], "--out a_file"),
    (["tables", "no_archive", "--out", "tables"], "no_archive"),
    (["tables", REF, "--out", "tables", "--bootstrap", "-1"], "--bootstrap"),
    (["fit-lambda", REF, "--seed", "-5"], "--seed = -5"),
    (["calibrate", "--report", "a_file", "--no-write"], "--report a_file"),
    (["calibrate", "--max-evaluations", "-3", "--no-write"], "--max-evaluations = -3"),
    (["calibrate", "--max-evaluations", "0", "--no-write"], "--max-evaluations = 0"),
    (["calibrate", "--calibration", "broken.yaml", "--no-write"], "broken.yaml"),
    (["calibrate", "--calibration", "nobounds.yaml", "--no-write"], "bounds"),
    (["identify", "missing.nc"], "missing.nc"),
    (["identify", "junk.nc"], "junk.nc"),
    (["archive", "verify", "no_archive"], "no_archive"),
    (["archive", "ls", REF, "--filter", "gain"], "'gain'"),
    (["meff", "--config", "3", "--lambda", "1,-2,0"], "-2"),
    (["meff", "--q", "1,2"], "--q 1,2"),
]

#: further rows of our own choosing, one per bad input
FURTHER_CASES = [
    (["meff", "--config", "9"], "--config 9"),
    (["meff", "--q", "0,150,nan"], "nan"),
    (["meff", "--config", "1", "--direction", "0,0,0"], "--direction 0,0,0"),
    (["meff", "--config", "1", "--q", "0,0,0"], "not allowed with argument --config"),
    (["meff"], "one of the arguments --config --q --table is required"),
    (["meff", "--config", "1", "--lambda", "1,2"], "--lambda 1,2"),
    (["plan", "--point", "0,0"], "--point 0,0"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--mass", "-1"], "--mass -1"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--objective", "displacement"], "--base flexible"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--top", "-1"], "--top -1"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--horizontal", "0"], "--horizontal 0"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--cone", "0,0,0,30"], "--cone 0,0,0,30"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--lambda", "=1,2,3"], "--lambda =1,2,3"),
    (["map", "workspace", "--out", "ws.jpg"], "--out ws.jpg"),
    (["map", "workspace", "--out", "m.png", "--resolution", "0"], "--resolution 0"),
    (["map", "directions", "--config", "7", "--out", "d.png"], "--config 7"),
    (["trial", "--speed", "0", "--out", "t.nc"], "got 0.0"),
    (["trial", "--speed", "nan", "--out", "t.nc"], "got nan"),
    (["trial", "--speed", "1.5", "--repeat", "-1", "--out", "t.nc"], "-1"),
    (["trial", "--speed", "1.5", "--gain", "medium", "--out", "t.nc"], "invalid choice: 'medium'"),
    (["trial", "--speed", "1.5", "--q", "0,150", "--out", "t.nc"], "--q 0,150"),
    (["trial", "--speed", "1.5", "--direction", "0,0,1", "--out", "t.nc"], "not horizontal"),
    (["trial", "--speed", "1.5", "--set", "contact.stiffness", "--out", "t.nc"], "'contact.stiffness'"),
    (["trial", "--speed", "1.5", "--config", "1", "--q", "0,150,90", "--out", "t.nc"], "not allowed with"),
    (["trial", "--speed", "fast", "--out", "t.nc"], "invalid float value: 'fast'"),
    (["sweep", "--speeds", "1.5", "--gains", "zero,medium", "--out", "s"], "'medium'"),
    (["sweep", "--speeds", "1.5", "--gains", "zero,zero", "--out", "s"], "zero is given twice"),
    (["sweep", "--speeds", "1.5,1.5", "--out", "s"], "1.5 is given twice"),
    (["sweep", "--speeds", "1.0001,1.0002", "--out", "s"], "1.0001 and 1.0002"),
    (["sweep", "--speeds", "1.5", "--repeats", "0", "--out", "s"], "--repeats 0"),
    (["sweep", "--speeds", "1.5", "--configs", "x", "--out", "s"], "'x' is not a configuration number"),
    (["sweep", "--speeds", "abc", "--out", "s"], "'abc' is not a speed"),
    (["sweep", "--speeds", "", "--out", "s"], "--speeds '': expected at least one speed"),
    (["sweep", "--speeds", "1.5", "--configs", "0", "--out", "s"], "configuration 0"),
    (["sweep", "--speeds", "1.5", "--out", "sweep_in_the_way"], "sweep_in_the_way/fixed is a file"),
    (["sweep", "--speeds", "0.0004", "--out", "s"], "0.0004 m/s would be stored as v0.000"),
    (["design", "--k", "0"], "--k 0"),
    (["design", "--speeds", "1.5,x"], "'x' is not a number"),
    (["design", "--prior", "bogus=1,2,3"], "'bogus'"),
    (["design", "--json", "a.json", "--md", "a.json"], "--json and --md both name a.json"),
    (["design", "--repeats", "0"], "--repeats 0"),
    (["design", "--criterion", "X"], "invalid choice: 'X'"),
    (["tables", REF, "--out", "tables_in_the_way"], "tables_in_the_way/table3.md is a folder"),
    (["tables", REF, "--out", "fifo"], "--out fifo: is a FIFO"),
    (["fit-lambda", "no_archive"], "no_archive"),
    (["recorded-lambda", "no_hits.csv", "--robot", "planar2", "--fit", "a", "--predict", "b"], "no_hits.csv"),
    (["recorded-lambda", "no_hits.csv", "--robot", "planar2", "--fit", "a", "--predict", "b", "--rtol", "2"],
     "--rtol 2: must be in (0, 1)"),
    (["recorded-lambda", "no_hits.csv", "--robot", "planar2", "--fit", "a", "--predict", "b", "--at", "1,x"],
     "--at 1,x: expected 2 comma-separated values"),
    (["recorded-lambda", "no_hits.csv", "--robot", "no_robot", "--fit", "a", "--predict", "b"],
     "--robot no_robot: unknown robot 'no_robot'"),
    (["identify"], "the following arguments are required: PATH"),
    (["identify", "a_file"], "a_file"),
    (["archive", "ls", REF, "--format", "xml"], "invalid choice: 'xml'"),
    (["archive", "ls", REF, "--filter", "=x"], "'=x'"),
    (["archive", "finalize", "no_archive"], "no_archive"),
    (["archive"], "the following arguments are required: ACTION"),
    (["bench", "work-precision", "--out", "a_file"], "--out a_file: is a file"),
    (["bench", "work-precision", "--quick", "--smoke"], "argument --smoke: not allowed with argument --quick"),
    # a file output typed as a folder (a trailing slash, or ending in . or ..) is refused,
    # though Path() would drop the slash and write the file
    (["trial", "--speed", "1.5", "--out", "t.nc/"], "--out t.nc/: ends with a slash, which names a folder"),
    (["trial", "--speed", "1.5", "--out", "t.nc/."], "--out t.nc/.: ends in '.'"),
    (["design", "--json", "d.json/"], "--json d.json/: ends with a slash"),
    (["design", "--md", "d.md/"], "--md d.md/: ends with a slash"),
    (["map", "workspace", "--out", "ws2.png/"], "--out ws2.png/: ends with a slash"),
    (["calibrate", "--rig", "rig.yaml/"], "--rig rig.yaml/: ends with a slash"),
    (["bench", "work-precision", "--out", "bench_in_the_way"], "bench_in_the_way/work_precision.png is a folder"),
    ([], "the following arguments are required: COMMAND"),
    # readers open regular files only: a FIFO or a folder is named as what it is, never waited on
    (["identify", "fifo"], "fifo: is a FIFO, not a regular file"),
    (["identify", "folder"], "folder: is a folder, not a regular file"),
    (["meff", "--config", "1", "--gain", "zero", "--speed", "1.5", "--model", "fifo"],
     "model file fifo: is a FIFO, not a regular file"),
    (["trial", "--speed", "1.5", "--rig", "fifo", "--out", "t.nc"], "rig parameter file fifo: is a FIFO"),
    (["trial", "--speed", "1.5", "--rig", "folder", "--out", "t.nc"], "rig parameter file folder: is a folder"),
]

CLI_CASES = ITEM_CASES + EARLIER_CASES + FURTHER_CASES


def _case_id(argv: list[str], names: str) -> str:
    return " ".join(a.replace(REF, "REF") for a in argv[:2]) + f" [{names[:40]}]"


@pytest.mark.parametrize("argv, names", CLI_CASES, ids=[_case_id(a, n) for a, n in CLI_CASES])
def test_cli_names_the_bad_value_and_writes_nothing(refused, argv, names):
    refused(argv, names)


def test_a_bad_source_date_epoch_is_named_before_any_import(refused):
    """numpy reads the variable on import (an 'invalid literal for int()' traceback): the
    command checks it first."""
    refused(["trial", "--speed", "1.5", "--out", "t.nc"], "SOURCE_DATE_EPOCH = 'abc'", env={"SOURCE_DATE_EPOCH": "abc"})


def test_the_table_covers_every_item_and_forty_more_cases():
    assert len(FURTHER_CASES) >= 40
    assert len({tuple(a) for a, _ in CLI_CASES}) == len(CLI_CASES)     # no row twice


# -------------------------------------------------------------------------------------------
# a device or FIFO where any command writes: refused, and the node left as it was
# -------------------------------------------------------------------------------------------
#: (command, where the node goes in the scratch folder): every command that writes, and
#: every kind of destination it has (the file, the folder, a file inside the folder)
NODE_TARGETS = [
    (["trial", "--speed", "1.5", "--out", "x.nc"], "x.nc"),
    (["sweep", "--speeds", "1.5", "--out", "s"], "s"),
    (["sweep", "--configs", "1", "--gains", "zero", "--speeds", "1.5", "--out", "s"],
     "s/fixed/config1/zero/v1.500/r00.nc"),
    (["design", "--json", "d.json"], "d.json"),
    (["design", "--md", "d.md"], "d.md"),
    (["tables", REF, "--out", "t"], "t"),
    (["tables", REF, "--out", "t"], "t/identification.csv"),
    (["map", "workspace", "--out", "m.png"], "m.png"),
    (["map", "workspace", "--out", "m.png"], "m.pdf"),
    (["calibrate", "--report", "r", "--no-write"], "r/calibration.json"),
    (["calibrate", "--rig", "rig.yaml"], "rig.yaml"),
    (["bench", "work-precision", "--out", "b"], "b/work_precision.json"),
]


@pytest.mark.parametrize("kind", ["fifo", "device"])
@pytest.mark.parametrize("argv, node", NODE_TARGETS, ids=[f"{a[0]} {n}" for a, n in NODE_TARGETS])
def test_a_device_or_fifo_destination_is_refused_and_left_intact(refused, tmp_path, argv, node, kind):
    make_node(tmp_path / node, kind)
    before = os.lstat(tmp_path / node)
    line = refused(argv, node)
    assert "not a regular file" in line or "is a FIFO" in line or "is a character device" in line \
        or "is a socket" in line, line
    after = os.lstat(tmp_path / node)
    assert (after.st_mode, after.st_rdev, after.st_ino) == (before.st_mode, before.st_rdev, before.st_ino)
    assert not stat.S_ISREG(after.st_mode)


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_the_writers_themselves_refuse_a_node(tmp_path, kind):
    """Below the commands: the atomic writer, the trial writer and the workflow's
    identification and fit jobs refuse a node too, and leave it."""
    from campaign.archive import write_trial
    from campaign.rig import simulate_arrays
    from campaign.scene.description import make_scene

    node = tmp_path / "node"
    make_node(node, kind)
    before = os.lstat(node)
    trial = simulate_arrays(make_scene(speed=1.5))
    calls = [lambda: write_atomic(node, "text"), lambda: write_trial(trial, node),
             lambda: identify_trials([str(TRIAL)], node),
             lambda: fit_lambda([], node, gain_class="high", gains=["high"])]
    for call in calls:
        with pytest.raises(InputError, match="node"):
            call()
    assert os.lstat(node).st_mode == before.st_mode and os.lstat(node).st_rdev == before.st_rdev
    assert sorted(p.name for p in tmp_path.iterdir()) == ["node"]


@pytest.mark.parametrize("typed", ["t.nc/", "t.nc/.", "sub/..", "t.nc//"])
def test_a_file_output_typed_as_a_folder_is_refused_by_the_shared_check(tmp_path, typed):
    """The check every file output goes through reads the path as typed (``Path`` would
    drop the trailing slash and write ``t.nc``); the same path without the slash passes."""
    with pytest.raises(InputError, match=re.escape(f"--out {tmp_path}/{typed}: ends ") + ".*, which names a folder"):
        check_output_file(f"{tmp_path}/{typed}")
    assert check_output_file(f"{tmp_path}/t.nc") == tmp_path / "t.nc"
    assert list(tmp_path.iterdir()) == []


def test_cli_guard_holds_in_a_real_process(tmp_path):
    """The console script itself: exit status 2, one line, no traceback (a misspelt key)."""
    exe = Path(sys.executable).parent / "campaign"
    proc = subprocess.run([str(exe), "trial", "--speed", "1.5", "--set", "contact.stifness=1", "--out", "t.nc"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "campaign trial: error: unknown rig parameter 'contact.stifness'; did you mean contact.stiffness, "
        "contact.restitution, contact.exponent?"]
    assert not list(tmp_path.iterdir())


def test_a_usage_error_is_one_line_in_a_real_process(tmp_path):
    exe = Path(sys.executable).parent / "campaign"
    proc = subprocess.run([str(exe), "sweep", "--speeds"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        "campaign sweep: error: argument --speeds: expected one argument; see 'campaign sweep --help'"]


def test_results_go_to_stdout_and_diagnostics_to_stderr(tmp_path, monkeypatch, capsys):
    """``campaign sweep ... > log`` captures what was written; errors stay on the terminal."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    assert main(["trial", "--speed", "1.5", "--out", "t.nc"]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("wrote t.nc: fixed/config1/zero/v1.500/r00") and err == ""
    assert main(["sweep", "--configs", "1", "--gains", "zero", "--speeds", "1.5", "--out", "s"]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert lines[0].startswith("[1/1] fixed/config1/zero/v1.500/r00: ") and lines[0].endswith(
        "-> s/fixed/config1/zero/v1.500/r00.nc")
    assert lines[1].startswith("wrote 1 trials under s in ") and len(lines) == 2 and err == ""


def test_closed_pipe_ends_quietly(tmp_path):
    """``campaign archive ls | head -1``: no BrokenPipeError traceback on stderr."""
    exe = Path(sys.executable).parent / "campaign"
    proc = subprocess.run(f"'{exe}' archive ls '{REFERENCE}' | head -1", shell=True, cwd=tmp_path,
                          capture_output=True, text=True, timeout=120, env={**os.environ, "CAMPAIGN_PROGRESS": "0"})
    assert proc.stdout.startswith("path")
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr, proc.stderr


def _api_cases(tmp: Path):
    from campaign.identify import IdentifyOptions
    from campaign.pipeline.calibration import load_calibration
    from campaign.scene.description import load_rig, make_scene

    return [
        (lambda: make_scene(speed=1.5, params={"contact.stifness": 1.0}), "contact.stifness"),
        (lambda: make_scene(speed=1.5, seed=2**64), str(2**64)),
        (lambda: make_scene(speed=1.5, config=9), "9"),
        (lambda: load_rig(tmp / "broken.yaml"), "broken.yaml"),
        (lambda: load_calibration(tmp / "list.yaml"), "list.yaml"),
        (lambda: IdentifyOptions(arm_velocity="radar"), "radar"),
        (lambda: check_identify_options({"edge_modl": "line"}), "edge_modl"),
        (lambda: check_speeds([1.0001, 1.0002]), "1.0002"),
        (lambda: check_speeds([1.0, 9.0], reach=4.5), "9.0"),
        (lambda: check_output_file(tmp / "folder"), "folder"),
        (lambda: check_output_dir(tmp / "a_file"), "a_file"),
        (lambda: identify_trials([str(TRIAL)], tmp / "out.csv", options={"k_sigmaa": 3}), "k_sigmaa"),
        (lambda: fit_lambda([], tmp / "fit.json", gain_class="high", gains=["high"], options={"bogus": 1}),
         "bogus"),
        (lambda: run_cells([("fixed", 1, "zero")], archive_dir=tmp / "a", speeds=[1.0, 9.0], repeats=1),
         "speed 9.0 m/s is beyond"),
        (lambda: run_cells([("fixed", 1, "zero")], archive_dir=tmp / "a", speeds=[2.0], repeats=1,
                                  params={"pendulum.radiu": 0.5}), "'pendulum.radiu'"),
    ]


API_IDS = ["make_scene key", "make_scene seed", "make_scene config", "load_rig yaml", "load_calibration shape",
           "IdentifyOptions value", "identify option name", "speeds rounding", "speeds reach", "output file",
           "output dir", "identify_trials option", "fit_lambda option", "run_cells reach", "run_cells rig key"]


@pytest.mark.parametrize("index", range(len(API_IDS)), ids=API_IDS)
def test_api_names_the_bad_value(tmp_path, index):
    _inputs(tmp_path)
    before = snapshot(tmp_path)
    call, names = _api_cases(tmp_path)[index]
    with pytest.raises(ValueError) as info:
        call()
    message = str(info.value)
    assert names in message and "\n" not in message, message
    assert snapshot(tmp_path) == before


# -------------------------------------------------------------------------------------------
# the workflow: every row's dry run, then each is checked
# -------------------------------------------------------------------------------------------
WORKFLOW_CASES = [
    # (--config arguments, or a dict merged into config/tests/ci.yaml; text the error must contain[;
    # environment variables])
    ({"rig_params": {"contact.stifness": 1200}}, "'contact.stifness'"),
    ({"speeds": [1.0, 9.0]}, "speed 9.0 m/s is beyond"),
    ({"bases": {"fixed": {"configurations": [1], "gains": ["zero"], "speeds": [1.0, 6.0]}}}, "bases.fixed.speeds"),
    ({"identify": {"edge_modl": "line"}}, "'edge_modl'"),
    ({"identify": {"edge_model": "cubic"}}, "'cubic'"),
    ({"speeds": [1.0001, 1.0002]}, "1.0001 and 1.0002"),
    (["simulate=maybe"], "configuration key simulate: 'maybe'"),
    (["speeds=[1.0,fast]"], "configuration key speeds.1: 'fast'"),
    (["simulate=false", "reuse_archive=no/such/archive"], "configuration key reuse_archive"),
    # a configuration file's quoted value is the string it says, not coerced
    ({"repeats": "3"}, "configuration key repeats: '3' is not of type 'integer'"),
    ({"simulate": "no"}, "configuration key simulate: 'no' is not of type 'boolean'"),
    # a switch on the command line is true or false (not YAML 1.1's no/off)
    (["simulate=no"], "configuration key simulate: 'no' is not of type 'boolean'"),
    ({}, "SOURCE_DATE_EPOCH = 'abc' is not a whole number", {"SOURCE_DATE_EPOCH": "abc"}),
]


@pytest.fixture(scope="module")
def workflow_runs(tmp_path_factory):
    """Each row's dry run in its own folder (through :mod:`snakemake_forks`): (folder, output, status)."""
    base = yaml.safe_load((REPO / "config" / "tests" / "ci.yaml").read_text())
    runs = []
    for i, (change, _, *env) in enumerate(WORKFLOW_CASES):
        work = tmp_path_factory.mktemp(f"wf{i}")
        cfg = dict(base)
        extra: list[str] = []
        if isinstance(change, dict):
            cfg.update(change)
        else:
            extra = ["--config", *change]
        (work / "c.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
        args = ["-s", str(REPO / "Snakefile"), "--directory", str(work), "-n", "--configfile", str(work / "c.yaml"),
                *extra]
        proc = snakemake_forks.run(args, cwd=work, env={**os.environ, **(env[0] if env else {})}, timeout=600)
        runs.append((work, proc.stdout + proc.stderr, proc.returncode))
    return runs


@pytest.mark.parametrize("index", range(len(WORKFLOW_CASES)),
                         ids=[str(c[0])[:40] for c in WORKFLOW_CASES])
def test_workflow_dry_run_names_the_bad_value(workflow_runs, index):
    work, output, status = workflow_runs[index]
    names = WORKFLOW_CASES[index][1]
    assert status != 0, output
    assert names in output, output
    assert "Traceback" not in output, output
    assert not (work / "archive").exists() and not (work / "results").exists()


def test_the_table_has_thirty_rows():
    assert len(CLI_CASES) + len(API_IDS) + len(WORKFLOW_CASES) >= 30


def test_config_values_typed_on_the_command_line_parse():
    """``--config simulate=false 'speeds=[1.0,2.5]'`` arrive as strings; the schema's types read them."""
    schema = yaml.safe_load((REPO / "workflow" / "schemas" / "config.schema.yaml").read_text())
    cfg = parse_typed_strings({"simulate": "false", "speeds": ["1.0", "2.5"], "campaign": "123",
                                      "bases": {"fixed": {"configurations": ["1"], "gains": ["zero"]}}}, schema)
    assert cfg == {"simulate": False, "speeds": [1.0, 2.5], "campaign": "123",
                   "bases": {"fixed": {"configurations": [1], "gains": ["zero"]}}}
    # only the command line's values are read: a file's quoted "3" stays a string for the schema
    given = {"simulate": "false"}
    assert parse_typed_strings({"repeats": "3", "simulate": "false"}, schema, given=given) == {
        "repeats": "3", "simulate": False}
    assert parse_typed_strings({"simulate": "no"}, schema)["simulate"] == "no"
    assert parse_typed_strings({"simulate": "TRUE"}, schema)["simulate"] is True
    with pytest.raises(InputError, match="configuration key simulate: 'maybe'"):
        ci = yaml.safe_load((REPO / "config" / "tests" / "ci.yaml").read_text())
        check_schema(parse_typed_strings({**ci, "simulate": "maybe"}, schema), schema)


def test_the_start_up_reach_agrees_with_the_pendulum():
    """The workflow checks speeds with campaign.scene.description.hammer_reach (no rig import); the
    simulated pendulum refuses exactly the speeds beyond it."""
    from campaign.rig.pendulum import Pendulum
    from campaign.scene.description import load_rig

    values, _ = load_rig()
    reach = pendulum_reach(values)
    pend = Pendulum(values["pendulum.head_mass"], values["pendulum.rod_mass"], values["pendulum.radius"],
                    values["gravity"], values["pendulum.max_release_deg"])
    assert 1.0 < reach < 10.0 and pend.max_speed == reach
    pend.release_angle(reach * (1 - 1e-9))
    with pytest.raises(InputError, match="beyond what the pendulum can reach"):
        pend.release_angle(reach * (1 + 1e-9))
