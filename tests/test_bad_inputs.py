"""Bad input, as a new user types it, across the CLI, the Python API and the workflow config.

Each row gives one bad value and a string the error must contain (the value or the option
it belongs to). The CLI must print exactly one line ``campaign <cmd>: error: ...`` naming
it, exit with status 2 and write nothing; the API must raise ``InputError`` (a
``ValueError``) naming it; the workflow must fail its dry run naming it, before any job,
without a traceback and without creating an archive or results folder.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.core.files import check_output_dir, check_output_file
from campaign.identify.options import check_identify_options
from campaign.identify.table import identify_trials
from campaign.pipeline.config import check_schema, parse_typed_strings
from campaign.pipeline.fit import fit_lambda
from campaign.pipeline.simulate import run_cells
from campaign.scene.checks import check_speeds, pendulum_reach

REPO = Path(__file__).resolve().parents[1]
REFERENCE = REPO / "archive" / "reference"
TRIAL = REFERENCE / "fixed" / "config1" / "zero" / "v1.500" / "r00.nc"


def _inputs(tmp: Path) -> None:
    """The bad files some rows name: malformed YAML, YAML of the wrong shape, a non-trial."""
    (tmp / "folder").mkdir()
    (tmp / "a_file").write_text("x\n")
    (tmp / "broken.yaml").write_text("contact: [1,\n")
    (tmp / "list.yaml").write_text("- 1\n- 2\n")
    (tmp / "nobounds.yaml").write_text("sweep: {}\nparameters: {a: {x: 1}}\nobservations: {}\noptimizer: {}\n")
    (tmp / "junk.nc").write_text("not a trial file\n")


CLI_CASES = [
    # (argv, text the one error line must contain)
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
    (["tables", str(REFERENCE), "--out", "a_file"], "--out a_file"),
    (["tables", "no_archive", "--out", "tables"], "no_archive"),
    (["tables", str(REFERENCE), "--out", "tables", "--bootstrap", "-1"], "--bootstrap"),
    (["fit-lambda", str(REFERENCE), "--seed", "-5"], "--seed = -5"),
    (["calibrate", "--report", "a_file", "--no-write"], "--report a_file"),
    (["calibrate", "--max-evaluations", "-3", "--no-write"], "--max-evaluations = -3"),
    (["calibrate", "--max-evaluations", "0", "--no-write"], "--max-evaluations = 0"),
    (["calibrate", "--calibration", "broken.yaml", "--no-write"], "broken.yaml"),
    (["calibrate", "--calibration", "nobounds.yaml", "--no-write"], "bounds"),
    (["identify", "missing.nc"], "missing.nc"),
    (["identify", "junk.nc"], "junk.nc"),
    (["archive", "verify", "no_archive"], "no_archive"),
    (["archive", "ls", str(REFERENCE), "--filter", "gain"], "'gain'"),
    (["meff", "--config", "3", "--lambda", "1,-2,0"], "-2"),
    (["meff", "--q", "1,2"], "--q 1,2"),
]


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.mark.parametrize("argv, names", CLI_CASES, ids=[" ".join(a[:2]) + f" [{n}]" for a, n in CLI_CASES])
def test_cli_names_the_bad_value_and_writes_nothing(tmp_path, monkeypatch, capsys, argv, names):
    _inputs(tmp_path)
    before = _tree(tmp_path)
    monkeypatch.chdir(tmp_path)
    status = main(argv)
    out, err = capsys.readouterr()
    assert status == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"campaign {argv[0]}: error: "), err
    assert names in lines[0], lines[0]
    assert "Traceback" not in out + err
    assert _tree(tmp_path) == before  # nothing written, not even a temporary file


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
    before = _tree(tmp_path)
    call, names = _api_cases(tmp_path)[index]
    with pytest.raises(ValueError) as info:
        call()
    message = str(info.value)
    assert names in message and "\n" not in message, message
    assert _tree(tmp_path) == before


# -------------------------------------------------------------------------------------------
# the workflow: every row's dry run is started at once (2 cores), then each is checked
# -------------------------------------------------------------------------------------------
WORKFLOW_CASES = [
    # (--config arguments, or a dict merged into config/ci.yaml; text the error must contain)
    ({"rig_params": {"contact.stifness": 1200}}, "'contact.stifness'"),
    ({"speeds": [1.0, 9.0]}, "speed 9.0 m/s is beyond"),
    ({"bases": {"fixed": {"configurations": [1], "gains": ["zero"], "speeds": [1.0, 6.0]}}}, "bases.fixed.speeds"),
    ({"identify": {"edge_modl": "line"}}, "'edge_modl'"),
    ({"identify": {"edge_model": "cubic"}}, "'cubic'"),
    ({"speeds": [1.0001, 1.0002]}, "1.0001 and 1.0002"),
    (["simulate=maybe"], "configuration key simulate: 'maybe'"),
    (["speeds=[1.0,fast]"], "configuration key speeds.1: 'fast'"),
    (["simulate=false", "reuse_archive=no/such/archive"], "configuration key reuse_archive"),
]


@pytest.fixture(scope="module")
def workflow_runs(tmp_path_factory):
    """Start every row's dry run in its own folder, then collect (folder, process result)."""
    snakemake = str(Path(sys.executable).parent / "snakemake")
    base = yaml.safe_load((REPO / "config" / "ci.yaml").read_text())
    procs = []
    for i, (change, _) in enumerate(WORKFLOW_CASES):
        work = tmp_path_factory.mktemp(f"wf{i}")
        cfg = dict(base)
        extra: list[str] = []
        if isinstance(change, dict):
            cfg.update(change)
        else:
            extra = ["--config", *change]
        (work / "c.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
        cmd = [snakemake, "-s", str(REPO / "Snakefile"), "--directory", str(work), "-n", "--configfile",
               str(work / "c.yaml"), *extra]
        procs.append((work, subprocess.Popen(cmd, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                             text=True)))
    return [(work, p.communicate(timeout=600)[0], p.returncode) for work, p in procs]


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
    with pytest.raises(InputError, match="configuration key simulate: 'maybe'"):
        ci = yaml.safe_load((REPO / "config" / "ci.yaml").read_text())
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
