"""Bad input in configuration, rig and YAML files, resource bombs, float edges, and writes
that would change what they must not, as rows like ``tests/cli/test_bad_inputs.py``'s.

Each CLI row goes through that file's ``refused`` fixture: exactly one line ``campaign <cmd>:
error: ...`` naming the value, exit status 2, nothing written or changed in the scratch
folder, nothing under a temporary name, no traceback. Each workflow row is a dry run that
fails naming the value before any job, without a traceback, creating no archive or results
folder. The YAML bombs are read by every reader of the project's YAML files in a child
process that measures the time and the growth of its peak memory.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
import yaml
from test_bad_inputs import REFERENCE, REPO, refused, snapshot  # noqa: F401 - refused is a fixture

import campaign.archive.manifest as manifest_module
import campaign.pipeline.paths as paths_module
from campaign.archive import check_listed_digests
from campaign.cli.main import main
from campaign.core.yamlfile import MAX_YAML_BYTES, read_yaml
from campaign.pipeline.paths import check_manifest

import snakemake_forks

RIG = (REPO / "config" / "rig.yaml").read_text(encoding="utf-8")
TRIAL = "fixed/config1/zero/v1.500/r00.nc"
#: the "billion laughs": 9 lines whose aliases expand to 9**9 (387 million) strings
BOMB = "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n" + "".join(
    f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi", strict=True))
#: no alias at all: 400 000 nodes in 800 kB (under the size limit)
WIDE = "[" + "0," * 400_000 + "0]\n"
DEEP = "[" * 5000 + "]" * 5000 + "\n"


def _line_of(text: str, prefix: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if line.startswith(prefix))


def _rig_with(old: str, new: str) -> str:
    assert RIG.count(old) == 1, old
    return RIG.replace(old, new)


def _files(tmp: Path) -> None:
    """The rows' input files in the scratch folder."""
    (tmp / "bomb.yaml").write_text(BOMB)
    (tmp / "wide.yaml").write_text(WIDE)
    (tmp / "deep.yaml").write_text(DEEP)
    (tmp / "recursive.yaml").write_text("a: &a [1, *a]\n")
    (tmp / "big.yaml").write_text("# " + "x" * (1 << 20) + "\nrobot: puma560\n")
    (tmp / "digits.yaml").write_text("gravity: " + "9" * 5000 + "\n")
    (tmp / "bogus.yaml").write_text(RIG + "bogus_key: 1\n")
    (tmp / "extra.yaml").write_text(RIG + "contact_extra: {value: 2.0, units: N}\n")
    (tmp / "dup.yaml").write_text(RIG + "gravity: {value: 1.62, units: m s-2}\n")
    (tmp / "misspelt.yaml").write_text(_rig_with("\n  stiffness: {value:", "\n  stifness: {value:"))
    (tmp / "leaf.yaml").write_text(re.sub(r"(\n  stiffness: \{value: [^,]+, )units:", r"\1unit:", RIG, count=1))
    (tmp / "structure.yaml").write_text(_rig_with("    overrides: {}\n", "    overrides: {flexible.beam_lenght: 30.0}\n"))
    calibration = (REPO / "config" / "calibration.yaml").read_text(encoding="utf-8")
    (tmp / "dupcal.yaml").write_text(calibration + "sweep: {}\n")


@pytest.fixture
def check(refused, tmp_path):  # noqa: F811 - the fixture imported above
    """``refused`` with this file's inputs in the scratch folder too."""
    _files(tmp_path)
    return refused


DUP_LINE, DUP_FIRST = RIG.count("\n") + 1, _line_of(RIG, "gravity:")

#: the issue's rows: (argv, text the error line must contain)
ITEM_CASES = [
    # 3: inputs that blew up before their check
    (["map", "workspace", "--resolution", "1e-300", "--out", "m.png"],
     "--resolution = 1e-300 m gives a workspace grid of 2e+300 x 2e+300 = inf points, over the 1,000,000"),
    (["trial", "--speed", "1.5", "--rig", "bomb.yaml", "--out", "t.nc"],
     "bomb.yaml: refused (line 5, column 12): more than 20,000 nodes with its aliases expanded"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--horizontal", "100000"], "--horizontal 100000: at most 3600 directions"),
    # 4: rig files with what they should refuse, seeds out of range
    (["trial", "--speed", "1.5", "--rig", "bogus.yaml", "--out", "t.nc"],
     "rig parameter file bogus.yaml: unknown rig parameter 'bogus_key'"),
    (["trial", "--speed", "1.5", "--rig", "extra.yaml", "--out", "t.nc"],
     "rig parameter file extra.yaml: unknown rig parameter 'contact_extra'; did you mean"),
    (["calibrate", "--rig", "bogus.yaml", "--no-write"], "unknown rig parameter 'bogus_key'"),
    (["trial", "--speed", "1.5", "--rig", "dup.yaml", "--out", "t.nc"],
     f"dup.yaml: refused (line {DUP_LINE}, column 1): key 'gravity' is given twice (first on line {DUP_FIRST})"),
    (["sweep", "--speeds", "1.5", "--campaign-seed", "-1", "--out", "s"],
     "--campaign-seed = -1 is not an integer in [0, 2**63 - 1]"),
    (["sweep", "--speeds", "1.5", "--campaign-seed", str(2**64), "--out", "s"],
     f"--campaign-seed = {2**64} is not an integer in [0, 2**63 - 1]"),
]

#: further rows of our own: resource bombs, YAML edges, float edges
FURTHER_CASES = [
    (["map", "workspace", "--resolution", "5e-324", "--out", "m.png"], "gives a workspace grid of inf x inf"),
    (["map", "workspace", "--resolution", "1e-3", "--out", "m.png"], "2001 x 2001 = 4004001 points"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--cone", "-1,0,0,30", "--count", "100000"],
     "--count 100000: at most 3600 directions"),
    (["sweep", "--speeds", "1.5", "--repeats", "100000000", "--out", "s"], "--repeats 100000000: expected 1 to 100"),
    (["sweep", "--speeds", ",".join(f"{1 + i / 10:.1f}" for i in range(12)), "--repeats", "100", "--out", "s"],
     "10800 trials, over the 10000 one sweep runs"),
    (["sweep", "--speeds", "1.5", "--campaign-seed", str(2**63), "--out", "s"], f"--campaign-seed = {2**63}"),
    (["trial", "--speed", "1.5", "--seed", str(2**63), "--out", "t.nc"], f"seed {2**63} is not an integer in [0, 2**63 - 1]"),
    (["trial", "--speed", "1.5", "--rig", "wide.yaml", "--out", "t.nc"], "wide.yaml: refused (line 1, column"),
    (["trial", "--speed", "1.5", "--rig", "deep.yaml", "--out", "t.nc"], "deep.yaml: refused (line 1, column 51): nested"),
    (["trial", "--speed", "1.5", "--rig", "recursive.yaml", "--out", "t.nc"], "a node that holds it (a recursive alias)"),
    (["trial", "--speed", "1.5", "--rig", "big.yaml", "--out", "t.nc"], "big.yaml: larger than 1 MiB, not read"),
    (["trial", "--speed", "1.5", "--rig", "digits.yaml", "--out", "t.nc"],
     "digits.yaml: not valid YAML: Exceeds the limit (4300 digits)"),
    (["trial", "--speed", "1.5", "--rig", "misspelt.yaml", "--out", "t.nc"],
     "unknown rig parameter 'contact.stifness'; did you mean contact.stiffness"),
    (["trial", "--speed", "1.5", "--rig", "leaf.yaml", "--out", "t.nc"],
     "parameter contact.stiffness has unknown field 'unit'"),
    (["sweep", "--base", "flexible", "--configs", "1", "--gains", "zero", "--speeds", "1.5", "--rig", "structure.yaml",
      "--set", "flexible.structure=stiff_mast", "--out", "s"],
     "structure 'stiff_mast' sets unknown rig parameter 'flexible.beam_lenght'"),
    (["trial", "--speed", "1.5", "--set", "contact.stiffness=&a [*a]", "--out", "t.nc"], "(a recursive alias)"),
    (["trial", "--speed", "1.5", "--set", "contact.stiffness=[1,", "--out", "t.nc"],
     "--set contact.stiffness: the value is not valid YAML"),
    (["calibrate", "--calibration", "bomb.yaml", "--no-write"], "bomb.yaml: refused (line 5, column 12)"),
    (["calibrate", "--calibration", "dupcal.yaml", "--no-write"], "key 'sweep' is given twice"),
    (["sweep", "--speeds", "1e308", "--out", "s"], "1e+308 m/s is beyond what the pendulum can reach"),
    (["trial", "--speed", "1e-320", "--out", "t.nc"], "would be stored as v0.000"),
    (["trial", "--speed", "inf", "--out", "t.nc"], "got inf"),
    (["trial", "--speed", "-0", "--out", "t.nc"], "got -0.0"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--speed", "inf"], "object speed = inf m/s"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--mass", "inf"], "--mass inf"),
    (["plan", "--point", "-0.6,-0.15,-0.15", "--restitution", "nan"], "restitution = nan"),
    (["trial", "--speed", "1.5", "--config", "99999999999999999999", "--out", "t.nc"],
     "unknown configuration 99999999999999999999"),
]

CASES = ITEM_CASES + FURTHER_CASES


@pytest.mark.parametrize("argv, names", CASES, ids=[f"{a[0]} [{n[:40]}]" for a, n in CASES])
def test_cli_refuses_config_and_resource_bombs(check, argv, names):
    check(argv, names)


@pytest.mark.parametrize("value", [" ", "", "\t", "1e9", "99999999999999999999"])
def test_a_blank_or_unreadable_source_date_epoch_is_named(check, value):
    """NumPy reads the variable with int() on import: a blank one was let through and ended
    in a traceback from NumPy's import."""
    check(["trial", "--speed", "1.5", "--out", "t.nc"], f"SOURCE_DATE_EPOCH = {value!r} is not a whole number",
          env={"SOURCE_DATE_EPOCH": value})


def test_enough_rows():
    assert len(FURTHER_CASES) >= 15
    assert len({tuple(a) for a, _ in CASES}) == len(CASES)


# -------------------------------------------------------------------------------------------
# writes that would change what they must not
# -------------------------------------------------------------------------------------------
def test_a_sweep_does_not_replace_another_trial(check, tmp_path, capsys):
    """Twice into the same --out: the same trial is replaced by itself; another seed or
    another rig is refused, the first trial kept as it was."""
    argv = ["sweep", "--configs", "1", "--gains", "zero", "--speeds", "1.5", "--out", "s", "--quiet"]
    assert main(argv) == 0
    capsys.readouterr()
    with h5py.File(tmp_path / "s" / TRIAL) as f:
        seed = int(f.attrs["seed"])
    line = check([*argv, "--campaign-seed", "5"], f"s/{TRIAL} holds another trial (seed {seed}, this sweep's ")
    assert line.endswith("a sweep does not replace another trial: write to another folder or remove it")
    check([*argv, "--set", "contact.stiffness=600"], "holds another trial (another rig)")
    (tmp_path / "t" / "fixed" / "config1" / "zero" / "v1.500").mkdir(parents=True)
    (tmp_path / "t" / TRIAL).write_text("not a trial\n")
    check([*argv[:-3], "--out", "t"], f"t/{TRIAL} is there and is not a readable trial file")
    assert main(argv) == 0       # the same trial: replaced by itself
    with h5py.File(tmp_path / "s" / TRIAL) as f:
        assert int(f.attrs["seed"]) == seed


@pytest.fixture
def finalized(tmp_path) -> Path:
    """A copy of the reference archive (finalized) in the scratch folder."""
    shutil.copytree(REFERENCE, tmp_path / "ref")
    return tmp_path / "ref"


def test_a_sweep_into_a_finalized_archive_is_refused(check, finalized):
    argv = ["sweep", "--configs", "1", "--gains", "zero", "--speeds", "2.5"]
    check([*argv, "--out", "ref"], "--out ref: is a finalized archive (MANIFEST.sha256 lists its files)")
    check([*argv, "--out", "ref/fixed"], f"--out ref/fixed: is inside {finalized}, which is a finalized archive")
    assert main(["archive", "verify", str(finalized)]) == 0


# -------------------------------------------------------------------------------------------
# readers of a corrupt trial: the manifest's sha256, an added group
# -------------------------------------------------------------------------------------------
def _flip_bit(path: Path, at: float = 2 / 3) -> None:
    data = bytearray(path.read_bytes())
    data[int(len(data) * at)] ^= 0x10
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("command", ["identify", "tables", "fit-lambda"])
def test_a_flipped_bit_in_a_finalized_trial_is_refused_by_its_readers(check, finalized, command):
    """A bit flipped at two thirds of the file lands in /truth, which identification never
    reads: the manifest's sha256 catches it, as ``archive verify`` does."""
    _flip_bit(finalized / TRIAL)
    argv = {"identify": ["identify", f"ref/{TRIAL}"], "tables": ["tables", "ref", "--out", "tab"],
            "fit-lambda": ["fit-lambda", "ref"]}[command]
    check(argv, f"{TRIAL}: sha256 differs from {finalized}/MANIFEST.sha256 (altered, corrupt or truncated); "
          f"`campaign archive verify {finalized}` lists every problem")


def test_a_trial_added_to_a_finalized_archive_is_refused_by_its_readers(check, finalized):
    added = finalized / "fixed" / "config1" / "zero" / "v1.500" / "r01.nc"
    shutil.copy(finalized / TRIAL, added)
    check(["identify", str(added)], "r01.nc: not in ")


def test_a_trial_with_an_added_group_is_refused_outside_an_archive(check, tmp_path):
    shutil.copy(REFERENCE / TRIAL, tmp_path / "lone.nc")
    with h5py.File(tmp_path / "lone.nc", "r+") as f:
        f.create_group("extra")
    check(["identify", "lone.nc"], "lone.nc: the root group holds extra; a trial file holds only the groups "
          "measured, truth")


def test_the_manifest_check_hashes_each_trial_once_and_reads_the_manifest_once(monkeypatch):
    """What a reader adds per trial is one sha256 of its file (its cost: benchmarks/bench_integrity.py)."""
    hashed, opened = [], []
    real_hash, real_open = manifest_module.sha256_file, manifest_module.open_regular
    monkeypatch.setattr(manifest_module, "sha256_file", lambda p, *a, **k: hashed.append(Path(p)) or real_hash(p, *a, **k))
    monkeypatch.setattr(manifest_module, "open_regular", lambda p, *a, **k: opened.append(Path(p)) or real_open(p, *a, **k))
    trials = sorted(REFERENCE.rglob("*.nc"))
    check_listed_digests(trials)
    assert sorted(hashed) == trials
    assert [p.name for p in opened].count("MANIFEST.sha256") == 1, opened


# -------------------------------------------------------------------------------------------
# the YAML bomb and its kin, for every YAML file the project reads: within 1 s and 100 MB
# -------------------------------------------------------------------------------------------
_MEASURE = r"""
import json, resource, sys, time
kind, path = sys.argv[1], sys.argv[2]
from campaign.cli.args import key_value
from campaign.model.conventions import read_drives
from campaign.model.robot import load_robot
from campaign.pipeline.calibration import load_calibration
from campaign.pipeline.config import check_config_files
from campaign.pipeline.plan_parts import DesignedPlan
from campaign.scene.description import load_rig

READERS = {
    "rig": lambda p: load_rig(p),
    "workflow config": lambda p: check_config_files([p]),
    "calibration settings": lambda p: load_calibration(p),
    "designed campaign": lambda p: DesignedPlan(settings_file=p, named=True, results_root="r", archive_root="a",
                                                structures=[]),
    "drive file (robot model)": lambda p: read_drives(p),
    "robot model loader": lambda p: load_robot(p),
    "--set value": lambda p: key_value("contact.stiffness=" + open(p).read()),
}
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
try:
    READERS[kind](path)
    message = "accepted"
except Exception as exc:
    message = f"{type(exc).__name__}: {exc}"
seconds = time.perf_counter() - t0
grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
print(json.dumps({"message": message, "seconds": seconds, "grown_kb": grown}))
"""

KINDS = ["rig", "workflow config", "calibration settings", "designed campaign", "drive file (robot model)",
         "robot model loader", "--set value"]
BOMBS = {"alias": (BOMB, "more than 20,000 nodes"), "wide": (WIDE, "more than 20,000 nodes"),
         "deep": (DEEP, "nested more than 50 levels"), "recursive": ("a: &a [1, *a]\n", "recursive alias")}


@pytest.mark.parametrize("bomb", list(BOMBS))
@pytest.mark.parametrize("kind", KINDS)
def test_a_yaml_bomb_is_refused_within_a_second_and_100_mb(tmp_path, kind, bomb):
    text, names = BOMBS[bomb]
    path = tmp_path / "bomb.yaml"
    path.write_text(text)
    proc = subprocess.run([sys.executable, "-c", _MEASURE, kind, str(path)], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)}, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    assert names in got["message"] and "Traceback" not in got["message"], got
    assert got["seconds"] < 1.0, got
    assert got["grown_kb"] < 100 * 1024, got


def test_the_bomb_as_a_rig_file_in_a_real_process(tmp_path):
    """``campaign trial --rig bomb.yaml`` grew past 1.9 GB: the whole command, imports
    included, now stays under 300 MB and ends in seconds with one line."""
    (tmp_path / "bomb.yaml").write_text(BOMB)
    exe = Path(sys.executable).parent / "campaign"
    # a parent of its own, whose only child is the command: its peak memory is the command's
    parent = ("import json, resource, subprocess, sys, time; t0 = time.perf_counter(); "
              "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
              "print(json.dumps({'status': p.returncode, 'stderr': p.stderr, 'seconds': time.perf_counter() - t0, "
              "'peak_kb': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))")
    proc = subprocess.run([sys.executable, "-c", parent, str(exe), "trial", "--speed", "1.5", "--rig", "bomb.yaml",
                           "--out", "t.nc"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    got = json.loads(proc.stdout)
    assert got["status"] == 2 and len(got["stderr"].splitlines()) == 1, got
    assert "more than 20,000 nodes" in got["stderr"]
    assert got["seconds"] < 60 and got["peak_kb"] < 300 * 1024, got
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bomb.yaml"]


def test_the_project_files_pass_the_reader():
    """The limits leave room: every YAML file the project ships reads, the largest far below them."""
    files = [p for p in REPO.rglob("*.yaml") if ".venv" not in p.parts and "archive" not in p.parts]
    assert len(files) > 10
    for path in files:
        read_yaml(path)
    assert max(p.stat().st_size for p in files) < MAX_YAML_BYTES / 20


# -------------------------------------------------------------------------------------------
# the workflow: each row's dry run
# -------------------------------------------------------------------------------------------
def _edited_units(work: Path) -> None:
    """A reuse archive (finalized) whose one trial has an edited ``units`` attribute."""
    shutil.copytree(REFERENCE, work / "ref")
    with h5py.File(work / "ref" / TRIAL, "r+") as f:
        name = next(n for n in f["measured"] if "units" in f["measured"][n].attrs)
        f["measured"][name].attrs["units"] = "furlongs"


def _rig_file(work: Path) -> None:
    (work / "bogus.yaml").write_text(RIG + "bogus_key: 1\n")


def _designed_bomb(work: Path) -> None:
    """A configuration folder whose designed campaign's settings are the bomb."""
    shutil.copytree(REPO / "config", work / "cfg")
    (work / "cfg" / "designed.yaml").write_text(BOMB)


#: (change to config/tests/ci.yaml: a dict merged in, a list of --config arguments, or text
#: appended to the file; text the error must contain; prepare the folder; environment)
WORKFLOW_CASES = [
    ({"plan_maps": {"resolution": 1e-300, "config": 1}},
     "configuration key plan_maps.resolution = 1e-300 m gives a workspace grid of 2e+300 x 2e+300", None, {}),
    ({"archive_root": "same", "results_root": "same"},
     "configuration key results_root: 'same' is also archive_root", None, {}),
    ({"archive_root": "same", "results_root": "./same/"},
     "configuration key results_root: './same/' is also archive_root", None, {}),
    ({"campaign_seed": 1e30}, "configuration key campaign_seed: 1e+30 is not of type 'integer'", None, {}),
    ({"campaign_seed": 2**64}, f"configuration key campaign_seed: {2**64} is greater than the maximum", None, {}),
    ({"campaign_seed": 5.0}, "configuration key campaign_seed: 5.0 is not of type 'integer'", None, {}),
    ({"repeats": 2.0}, "configuration key repeats: 2.0 is not of type 'integer'", None, {}),
    (["campaign_seed=-1"], "configuration key campaign_seed: -1 is less than the minimum of 0", None, {}),
    ({"rig": "bogus.yaml"}, "rig parameter file bogus.yaml: unknown rig parameter 'bogus_key'", _rig_file, {}),
    ("repeats: 2\n", "c.yaml: refused (line {n}, column 1): key 'repeats' is given twice (first on line", None, {}),
    ({}, "cfg/designed.yaml: refused (line 5, column 12): more than 20,000 nodes", _designed_bomb,
     {"CAMPAIGN_CONFIG_DIR": "{work}/cfg"}),
    ({"campaign": "sde"}, "SOURCE_DATE_EPOCH = ' ' is not a whole number", None, {"SOURCE_DATE_EPOCH": " "}),
    ({"simulate": False, "reuse_archive": "ref"},
     f"configuration key reuse_archive: ref/{TRIAL}: sha256 differs from MANIFEST.sha256", _edited_units, {}),
]


@pytest.fixture(scope="module")
def workflow_runs(tmp_path_factory):
    """Each row's dry run in its own folder: (folder, output, status, config text)."""
    base = yaml.safe_load((REPO / "config" / "tests" / "ci.yaml").read_text())
    runs = []
    for i, (change, _, prepare, env) in enumerate(WORKFLOW_CASES):
        work = tmp_path_factory.mktemp(f"wfc{i}")
        if prepare:
            prepare(work)
        extra: list[str] = []
        text = yaml.safe_dump({**base, **change} if isinstance(change, dict) else base, sort_keys=False)
        if isinstance(change, list):
            extra = ["--config", *change]
        elif isinstance(change, str):
            text += change
        (work / "c.yaml").write_text(text)
        before = snapshot(work)
        args = ["-s", str(REPO / "Snakefile"), "--directory", str(work), "-n", "--configfile", str(work / "c.yaml"),
                *extra]
        env = {k: v.format(work=work) for k, v in env.items()}
        proc = snakemake_forks.run(args, cwd=work, env={**os.environ, **env}, timeout=600)
        runs.append((work, proc.stdout + proc.stderr, proc.returncode, text, before))
    return runs


@pytest.mark.parametrize("index", range(len(WORKFLOW_CASES)), ids=[str(c[0])[:40] for c in WORKFLOW_CASES])
def test_workflow_dry_run_refuses_the_config(workflow_runs, index):
    work, output, status, text, before = workflow_runs[index]
    names = WORKFLOW_CASES[index][1].replace("{n}", str(text.count("\n")))
    assert status != 0, output
    assert names in output, output
    assert "Traceback" not in output, output
    assert {k: v for k, v in snapshot(work).items() if not k.startswith(".snakemake")} == \
        {k: v for k, v in before.items() if not k.startswith(".snakemake")}
    assert not (work / "archive").exists() and not (work / "results").exists() and not (work / "same").exists()


def test_the_reuse_check_hashes_each_listed_file_once(monkeypatch):
    """The start-up check of a reused archive reads each listed file once and nothing else
    (its cost: benchmarks/bench_integrity.py)."""
    hashed = []
    real = paths_module.sha256_file
    monkeypatch.setattr(paths_module, "sha256_file", lambda p, *a, **k: hashed.append(Path(p)) or real(p, *a, **k))
    trials = [str(p) for p in sorted(REFERENCE.rglob("*.nc"))]
    check_manifest(REFERENCE, trials)
    listed = [line.split("  ", 1)[1] for line in (REFERENCE / "MANIFEST.sha256").read_text().splitlines()]
    assert sorted(hashed) == sorted(REFERENCE / rel for rel in listed)
    assert len(set(hashed)) == len(hashed)