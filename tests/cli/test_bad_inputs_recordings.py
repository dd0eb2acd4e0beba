"""Bad input to ``campaign import`` and ``campaign identify-recordings``: one line naming the
value at fault, exit status 2, nothing written (the checks of ``tests/cli/test_bad_inputs.py``)."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest
import yaml

from campaign.cli.main import main


def snapshot(root: Path) -> dict[str, tuple]:
    """Every entry under ``root``: its type, and for a file its size and modification time."""
    out = {}
    for path in sorted(root.rglob("*")):
        st = path.lstat()
        out[str(path.relative_to(root))] = ((st.st_mode,) if stat.S_ISDIR(st.st_mode)
                                            else (st.st_mode, st.st_size, st.st_mtime_ns))
    return out


def _robot_csv(rows: int) -> str:
    lines = ["DesiredFlux,1,HitTime,1700000000.5,DesiredPos,0 0 0",
             "RobotName,RosTime,JointPosition,JointVelocity,JointEffort,TorqueCmd,EEF_Position,EEF_Orientation,"
             "EEF_Velocity,EEF_DesiredVelocity,Inertia,DirGrad,HittingFlux"]
    for k in range(rows):
        lines.append(f"ARM_1,{1700000000 + 0.005 * k:.4f}, 0 {0.001 * k} 0, 0 0 0,0 0 0,0 0 0, {0.001 * k} 0 0,"
                     "0 0 0 1,0 0 0,0 0 0,1 0 0 0 1 0 0 0 1,0 0 0,0")
    return "\n".join(lines) + "\n"


def _object_csv(rows: int) -> str:
    return "RosTime,PositionForArm1\n" + "".join(f"{1700000000 + 0.005 * k:.4f},0.5 0 0\n" for k in range(rows))


def _mapping(tmp: Path, **change) -> Path:
    spec = {"object_mass": 1.0,
            "robot": {"file": "arm.csv", "time": {"column": "t", "units": "s"},
                      "ee_position": {"columns": ["x", "y", "z"], "units": "m"}},
            "object": {"file": "box.csv", "time": {"column": "t", "units": "s"},
                       "position": {"columns": ["bx", "by", "bz"], "units": "m"}}}
    for path, value in change.items():
        *keys, last = path.split("__")
        node = spec
        for key in keys:
            node = node[key]
        if value is None:
            node.pop(last)
        else:
            node[last] = value
    name = tmp / f"map_{abs(hash(repr(sorted(change.items())))) % 10**6}.yaml"
    name.write_text(yaml.safe_dump(spec))
    return name


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    """Two air-hockey sessions (one too short) and CSV files a mapping can name."""
    for name, rows in (("good", 60), ("short", 8)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "ARM_1_hit_1.csv").write_text(_robot_csv(rows))
        (tmp_path / name / "object_1_hit_1.csv").write_text(_object_csv(rows))
    (tmp_path / "arm.csv").write_text("t,x,y,z\n" + "".join(f"{0.005 * k},{0.001 * k},0,0\n" for k in range(60)))
    (tmp_path / "box.csv").write_text("t,bx,by,bz\n" + "".join(f"{0.005 * k},0.5,0,0\n" for k in range(60)))
    (tmp_path / "shortarm.csv").write_text("t,x,y,z\n" + "".join(f"{0.005 * k},{0.001 * k},0,0\n" for k in range(8)))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _refused(argv: list[str], names: str, tmp: Path, capsys) -> None:
    before = snapshot(tmp)
    try:
        got = main(argv)
    except SystemExit as exc:
        got = exc.code
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert got == 2, (out, err)
    assert out == "" and len(lines) == 1, (out, err)
    assert lines[0].startswith("campaign") and ": error: " in lines[0], lines[0]
    assert names in lines[0], lines[0]
    assert "Traceback" not in err
    assert snapshot(tmp) == before
    assert list(tmp.rglob(".*.tmp")) == []


def test_mapping_names_a_missing_column(inputs, capsys):
    bad = _mapping(inputs, robot__ee_position={"columns": ["x", "y", "w"], "units": "m"})
    _refused(["import", "--format", "csv", "--mapping", str(bad), "--out", "rec"], "column(s) 'w'", inputs, capsys)


def test_mapping_with_inconsistent_units(inputs, capsys):
    bad = _mapping(inputs, object__position={"columns": ["bx", "by", "bz"], "units": ["m", "mm", "m"]})
    _refused(["import", "--format", "csv", "--mapping", str(bad), "--out", "rec"], "inconsistent units", inputs,
             capsys)


def test_mapping_with_a_unit_of_the_wrong_kind(inputs, capsys):
    bad = _mapping(inputs, robot__time={"column": "t", "units": "mm"})
    _refused(["import", "--format", "csv", "--mapping", str(bad), "--out", "rec"], "units 'mm' are not a time unit",
             inputs, capsys)


def test_a_hit_without_enough_samples(inputs, capsys):
    _refused(["import", "--format", "airhockey", "good", "short", "--object-mass", "1.9", "--out", "rec"],
             "8 rows, fewer than the 20", inputs, capsys)


def test_a_mapped_hit_without_enough_samples(inputs, capsys):
    bad = _mapping(inputs, robot__file="shortarm.csv")
    _refused(["import", "--format", "csv", "--mapping", str(bad), "--out", "rec"], "fewer than the 20", inputs, capsys)


def test_a_missing_object_mass(inputs, capsys):
    _refused(["import", "--format", "airhockey", "good", "--out", "rec"], "--object-mass is missing", inputs, capsys)


def test_a_mapping_without_object_mass(inputs, capsys):
    bad = _mapping(inputs, object_mass=None)
    _refused(["import", "--format", "csv", "--mapping", str(bad), "--out", "rec"], "object_mass is missing", inputs,
             capsys)


def test_a_negative_object_mass(inputs, capsys):
    _refused(["import", "--format", "airhockey", "good", "--object-mass", "-1", "--out", "rec"],
             "--object-mass '-1'", inputs, capsys)


def test_identify_an_empty_folder(inputs, capsys):
    _refused(["identify-recordings", "good", "--out", "hits.csv"], "no recorded hits", inputs, capsys)
