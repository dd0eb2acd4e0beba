"""Recorded hits without real data: the rig's own trial exported in the air-hockey layout, with
a logger's quirks, imported and identified against the rig's truth; the generic CSV layout
round trip; the cleaning steps on their own."""

from __future__ import annotations

import csv

import h5py
import numpy as np
import pytest
import yaml

from campaign.cli.main import main
from campaign.recordings import (
    NO_LICENCE,
    RecordedHitOptions,
    drop_stale,
    export_airhockey,
    identify_recording,
    read_airhockey_hit,
    read_recording,
    recording_files,
    repair_stamps,
    truth_of,
    verify_recordings,
)

LEAD = 0.006
#: the rig's zero-gain arm in configuration 3 struck at 1.5 m/s by a 2 kg hammer head on a stiff
#: pad: a contact of about 9 ms and a velocity change of the arm of about 40 % of the speed, the
#: conditions of the air-hockey hits with the 1.9 kg box (the rig's default 0.7 kg hammer on its
#: soft pad is an object too light against m*, over a 70 ms contact)


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """A rig trial exported as session ``rig`` (hit 1), imported, identified: (folder, rows, truth)."""
    tmp = tmp_path_factory.mktemp("recordings")
    trial = tmp / "trial.nc"
    assert main(["trial", "--config", "3", "--gain", "zero", "--speed", "1.5", "--set", "pendulum.head_mass=2.0",
                 "--set", "contact.stiffness=40000", "--out", str(trial), "--quiet"]) == 0
    export_airhockey(trial, tmp / "src" / "rig", hit=1, clock_lead=LEAD, seed=0)
    truth = truth_of(trial)
    assert main(["import", "--format", "airhockey", str(tmp / "src" / "rig"), "--object-mass",
                 repr(truth["object_mass"]), "--out", str(tmp / "rec")]) == 0
    assert main(["identify-recordings", str(tmp / "rec"), "--out", str(tmp / "hits.csv"), "--bootstrap", "200"]) == 0
    with open(tmp / "hits.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return tmp, rows, truth


def test_round_trip_recovers_the_rigs_truth_within_the_intervals(imported):
    _, rows, truth = imported
    (row,) = rows
    assert row["flag"] == "ok"
    assert float(row["m_eff_lo"]) <= truth["m_eff"] <= float(row["m_eff_hi"])
    assert float(row["e_lo"]) <= truth["e"] <= float(row["e_hi"])
    # an interval that says something: narrower than half of m* (a wider one flags the hit)
    assert 0 < float(row["m_eff_hi"]) - float(row["m_eff_lo"]) < 0.5 * truth["m_eff"]
    # the hammer is struck back along -n of the rig: the object's velocity change points along +x
    assert float(row["n_x"]) > 0.99
    # the rig's contact lasts as long as the range of durations the samples allow
    assert (float(row["contact_duration_lo"]) <= truth["contact_end"] - truth["contact_start"]
            <= float(row["contact_duration_hi"]))
    # the logged model is the rig's eq 7 (rotor inertia included): the momentum balance's m* is
    # heavier, as the joints' friction resists the contact too
    assert 0 < float(row["m_eff_logged"]) < truth["m_eff"]


#: export seeds drawn after the identification's last change, not used to develop it; on them (and
#: 30 such seeds of this trial and of three more rig trials, docs/recordings.rst) every hit the
#: identification did not refuse had the truth inside its 95 % intervals but three of 116
COVERAGE_SEEDS = range(300, 310)


def test_intervals_hold_the_truth_over_export_seeds(imported):
    """The interval's coverage, measured: the same rig hit exported with the logger's quirks drawn
    anew (noise, stale rows, glitches), imported and identified; the 95 % intervals hold the
    truth's m* and e in all but at most one of the hits identified, and at most one is refused."""
    tmp, _, truth = imported
    rows = []
    for seed in COVERAGE_SEEDS:
        robot_file, object_file = export_airhockey(tmp / "trial.nc", tmp / "coverage" / str(seed), hit=1,
                                                   clock_lead=LEAD, seed=seed)
        rec = read_airhockey_hit(robot_file, object_file, object_mass=truth["object_mass"], session="rig", hit="1")
        rows.append(identify_recording(rec, RecordedHitOptions(n_boot=200)))
    identified = [r for r in rows if not r["flag"].startswith("refused")]
    assert len(identified) >= len(rows) - 1
    for key in ("m_eff", "e"):
        covered = sum(r[f"{key}_lo"] <= truth[key] <= r[f"{key}_hi"] for r in identified)
        assert covered >= len(identified) - 1, (key, covered, len(identified))
    # intervals that say something: m* to within +-15 % (the window's placement costs the most)
    assert all(r["m_eff_hi"] - r["m_eff_lo"] < 0.3 * truth["m_eff"] for r in identified)


def test_import_handles_the_loggers_quirks(imported):
    tmp, rows, _ = imported
    (path,) = recording_files(tmp / "rec")
    with h5py.File(path, "r") as f:
        robot, obj = dict(f["robot"].attrs), dict(f["object"].attrs)
        assert set(f) == {"robot", "object"}          # what was recorded; no truth
        assert f["robot/ee_position"].attrs["units"] == "m"
        assert f["object/position"].attrs["units"] == "m"
        assert f.attrs["license"] == NO_LICENCE
        assert f.attrs["object_mass"] == pytest.approx(truth_of(tmp / "trial.nc")["object_mass"])
    assert robot["stale_rows_dropped"] > 0
    assert robot["stamps_repaired"] == 2               # the two glitched stamps the export put in
    assert abs(obj["clock_offset"] - LEAD) < 0.001     # the motion capture's lead, found
    rec = read_recording(path)
    assert np.all(np.diff(rec.t_robot) > 0.004)         # no stale rows, no glitched stamps left
    assert float(rows[0]["clock_offset"]) == pytest.approx(obj["clock_offset"], rel=1e-5)


def test_recording_folder_verifies_and_reports_damage(imported, capsys):
    tmp, _, _ = imported
    assert main(["archive", "verify", str(tmp / "rec")]) == 0
    assert verify_recordings(tmp / "rec") == []
    (path,) = recording_files(tmp / "rec")
    data = bytearray(path.read_bytes())
    data[-200] ^= 0xFF
    damaged = tmp / "damaged"
    (damaged / "rig").mkdir(parents=True)
    for name in ("index.csv", "README.md", "MANIFEST.sha256"):
        (damaged / name).write_bytes((tmp / "rec" / name).read_bytes())
    (damaged / "rig" / path.name).write_bytes(bytes(data))
    capsys.readouterr()
    assert main(["archive", "verify", str(damaged)]) == 1
    assert f"rig/{path.name}" in capsys.readouterr().out


def test_linear_fits_are_selectable_and_stated(imported):
    tmp, _, _ = imported
    (path,) = recording_files(tmp / "rec")
    rec = read_recording(path)
    quad = identify_recording(rec, RecordedHitOptions(n_boot=50))
    line = identify_recording(rec, RecordedHitOptions(fit="linear", n_boot=50))
    assert (quad["fit"], line["fit"]) == ("quadratic", "linear")
    # the arm decelerates after the contact: a straight line through its samples misses that
    assert line["m_eff"] != pytest.approx(quad["m_eff"], rel=0.05)


def test_too_few_samples_after_the_contact_refuse_the_hit(imported):
    tmp, _, _ = imported
    (path,) = recording_files(tmp / "rec")
    rec = read_recording(path)
    keep = rec.t_robot < float(rec.t_robot[0]) + 0.24      # the robot's log stops early in the contact
    rec.t_robot, rec.q, rec.ee_position = rec.t_robot[keep], rec.q[keep], rec.ee_position[keep]
    rec.qd = rec.ee_velocity = rec.inertia_inv = None
    row = identify_recording(rec, RecordedHitOptions(n_boot=50))
    assert row["flag"].startswith("refused: too few samples") and row["m_eff"] == ""


def test_a_light_object_is_flagged(imported):
    tmp, _, truth = imported
    (path,) = recording_files(tmp / "rec")
    rec = read_recording(path)
    row = identify_recording(rec, RecordedHitOptions(n_boot=50, min_dv_ratio=0.5))
    assert row["flag"].startswith("poor: object too light against m*")
    assert row["m_eff"] != ""


def test_generic_csv_round_trip(imported, tmp_path):
    """The imported hit written as plain CSV (ms, mm, deg, the object in a turned frame) and read
    back through a mapping file: the same samples, the same identification within its intervals."""
    tmp, _, _ = imported
    (path,) = recording_files(tmp / "rec")
    rec = read_recording(path)
    with open(tmp_path / "arm.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_ms", "X", "Y", "Z", "j1", "j2", "j3"])
        for t, p, q in zip(rec.t_robot, rec.ee_position, rec.q, strict=True):
            w.writerow([repr(float(1e3 * t)), *map(lambda v: repr(float(1e3 * v)), p), *map(lambda v: repr(float(np.degrees(v))), q)])
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])   # object frame -> robot frame
    shift = np.array([0.1, -0.2, 0.05])
    with open(tmp_path / "box.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "bx", "by", "bz"])
        for t, p in zip(rec.t_object, rec.object_position, strict=True):
            w.writerow([repr(float(t)), *(repr(float(v)) for v in turn.T @ (p - shift))])
    mapping = {"object_mass": rec.object_mass, "robot_name": "rig", "session": "csv", "hit": "7",
               "robot": {"file": "arm.csv", "time": {"column": "time_ms", "units": "ms"},
                         "ee_position": {"columns": ["X", "Y", "Z"], "units": "mm"},
                         "joint_position": {"columns": ["j1", "j2", "j3"], "units": "deg"}},
               "object": {"file": "box.csv", "time": {"column": "t", "units": "s"},
                          "position": {"columns": ["bx", "by", "bz"], "units": "m"},
                          "frame": {"rotation": turn.tolist(), "translation": shift.tolist()},
                          "clock_offset": 0.0}}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping))
    assert main(["import", "--format", "csv", "--mapping", str(tmp_path / "map.yaml"), "--out",
                 str(tmp_path / "rec")]) == 0
    assert main(["archive", "verify", str(tmp_path / "rec")]) == 0
    back = read_recording(tmp_path / "rec" / "csv" / "hit_007.nc")
    np.testing.assert_allclose(back.ee_position, rec.ee_position, atol=1e-12)
    np.testing.assert_allclose(back.q, rec.q, atol=1e-12)
    np.testing.assert_allclose(back.object_position, rec.object_position, atol=1e-12)
    np.testing.assert_allclose(back.t_object - back.t_object[0], rec.t_object - rec.t_object[0], atol=1e-12)
    a = identify_recording(rec, RecordedHitOptions(n_boot=50))
    b = identify_recording(back, RecordedHitOptions(n_boot=50))
    # the same samples to rounding: the same m* and e within each other's intervals (the window
    # search is discrete, so a rounding-level difference may pick a neighbouring window)
    assert a["m_eff_lo"] <= b["m_eff"] <= a["m_eff_hi"] and b["m_eff_lo"] <= a["m_eff"] <= b["m_eff_hi"]
    assert a["e_lo"] <= b["e"] <= a["e_hi"] and b["e_lo"] <= a["e"] <= b["e_hi"]


def test_stale_rows_and_glitched_stamps():
    pose = np.array([[0.0], [1.0], [1.0], [2.0], [2.0], [2.0], [3.0]])
    assert drop_stale(pose).tolist() == [True, True, False, True, False, False, True]
    t = np.arange(10) * 0.005
    t[4] += 0.005                                # one stamp a period late
    t[7] -= 0.005                                # one a period early
    fixed, keep, report = repair_stamps(t)
    np.testing.assert_allclose(fixed, np.arange(10) * 0.005, atol=1e-12)
    assert report.repaired == 2 and keep.all()
