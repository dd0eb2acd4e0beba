"""``campaign meff``: values agree with the library, Table 2 with the paper, bad input exits 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from campaign.cli.main import main
from campaign.model import exiit
from campaign.model.paper import configuration_q
from campaign.model.robot.floating import attach_to_floating_base
from campaign.scene.description import load_rig

# The paper's published Table 2 [kg].
PAPER_TABLE2 = {
    "m1": {1: 6.99, 2: 19.66, 3: 4.96},
    "m2": {1: 12.98, 2: 38.14, 3: 8.91},
    "m3": {1: 28.45, 2: 76.45, 3: 19.11},
}
TOLERANCE = {"m1": 0.015, "m2": 0.05, "m3": 0.05}


def run(capsys, *argv):
    """(exit status, stdout, stderr) of ``campaign meff argv``."""
    status = main(["meff", *argv])
    out, err = capsys.readouterr()
    return status, out, err


def run_json(capsys, *argv):
    status, out, err = run(capsys, *argv, "--json")
    assert status == 0, err
    return json.loads(out)


# -- values ---------------------------------------------------------------------------
@pytest.mark.parametrize("config", [1, 2, 3])
def test_config_json_is_the_fixed_base_m_eff(capsys, puma, config):
    d = run_json(capsys, "--config", str(config))
    assert d["m_eff"] == pytest.approx(exiit.effective_mass(puma, configuration_q(config), (-1, 0, 0)), rel=1e-14)
    assert d["m_eff_is_infinite"] is False
    assert d["units"] == "kg" and d["base"] == "fixed" and d["config"] == config
    assert d["lambda"] == [0.0, 0.0, 0.0] and d["direction"] == [-1.0, 0.0, 0.0]


def test_paper_angles_lambda_and_direction_are_passed_through(capsys, puma):
    d = run_json(capsys, "--q", "0,150,90", "--lambda", "19.82,4.62,0.80", "--direction", "-2,0,0")
    expected = exiit.effective_mass(puma, np.radians([0.0, 150.0, 0.0]), (-1, 0, 0), [19.82, 4.62, 0.80])
    assert d["m_eff"] == pytest.approx(expected, rel=1e-14)
    assert d["config"] is None and d["q_paper_deg"] == [0.0, 150.0, 90.0]
    assert d["direction"] == [-1.0, 0.0, 0.0]   # normalised


def test_a_negative_value_works_without_an_equals_sign(capsys):
    assert run_json(capsys, "--q", "-10,150,90", "--direction", "-1,0.5,0") == \
        run_json(capsys, "--q=-10,150,90", "--direction=-1,0.5,0")


def test_flexible_base_uses_the_rigs_emulated_base(capsys, puma):
    # platform + the beam's tip share: the body the flexible rig integrates
    from campaign.rig.beam import Beam
    from campaign.scene.description import make_scene
    base = Beam.from_scene(make_scene(base="flexible")).base_body()
    params, _ = load_rig()
    assert base.mass > params["flexible.platform_mass"]
    frobot = attach_to_floating_base(puma, base)
    for config in (1, 2):
        d = run_json(capsys, "--config", str(config), "--base", "flexible", "--lambda", "53.18,8.66,2.83")
        q = configuration_q(config)
        assert d["base"] == "flexible"
        assert d["m_eff"] == pytest.approx(exiit.effective_mass(frobot, q, (-1, 0, 0), [53.18, 8.66, 2.83]), rel=1e-14)
        assert d["m_eff"] < exiit.effective_mass(puma, q, (-1, 0, 0), [53.18, 8.66, 2.83])


def test_infinite_m_eff_is_json_null(capsys, puma):
    """Elbow straightened at its singularity, n along the lost direction: m* = inf -> null."""
    model, data = puma.model, puma.model.createData()

    def jac(q3):
        return exiit.impact_jacobian(model, data, np.array([0.0, 0.0, q3]), puma.impact_frame_id)[:3]

    q3 = brentq(lambda x: np.linalg.det(jac(x)), np.radians(-90.0), np.radians(-75.0), xtol=1e-15)
    n = np.linalg.svd(jac(q3))[0][:, 2]
    q_paper = f"0,0,{float(np.degrees(q3)) + 90.0!r}"
    direction = ",".join(repr(float(v)) for v in n)
    d = run_json(capsys, "--q", q_paper, "--direction", direction)
    assert d["m_eff"] is None and d["m_eff_is_infinite"] is True
    status, out, _ = run(capsys, "--q", q_paper, "--direction", direction)
    assert status == 0 and out.startswith("m*        = inf")


def test_text_output_names_units(capsys):
    status, out, _ = run(capsys, "--config", "1")
    assert status == 0
    assert "kg" in out and "kg m^2" in out and "deg (paper)" in out and "deg (DH)" in out


def test_help_documents_units_and_the_flexible_base(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["meff", "--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for fragment in ("[deg]", "[kg m^2]", "m* in kg", "flexible.platform_mass [kg]",
                     "flexible.platform_inertia [kg m^2]", "flexible.beam_mass [kg]", "config/rig.yaml", "inclusive"):
        assert fragment in text


# -- Table 2 ----------------------------------------------------------------------------
def test_table_json_reproduces_table2(capsys):
    d = run_json(capsys, "--table")
    rows = d["rows"]
    assert sorted((r["column"], r["config"]) for r in rows) == sorted(
        (c, k) for c in PAPER_TABLE2 for k in PAPER_TABLE2[c])
    for r in rows:
        assert r["paper"] == PAPER_TABLE2[r["column"]][r["config"]]
        assert r["rel_diff"] == pytest.approx((r["model"] - r["paper"]) / r["paper"], rel=1e-12)
        assert abs(r["rel_diff"]) <= TOLERANCE[r["column"]]


def test_table_text_shows_model_paper_and_difference(capsys):
    status, out, _ = run(capsys, "--table")
    assert status == 0
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines() if line[:6].strip() in ("1", "2", "3")}
    assert sorted(rows) == ["1", "2", "3"]
    for config, cells in rows.items():
        for i, column in enumerate(("m1", "m2", "m3")):
            model, paper, diff = float(cells[3 * i]), float(cells[3 * i + 1]), float(cells[3 * i + 2].rstrip("%"))
            assert paper == PAPER_TABLE2[column][int(config)]
            assert diff == pytest.approx(100 * (model - paper) / paper, abs=0.1)
            assert abs(diff) <= 100 * TOLERANCE[column]


# -- bad input ----------------------------------------------------------------------------
BAD = [
    (["--config", "4"], "--config 4: unknown configuration"),
    (["--config", "one"], "--config one: unknown configuration"),
    (["--config", "1", "--lambda", "1,2"], "--lambda 1,2: expected 3"),
    (["--config", "1", "--lambda", "1,2,3,4"], "--lambda 1,2,3,4: expected 3"),
    (["--config", "1", "--lambda", "1,-2,0"], "lambda_2 = -2 kg m^2 is negative"),
    (["--config", "1", "--lambda", "1,nan,0"], "--lambda 1,nan,0: value 2 = nan is not a finite number"),
    (["--config", "1", "--lambda", "1,x,0"], "--lambda 1,x,0: value 2 'x' is not a number"),
    (["--config", "1", "--direction", "0,0,0"], "--direction 0,0,0: the zero vector"),
    (["--config", "1", "--direction", "0,0,inf"], "--direction 0,0,inf: value 3 = inf is not a finite number"),
    (["--q", "0,135,135.001"], "--q 0,135,135.001: joint j3 angle 45.001 deg (DH) is outside its limits [-225, 45]"),
    (["--q", "0,-45.5,90"], "--q 0,-45.5,90: joint j2 angle -45.5 deg (DH) is outside its limits [-45, 225]"),
    (["--q", "170,150,90"], "--q 170,150,90: joint j1 angle 170 deg (DH) is outside its limits [-160, 160]"),
    (["--q", "0,150"], "--q 0,150: expected 3"),
    (["--table", "--base", "flexible"], "--table reproduces the paper's Table 2"),
]


@pytest.mark.parametrize("argv, message", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_is_one_line_naming_the_value_and_exit_2(capsys, argv, message):
    status, out, err = run(capsys, *argv)
    assert status == 2
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("campaign meff: error: ")
    assert message in err


def test_the_limit_itself_is_accepted(capsys):
    """Configuration 3 is exactly on joint 3's +45 deg DH limit (limits are inclusive)."""
    assert run_json(capsys, "--q", "0,135,135")["m_eff"] == run_json(capsys, "--config", "3")["m_eff"]


def test_the_installed_command_exits_2_without_a_traceback():
    script = Path(sys.executable).with_name("campaign")   # the console script beside this interpreter
    proc = subprocess.run([str(script), "meff", "--config", "9"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip() == "campaign meff: error: --config 9: unknown configuration; known: [1, 2, 3]"
    assert "Traceback" not in proc.stderr and proc.stdout == ""
