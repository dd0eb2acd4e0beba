"""The tolerance policy (campaign.core.tolerance): each quantity is judged on its own scale,
quantised channels may flip by one step on a few samples, the worst offender is named, and
identification results compare on the scale of each result; an identification table keeps
the rows that did not move."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from campaign.core.tolerance import (
    CROSS_MACHINE_RTOL,
    CROSS_PATH_RTOL,
    IDENTIFY_RTOL,
    QUANTUM_FLIP_FRACTION,
    compare,
    differences,
    identification_differences,
    worst,
)
from campaign.pipeline.stages import export_identification


def test_a_value_near_zero_is_judged_on_its_channels_scale_not_its_own():
    v = np.array([2.5, 1.0, 5.4e-6, -0.7])
    moved = v.copy()
    moved[2] += 1e-12            # 2e-7 of the value itself, 4e-13 of the channel's 2.5
    d = compare(v, moved, name="v", rtol=CROSS_PATH_RTOL)
    assert d.ok and d.scale == 2.5 and d.relative == pytest.approx(1e-12 / 2.5)
    moved[2] += 1e-10            # now 4e-11 of the channel: beyond
    d = compare(v, moved, name="v", rtol=CROSS_PATH_RTOL)
    assert not d.ok and "v: largest difference" in str(d)


def test_columns_of_a_state_are_each_judged_on_their_own_scale():
    x = np.column_stack([np.linspace(0, 2.0, 50), np.linspace(0, 1e-3, 50)])
    moved = x.copy()
    moved[:, 1] *= 1 + 1e-9      # 1e-12 absolute: roundoff against column 0, a real change of column 1
    assert compare(x, moved, name="x", rtol=CROSS_PATH_RTOL).ok
    d = compare(x, moved, name="x", rtol=CROSS_PATH_RTOL, per_column=True)
    assert not d.ok and d.name == "x[1]" and d.scale == pytest.approx(1e-3)


def test_a_zero_scale_allows_nothing_but_the_floor():
    zero = np.zeros(5)
    assert compare(zero, zero, rtol=CROSS_PATH_RTOL).ok
    tiny = zero + 1e-300
    assert not compare(zero, tiny, rtol=CROSS_PATH_RTOL, scale=0.0).ok
    assert compare(zero, tiny, rtol=CROSS_PATH_RTOL, scale=0.0, floor=1e-299).ok


def test_nan_shape_text_and_integers_compare_exactly():
    a = np.array([1.0, np.nan, 3.0])
    assert compare(a, a.copy(), rtol=CROSS_PATH_RTOL).ok
    assert not compare(a, np.array([1.0, 2.0, 3.0]), rtol=CROSS_PATH_RTOL).ok
    d = compare(np.zeros(3), np.zeros(4), name="t", rtol=1.0)
    assert not d.ok and "shape (3,) against (4,)" in str(d)
    assert compare(np.array(["q1", "q2"]), np.array([b"q1", b"q2"], dtype=object), rtol=0.0).ok
    assert not compare(np.array(["q1", "q2"]), np.array(["q1", "q3"]), rtol=1.0).ok
    # counts have no roundoff: one step in a thousand is a difference
    assert not compare(np.array([1000]), np.array([1001]), rtol=CROSS_MACHINE_RTOL).ok


def test_a_quantised_channel_may_flip_by_one_step_on_a_bounded_fraction_of_its_samples():
    step = 0.01
    f = np.round(np.sin(np.linspace(0, 3, 20000)) * 50 / step) * step
    allowed = int(QUANTUM_FLIP_FRACTION * f.size)
    flipped = f.copy()
    flipped[:allowed] += step
    d = compare(f, flipped, name="f_piezo", rtol=CROSS_MACHINE_RTOL, quantum=step)
    assert d.ok and d.flips == allowed and d.largest == 0
    flipped[allowed] += step     # one more than the policy allows
    assert not compare(f, flipped, rtol=CROSS_MACHINE_RTOL, quantum=step).ok
    twice = f.copy()
    twice[3] += 2 * step         # two steps is no rounding flip
    d = compare(f, twice, rtol=CROSS_MACHINE_RTOL, quantum=step)
    assert not d.ok and d.flips == 0 and d.largest == pytest.approx(2 * step)
    # a short channel: one flip, whatever its length; a step per column
    q = np.zeros((30, 2))
    q2 = q.copy()
    q2[4, 1] = 0.5
    assert compare(q, q2, rtol=CROSS_MACHINE_RTOL, quantum=[1.0, 0.5]).ok
    assert not compare(q, q2, rtol=CROSS_MACHINE_RTOL, quantum=[1.0, 0.25]).ok


def test_differences_name_the_worst_channel_and_take_related_scales():
    a = {"v_b_pre": np.float64(2.5), "v_a_post": np.float64(1e-4), "t_truth": np.linspace(0, 0.6, 7),
         "contact_end": np.float64(0.27)}
    b = dict(a, v_a_post=np.float64(1e-4 + 1e-12), contact_end=np.float64(0.27 + 1e-6))
    found = differences(a, b, rtol=CROSS_MACHINE_RTOL, prefix="truth/")
    assert [d.name for d in found] == sorted(f"truth/{k}" for k in a)
    by = {d.name: d for d in found}
    # the arm's velocity on the hammer's speed (2.5), the contact's end on the recording's 0.6 s
    assert by["truth/v_a_post"].scale == 2.5 and by["truth/v_a_post"].ok
    assert by["truth/contact_end"].scale == pytest.approx(0.6) and not by["truth/contact_end"].ok
    assert worst(found).name == "truth/contact_end"
    missing = differences(a, {k: v for k, v in a.items() if k != "t_truth"}, rtol=1.0)
    assert not worst(missing).ok and "only in the first" in str(worst(missing))
    assert worst([]).ok


def test_identification_results_compare_on_each_results_scale():
    stored = {"speed": "1.5", "m_eff": "31.2", "e": "0.55", "v_a": "5.4304e-06", "contact_start": "0.2",
              "contact_end": "0.27", "reason": "", "peak_force": "", "excluded": "0", "q_cmd": "0.0 2.6 0.0"}
    # another machine: an arm velocity near zero moved by 1.2e-8 m/s (2e-3 of itself, 8e-9 of the
    # hammer's speed), m* by 1e-6 of itself, the contact's end by 1e-9 s
    new = {"speed": 1.5, "m_eff": 31.2 * (1 + 1e-6), "e": 0.55 + 5e-8, "v_a": 5.4426e-06, "contact_start": 0.2,
           "contact_end": 0.27 + 1e-9, "reason": "", "peak_force": float("nan"), "excluded": False,
           "q_cmd": (0.0, 2.6, 0.0)}
    found = identification_differences(stored, new, name="r00")
    assert len(found) == len(stored) and worst(found).ok, [str(d) for d in found if not d.ok]
    for key, value in (("m_eff", 31.2 * (1 + 3 * IDENTIFY_RTOL)), ("e", 0.55 + 3 * IDENTIFY_RTOL),
                       ("v_a", 5.4e-6 + 3 * IDENTIFY_RTOL * 1.5), ("contact_end", 0.27 + 3 * IDENTIFY_RTOL * 0.07),
                       ("reason", "no contact"), ("excluded", True)):
        moved = worst(identification_differences(stored, {**new, key: value}, name="r00"))
        assert not moved.ok and moved.name == f"r00: {key}", (key, str(moved))


def _table(path, rows):
    header = ["path", "speed", "m_eff", "e", "reason"]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
    return path


def test_an_identification_table_keeps_its_rows_that_did_not_move(tmp_path, capsys):
    out = _table(tmp_path / "identification.csv", [["a.nc", "1.5", "26.606125502486695", "0.53", ""],
                                                   ["b.nc", "2.5", "31.6", "0.53", ""]])
    before = out.read_bytes()
    # recomputed elsewhere: a's m* moved by 1e-8 of itself (roundoff), b's by 1e-3 (a change)
    new = _table(tmp_path / "new.csv", [["b.nc", "2.5", "31.6316", "0.53", ""],
                                        ["a.nc", "1.5", "26.606125768547", "0.53", ""]])
    export_identification([new], out)
    printed = capsys.readouterr().out
    assert "kept 1 of 2 rows" in printed and "moved beyond the tolerance, rewritten: b.nc: m_eff" in printed
    rows = list(csv.reader(out.open(encoding="utf-8")))
    assert rows[1] == ["a.nc", "1.5", "26.606125502486695", "0.53", ""]      # as it was
    assert rows[2] == ["b.nc", "2.5", "31.6316", "0.53", ""]                  # the new one
    # nothing moved: the file is left as it is
    out.write_bytes(before)
    export_identification([_table(tmp_path / "same.csv", [["a.nc", "1.5", "26.606125768547", "0.53", ""],
                                                          ["b.nc", "2.5", "31.6", "0.53", ""]])], out)
    assert out.read_bytes() == before
    # other columns: written as computed
    other = tmp_path / "other.csv"
    other.write_text("path,m_eff\na.nc,1.0\n", encoding="utf-8")
    export_identification([new], other)
    assert next(csv.reader(other.open(encoding="utf-8"))) == ["path", "speed", "m_eff", "e", "reason"]
