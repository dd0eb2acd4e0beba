"""Messages that name the real problem, options that are refused rather than ignored, and
values at the edges of floats, as a new user types them.

Each row is one command and a string its error line must contain. :func:`refused` (from
``test_bad_inputs``) asserts one line ``campaign <cmd>: error: ...`` on stderr and nothing on
stdout, the documented exit status 2, nothing written or changed in the scratch folder and
nothing under a temporary name, no traceback; :func:`quiet` adds that no ``RuntimeWarning``
is raised on the way (whichever module raises it, NumPy's own included). A few values that
used to be refused for the wrong reason are valid and must give the answer (the last tests).
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import pytest
from test_bad_inputs import TRIAL, refused  # noqa: F401  (refused: the shared fixture)

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.plan.grid import grid_points

POINT = "-0.6,-0.15,-0.15"       # a point the arm reaches with two branches

#: the issue's rows: a message that named the wrong problem, an option silently ignored, a
#: figure drawn from one grid point; each (argv, text the error line must contain)
ITEM_CASES = [
    # messages that name the wrong problem
    (["trial", "--speed", "1.5", "--rig", "fifo", "--out", "t.nc"],
     "rig parameter file fifo: is a FIFO, not a regular file"),
    (["trial", "--speed", "1.5", "--rig", "folder", "--out", "t.nc"],
     "rig parameter file folder: is a folder, not a regular file"),
    (["identify", "fifo"], "fifo: is a FIFO, not a regular file"),
    (["meff", "--robot", "planar2", "--config", "1", "--model", "--gain", "high", "--speed", "2"],
     "--robot planar2: --model config/response_model.json (shipped) predicts for the rig's robot 'puma560'"),
    (["map", "workspace", "--y", "nan", "--out", "m.png"], "--y nan: the plane of the workspace map must be a finite"),
    (["design", "--calibration", str(TRIAL)], f"identification table {TRIAL}: not a CSV table (not UTF-8 text"),
    (["design", "--candidates", "random", "--seed=-1"], "--seed -1: the seed of the random candidates must be"),
    (["plan", "--point=-1e308,0,0"], "point (-1e+308, 0, 0) m is out of the arm's reach"),
    (["plan", "--point", POINT, "--lambda", "high=53.18,8.66,2.83", "--mass=1e9"],
     "--mass 1e+09 kg at --speed 2 m/s: the planner's contact model cannot predict this impact"),
    # options silently ignored
    (["map", "directions", "--config", "2", "--q", "0,150,90", "--out", "d.png"],
     "argument --q: not allowed with argument --config"),
    (["plan", "--point", POINT, "--weights", "1,2,3"],
     "--weights 1,2,3: weigh the weighted objective only; give --objective weighted too"),
    # a map of one grid point
    (["map", "workspace", "--resolution", "1.5", "--out", "m.png"],
     "--resolution = 1.5 m gives a workspace grid of 2 x 2 points, fewer than the 5 a side"),
]

#: further cases: readers of special files, values at the edges of floats, empty strings,
#: unicode in options
FURTHER_CASES = [
    (["trial", "--speed", "1.5", "--rig", "device", "--out", "t.nc"], "rig parameter file device: is a"),
    (["identify", "device"], "device: is a"),
    (["identify", "folder"], "folder: is a folder, not a regular file"),
    (["design", "--calibration", "fifo"], "identification table fifo: is a FIFO, not a regular file"),
    (["design", "--calibration", "folder"], "identification table folder: is a folder, not a regular file"),
    (["design", "--calibration", "no_such.csv"], "identification table no_such.csv: does not exist"),
    (["design", "--candidates", "fifo"], "candidate file fifo: is a FIFO, not a regular file"),
    (["design", "--candidates", str(TRIAL)], f"candidate file {TRIAL}: not a CSV table (not UTF-8 text"),
    (["design", "--candidates", "random", "--seed=-340282366920938463463374607431768211457"],
     "--seed -340282366920938463463374607431768211457"),
    (["design", "--candidates", "random", "--n-random", "0"], "--n-random 0: must be >= 1"),
    (["map", "workspace", "--resolution", "inf", "--out", "m.png"], "--resolution inf: must be a finite step > 0"),
    (["map", "workspace", "--resolution", "0.6", "--out", "m.png"], "gives a workspace grid of 4 x 4 points"),
    (["map", "workspace", "--y=-inf", "--out", "m.png"], "--y -inf: the plane of the workspace map"),
    (["map", "workspace", "--y", "\u22120.1", "--out", "m.png"], "argument --y: invalid float value"),
    (["map", "workspace", "--config", "2", "--out", "m.png"], "--config 2: is the direction map's"),
    (["map", "workspace", "--q", "0,150,90", "--out", "m.png"], "--q 0,150,90: is the direction map's"),
    (["map", "directions", "--y", "0.1", "--out", "d.png"], "--y 0.1: is the workspace map's"),
    (["map", "directions", "--resolution", "0.1", "--out", "d.png"], "--resolution 0.1: is the workspace map's"),
    (["map", "directions", "--config", "\uff12", "--out", "d.png"], "--config \uff12: unknown configuration"),
    (["map", "directions", "--config", "", "--out", "d.png"], "--config : unknown configuration"),
    (["meff", "--config", "1", "--direction=-0.0,0,0"], "--direction -0.0,0,0: the zero vector has no direction"),
    (["meff", "--config", "1", "--direction", "1e309,0,0"], "--direction 1e309,0,0: value 1 = 1e309 is not a finite"),
    (["plan", "--point", "1e-320,0,-0.0"], "point (1e-320, 0, 0) m is out of the arm's reach"),
    (["plan", "--point", "nan,0,0"], "--point nan,0,0: value 1 = nan is not a finite number"),
    (["plan", "--point", POINT, "--cone=-0.0,0,0,30"], "--cone -0.0,0,0,30: the zero vector has no direction"),
    (["plan", "--point", POINT, "--objective", "weighted", "--weights", ""], "--weights : expected 3"),
    (["plan", "--point", POINT, "--weights", "1,1,1", "--objective", "force"],
     "(the ranking is by force)"),
    (["plan", "--point", POINT, "--objective", "weighted", "--weights", "0,0,1"],
     "weigh only the displacement, which a fixed base has not"),
]

CASES = ITEM_CASES + FURTHER_CASES


@pytest.fixture
def quiet(refused):  # noqa: F811  (the shared fixture, by name)
    """:func:`refused`, and no RuntimeWarning on the way (NumPy's own included)."""
    def check(argv, names):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            line = refused(argv, names)
        runtime = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
        assert not runtime, runtime
        return line
    return check


def _case_id(argv: list[str], names: str) -> str:
    return " ".join(Path(a).name if "/" in a else a for a in argv)[:70]


@pytest.mark.parametrize("argv, names", CASES, ids=[_case_id(a, n) for a, n in CASES])
def test_the_error_names_the_real_problem(quiet, argv, names):
    quiet(argv, names)


def test_the_table_has_its_rows():
    assert len(FURTHER_CASES) >= 15
    assert len({tuple(a) for a, _ in CASES}) == len(CASES)      # no row twice


# -------------------------------------------------------------------------------------------
# values at the edges of floats that are valid: the answer, not an error
# -------------------------------------------------------------------------------------------
def _meff(argv, capsys) -> dict:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        status = main(["meff", "--config", "1", "--json", *argv])
    out, err = capsys.readouterr()
    assert status == 0 and err == "", err
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
    return json.loads(out)


@pytest.mark.parametrize("huge, plain", [("1e308,1e308,0", "1,1,0"), ("5e-324,0,0", "1,0,0"),
                                         ("1e-320,-1e-320,0", "1,-1,0"), ("-1.7976931348623157e308,0,0", "-1,0,0")],
                         ids=["overflowing norm", "smallest subnormal", "underflowing norm", "largest float"])
def test_a_direction_of_huge_or_subnormal_parts_is_its_direction(capsys, huge, plain):
    """n is normalised after scaling by its largest part: 1e308,1e308,0 is the direction
    1,1,0 (its norm overflows, which used to be read as the zero vector), and subnormal parts
    (whose squares underflow to 0) point where they point."""
    a, b = _meff([f"--direction={huge}"], capsys), _meff([f"--direction={plain}"], capsys)
    assert a["direction"] == pytest.approx(b["direction"], rel=1e-15, abs=1e-15)
    assert math.isclose(sum(x * x for x in a["direction"]), 1.0, rel_tol=1e-15)
    assert a["m_eff"] == pytest.approx(b["m_eff"], rel=1e-12)


def test_the_planner_takes_a_direction_whose_norm_overflows(capsys):
    def rows(direction):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            status = main(["plan", "--point", POINT, "--lambda", "high=53.18,8.66,2.83", "--json",
                           f"--direction={direction}"])
        out, err = capsys.readouterr()
        assert status == 0 and not [w for w in caught if issubclass(w.category, RuntimeWarning)], err
        return json.loads(out)["candidates"]

    big, plain = rows("1e308,1e308,0"), rows("1,1,0")
    assert [r["m_eff"] for r in big] == pytest.approx([r["m_eff"] for r in plain], rel=1e-12)
    assert big[0]["direction"] == pytest.approx([2 ** -0.5, 2 ** -0.5, 0.0], rel=1e-15)


def test_the_weights_are_taken_with_the_weighted_objective(capsys):
    """--weights with --objective weighted ranks (the refusal is only without it), on the fixed
    base too, whose missing displacement term is left out (it used to end in a zip() error)."""
    status = main(["plan", "--point", POINT, "--lambda", "high=53.18,8.66,2.83", "--objective", "weighted",
                   "--weights", "1,0,0", "--json"])
    out, err = capsys.readouterr()
    assert status == 0, err
    doc = json.loads(out)
    assert doc["weights"] == [1.0, 0.0, 0.0]
    impulses = [r["impulse"] for r in doc["candidates"]]
    assert impulses == sorted(impulses)          # weight on the impulse alone: ranked by it


def test_a_coarse_map_grid_is_refused_by_the_key_that_set_it():
    """The workflow's start-up check of plan_maps.resolution names its key, as --resolution."""
    with pytest.raises(InputError, match=r"^configuration key plan_maps.resolution = 0.6 m gives a workspace grid "
                                         r"of 4 x 4 points, fewer than the 5 a side this map samples at least "
                                         r"\(a step of at most 0.5 m"):
        grid_points(0.6, key="configuration key plan_maps.resolution")
    assert grid_points(0.5) == 25            # the coarsest step the map takes: 5 x 5
    with pytest.raises(InputError, match="fewer than the 5 a side"):
        grid_points(0.1, (0.0, 0.3), (0.0, 1.0))    # a narrow range: 4 points along x
