"""The response model's bad inputs: edited model files and predictions outside its domain.

An edited copy of the shipped model given to ``campaign meff --model FILE`` (a value out of
its valid range, a non-finite number, an unknown option, or any edit after the fit: its
content digest) and a prediction outside the model's domain (speed, direction, object mass)
are each refused with one line naming the entry or the bound and the value, exit status 2,
nothing on stdout, no traceback and no RuntimeWarning. With ``--extrapolate`` the same
predictions answer with one warning line and an interval wider than the model's own; where
the tip recoils the answer says so (m* has no value) instead of calling it infinite.
``campaign plan`` and ``campaign map`` refuse the same and take ``--structure``.
"""

from __future__ import annotations

import copy
import json
import math
import re
import warnings

import pytest

from campaign.cli.main import main
from campaign.joints.modelfile import shipped_model_path

MEFF = ("meff", "--config", "1", "--model")


@pytest.fixture(scope="module")
def shipped() -> dict:
    return json.loads(shipped_model_path().read_text(encoding="utf-8"))


def cli(capsys, *argv):
    """(status, stdout, stderr) of ``campaign argv``; no RuntimeWarning may be raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        status = main(list(argv))
    out, err = capsys.readouterr()
    runtime = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert not runtime, runtime
    assert "Traceback" not in err and "RuntimeWarning" not in err
    return status, out, err


def refused(capsys, argv, words: str) -> str:
    status, out, err = cli(capsys, *argv)
    lines = err.strip().splitlines()
    assert status == 2 and out == "" and len(lines) == 1, err
    assert lines[0].startswith(f"campaign {argv[0]}: error: ") and words in lines[0], lines[0]
    return lines[0]


def _edit(doc: dict, where: str, value) -> dict:
    """A copy of ``doc`` with the entry at the dotted/indexed path ``where`` set to ``value``."""
    bad = copy.deepcopy(doc)
    keys = where.split(".")
    node = bad
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node[k]
    last = keys[-1]
    node[int(last) if isinstance(node, list) else last] = value
    return bad


NAN = math.nan
EDITS = {
    "restitution 5": ("parameters.restitution", 5, "parameters.restitution = 5 must be <= 1"),
    "restitution -0.5": ("parameters.restitution", -0.5, "parameters.restitution = -0.5 must be > 0"),
    "residual_scatter -1": ("fit.residual_scatter", -1, "fit.residual_scatter = -1 must be > 0"),
    "NaN in the covariance": ("parameters.covariance.1.2", NAN, "parameters.covariance[1, 2] = nan must be a finite"),
    "NaN in the scatter": ("fit.residual_scatter", NAN, "fit.residual_scatter = nan must be a finite number"),
    "NaN in a structure's scatter": ("fit.structure_scatter.stiff_mast", NAN,
                                     "fit.structure_scatter.stiff_mast = nan must be a finite number"),
    "damping 1e308": ("parameters.damping.0", 1e308, "parameters.damping[0] = 1e+308 lies outside its own 95 %"),
    "coupling telepathy": ("options.coupling", "telepathy", "options.coupling = 'telepathy' is not one of"),
    "steps 0": ("options.steps", 0, "options.steps = 0 must be an integer >= 1"),
    "an asymmetric covariance": ("parameters.covariance.0.1", 1e-3, "parameters.covariance is not symmetric"),
    "a restitution edited within range": ("parameters.restitution", 0.6,
                                          "edited after its fit: parameters.restitution differs"),
    "a wider domain": ("domain.speed_m_s", [0.1, 10.0], "edited after its fit: domain.speed_m_s differs"),
    "another digest": ("digest.sha256", "0" * 64, "edited after its fit"),
}


@pytest.mark.parametrize("case", sorted(EDITS))
def test_an_edited_model_file_is_refused_with_one_line(case, shipped, capsys, tmp_path):
    where, value, words = EDITS[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_edit(shipped, where, value)))          # NaN written as JSON's NaN token
    refused(capsys, [*MEFF, str(path), "--gain", "high", "--speed", "2"], words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


def test_a_covariance_that_is_not_positive_semi_definite_is_refused(shipped, capsys, tmp_path):
    cov = [row[:] for row in shipped["parameters"]["covariance"]]
    cov[0][0] = -cov[0][0]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_edit(shipped, "parameters.covariance", cov)))
    refused(capsys, [*MEFF, str(path), "--gain", "high", "--speed", "2"], "not positive semi-definite")


OUTSIDE = {
    "speed 0.05": (("--gain", "high", "--speed", "0.05"), "speed 0.05 m/s is below the model's domain"),
    "speed 20": (("--gain", "high", "--speed", "20"), "speed 20 m/s is above the model's domain"),
    "speed 1e6": (("--gain", "low", "--speed", "1e6"), "speed 1e+06 m/s is above the model's domain"),
    "a non-horizontal direction": (("--gain", "high", "--speed", "2", "--direction=-0.8,0,-0.6"),
                                   "direction [-0.8, 0, -0.6] (n_z = -0.6) is outside the model's domain"),
    "mass 1.5 at High gains": (("--gain", "high", "--speed", "2", "--mass", "1.5"),
                               "object mass 1.5 kg is above the model's domain"),
}


@pytest.mark.parametrize("case", sorted(OUTSIDE))
def test_a_prediction_outside_the_domain_is_refused(case, capsys):
    argv, words = OUTSIDE[case]
    line = refused(capsys, [*MEFF, *argv], words)
    assert "--extrapolate" in line and "fitted on" in line


@pytest.mark.parametrize("case", ["speed 0.05", "speed 20", "a non-horizontal direction"])
def test_extrapolating_warns_and_widens_the_interval(case, capsys):
    argv, words = OUTSIDE[case]
    status, out, err = cli(capsys, *MEFF, *argv, "--extrapolate", "--json")
    lines = err.strip().splitlines()
    assert status == 0 and len(lines) == 1, err
    assert lines[0].startswith("campaign meff: warning: extrapolating outside the model's domain") and words in lines[0]
    d = json.loads(out)
    assert d["m_eff_state"] == "finite" and d["m_eff"] > 0 and d["extrapolated"]
    lo, hi = d["interval_95"]
    lo0, hi0 = d["interval_95_in_domain"]
    assert lo < lo0 <= d["m_eff"] <= hi0 < hi


def test_a_recoiling_tip_is_said_to_have_no_m_eff_not_an_infinite_one(capsys):
    status, out, err = cli(capsys, *MEFF, "--gain", "high", "--speed", "2", "--mass", "1.5", "--extrapolate", "--json")
    assert status == 0 and err.startswith("campaign meff: warning: ") and len(err.strip().splitlines()) == 1
    d = json.loads(out)
    assert d["m_eff"] is None and d["m_eff_state"] == "recoil" and d["m_eff_is_infinite"] is False
    assert d["tip_velocity"] < 0 and d["interval_95"] is None and "recoils" in d["m_eff_note"]
    status, out, err = cli(capsys, *MEFF, "--gain", "high", "--speed", "2", "--mass", "1.5", "--extrapolate")
    assert status == 0 and out.startswith("m*        = none: the tip recoils")


def test_inside_the_domain_nothing_is_extrapolated(capsys):
    status, out, err = cli(capsys, *MEFF, "--gain", "high", "--speed", "2", "--json")
    d = json.loads(out)
    assert status == 0 and err == "" and d["extrapolated"] == [] and "interval_95_in_domain" not in d
    assert d["m_eff_state"] == "finite" and d["interval_95"][0] < d["m_eff"] < d["interval_95"][1]


def test_extrapolate_goes_with_a_model(capsys):
    refused(capsys, ["meff", "--config", "1", "--extrapolate"], "--extrapolate goes with --model")


PLAN = ("plan", "--point", "-0.6,-0.15,-0.15")
PLAN_OUTSIDE = {
    "speed 6": (("--speed", "6"), "speed 6 m/s is above the model's domain"),
    "speed 0.05": (("--speed", "0.05"), "speed 0.05 m/s is below the model's domain"),
    "mass 1.5": (("--mass", "1.5"), "object mass 1.5 kg is above the model's domain"),
    "a tilted direction": (("--direction=-0.8,0,-0.6",), "(n_z = -0.6) is outside the model's domain"),
    "a cone of directions": (("--cone", "-1,0,0,30", "--count", "5"), "is outside the model's domain"),
    "a structure on the fixed base": (("--structure", "stiff_mast"), "give --base flexible too"),
    "an unknown structure": (("--base", "flexible", "--structure", "telepathy"), "not a structure of the rig file"),
    "extrapolating eq 7": (("--lambda", "high=53.18,8.66,2.83", "--extrapolate"), "--extrapolate goes with a response"),
}


@pytest.mark.parametrize("case", sorted(PLAN_OUTSIDE))
def test_the_planner_refuses_outside_the_domain(case, capsys):
    argv, words = PLAN_OUTSIDE[case]
    refused(capsys, [*PLAN, *argv], words)


def test_the_planner_extrapolates_with_a_warning(capsys):
    status, out, err = cli(capsys, *PLAN, "--speed", "6", "--extrapolate", "--json")
    lines = err.strip().splitlines()
    assert status == 0 and len(lines) == 1 and "speed 6 m/s is above the model's domain" in lines[0]
    assert lines[0].startswith("campaign plan: warning: ")
    assert json.loads(out)["speed"] == 6.0


def test_plan_structure_plans_on_the_named_structure(capsys):
    rows = {}
    for name in ("space_class", "stiff_mast"):
        status, out, err = cli(capsys, *PLAN, "--base", "flexible", "--structure", name, "--horizontal", "2",
                               "--json")
        assert status == 0, err
        d = json.loads(out)
        assert d["structure"] == name
        rows[name] = {(c["branch"], c["gain_class"], tuple(c["direction"])): c for c in d["candidates"]}
    assert rows["space_class"].keys() == rows["stiff_mast"].keys()
    # the structures differ (their periods): the base's peak displacement moves with them
    assert any(rows["space_class"][k]["structure_peak"] != rows["stiff_mast"][k]["structure_peak"]
               for k in rows["space_class"])


def test_map_structure(capsys, tmp_path):
    out = tmp_path / "dirs.png"
    status, text, err = cli(capsys, "map", "directions", "--config", "2", "--structure", "stiff_mast", "--out",
                            str(out))
    assert status == 0 and out.is_file() and out.with_suffix(".pdf").is_file(), err
    assert "(stiff_mast)" in text
    status, default, err = cli(capsys, "map", "directions", "--config", "2", "--out", str(tmp_path / "d.png"))
    assert status == 0, err
    peak = re.compile(r"structure peak ([0-9.]+)-([0-9.]+) mm")      # the mast is far stiffer: its peak smaller
    assert float(peak.search(text).group(2)) < 0.5 * float(peak.search(default).group(1)), (text, default)
    refused(capsys, ["map", "directions", "--structure", "telepathy", "--out", str(tmp_path / "x.png")],
            "not a structure of the rig file")
    refused(capsys, ["map", "directions", "--base", "fixed", "--structure", "stiff_mast", "--out",
                     str(tmp_path / "x.png")], "give --base flexible too")
