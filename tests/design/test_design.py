"""Any pose and horizontal direction on the rig, the experiment design for lambda, the
lambda + Coulomb impulse model, and the designed campaign's wiring."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from campaign.core.errors import InputError
from campaign.core.vocabulary import direction_azimuth
from campaign.model.exiit import effective_mass
from campaign.model.paper import impact_direction, load_paper, paper_q
from campaign.model.robot import load_robot
from campaign.scene.description import (
    Scene,
    check_direction,
    direction_from_azimuth,
    make_scene,
)

import snakemake_forks

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def robot():
    return load_robot("puma560")


@pytest.fixture
def cli(monkeypatch, capsys):
    """``cli(*args, cwd=folder)``: ``campaign ARGS`` run by the command's entry point in this
    process, in ``folder``; returns its exit status, stdout and stderr. (The console script
    in a process of its own: tests/cli/test_bad_inputs.py.)"""
    from campaign.cli.main import main

    def run(*args, cwd):
        monkeypatch.chdir(cwd)
        monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
        try:
            status = main(list(args))
        except SystemExit as exc:          # argparse's usage errors end the process
            status = exc.code
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(["campaign", *args], status, out, err)

    return run


# -- directions and scenes --------------------------------------------------------------
def test_check_direction_accepts_typed_horizontal_unit_vectors_and_refuses_the_rest():
    n = check_direction([-0.866, -0.5, 0.0])
    assert math.isclose(math.hypot(n[0], n[1]), 1.0, rel_tol=0, abs_tol=1e-15) and n[2] == 0.0
    with pytest.raises(InputError, match="not horizontal"):
        check_direction([-0.8, 0.0, 0.6])
    with pytest.raises(InputError, match="not a unit vector"):
        check_direction([-2.0, 0.0, 0.0])
    with pytest.raises(InputError, match="3 finite"):
        check_direction([1.0, float("nan"), 0.0])


def test_azimuth_round_trips_and_the_papers_direction_is_zero():
    assert direction_azimuth(impact_direction()) == pytest.approx(0.0)
    for deg in (-150.0, -30.0, 30.0, 90.0, 180.0):
        assert direction_azimuth(direction_from_azimuth(deg)) == pytest.approx(deg)
    # 30 deg from -x toward -y
    assert np.allclose(direction_from_azimuth(30.0), [-math.cos(math.pi / 6), -0.5, 0.0])


def test_a_paper_scene_keeps_its_json_and_a_custom_scene_round_trips_with_its_direction():
    paper = make_scene(config=1, gain="zero", speed=1.5)
    assert "direction" not in json.loads(paper.to_json()) and paper.cell == "fixed/config1/zero/v1.500/r00"
    custom = make_scene(config=0, q_paper_deg=[45.0, 150.0, 90.0], direction=[-0.8660254, -0.5, 0.0], speed=1.5)
    back = Scene.from_json(custom.to_json())
    assert back == custom and back.sha256 == custom.sha256
    assert custom.cell.startswith("fixed/pose-45.000_150.000_90.000-n30.000/")
    # each custom pose has its own seed; the paper's cell keeps its own
    other = make_scene(config=0, q_paper_deg=[45.0, 150.0, 90.0], direction=[-1.0, 0.0, 0.0], speed=1.5)
    assert other.seed != custom.seed and other.cell != custom.cell


# -- placement --------------------------------------------------------------------------
def test_the_papers_configurations_can_be_struck_along_minus_x(robot):
    from campaign.rig.trial import build

    for k in load_paper()["configurations"]:
        build(make_scene(config=k, gain="high", speed=2.5))   # raises if refused


@pytest.mark.parametrize("q, n, match", [
    ([170.0, 150.0, 90.0], [-1, 0, 0], "outside its limits"),
    ([0.0, 60.0, 0.0], [-1, 0, 0], "cannot reach"),
    ([0.0, 172.0, 40.0], [-0.2, 0.98, 0.0], None),             # across the stretched forearm: struck
])
def test_placement_refuses_what_the_pendulum_cannot_strike(robot, q, n, match):
    from campaign.rig.trial import build

    scene = make_scene(config=0, q_paper_deg=q, direction=check_direction(np.array(n) / np.linalg.norm(n)),
                       speed=2.5)
    if match is None:
        build(scene)
    else:
        with pytest.raises(InputError, match=match):
            build(scene)


def test_a_swing_along_the_forearm_from_the_elbow_is_refused(robot):
    from campaign.rig.placement import arm_segments, place_pendulum

    q = paper_q([0.0, 172.0, 40.0])
    segs, tip = arm_segments(robot, q)
    elbow = segs[-1][1]
    # the hammer comes from -n: n pointing from the elbow to the tip puts the head's path on the forearm
    n = tip - elbow
    n[2] = 0.0
    n /= np.linalg.norm(n)
    with pytest.raises(InputError, match="passes through link"):
        place_pendulum(robot, q, n, radius=0.5, release_angle=1.0, link_radius=0.08, head_radius=0.03,
                       floor_z=-0.6718, pivot_z_max=1.0, struck_zone=0.35)
    # the opposite direction strikes from outside
    place_pendulum(robot, q, -n, radius=0.5, release_angle=1.0, link_radius=0.08, head_radius=0.03,
                   floor_z=-0.6718, pivot_z_max=1.0, struck_zone=0.35)


# -- the CLI (the must-show runs) ---------------------------------------------------------
def test_trial_cli_runs_a_pose_with_joint_1_at_45_deg_struck_30_deg_from_minus_x(cli, tmp_path):
    from campaign.archive import list_trials, open_trial_arrays

    out = tmp_path / "camp" / "fixed" / "x.nc"
    r = cli("trial", "--q", "45,150,90", "--direction=-0.8660254,-0.5,0", "--speed", "1.5", "--out", str(out),
             "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    measured = open_trial_arrays(out)
    assert np.allclose(measured["impact_direction"].values, [-0.8660254, -0.5, 0.0], atol=1e-6)
    assert np.allclose(measured["q_cmd"].values, paper_q([45.0, 150.0, 90.0]))
    scene = Scene.from_json(measured.attrs["scene_json"]) if "scene_json" in measured.attrs else None
    if scene is None:
        import h5py
        with h5py.File(out) as f:
            scene = Scene.from_json(f.attrs["scene_json"])
    assert scene.q_paper_deg == (45.0, 150.0, 90.0) and scene.config == 0
    # the archive's index shows the pose and the direction
    target = tmp_path / "camp" / scene.cell
    target.parent.mkdir(parents=True)
    out.rename(target.with_suffix(".nc"))
    rec = list_trials(tmp_path / "camp")[0]
    assert rec.row()["q_paper_deg"] == "45 150 90"
    assert np.allclose([float(x) for x in rec.row()["direction"].split()], [-0.8660254, -0.5, 0.0], atol=1e-6)


@pytest.mark.parametrize("args, words", [
    (("--q", "0,60,0"), "cannot reach"),
    (("--q", "0,150,90", "--direction=-0.8,0,0.6"), "not horizontal"),
    (("--q", "170,150,90"), "outside its limits"),
])
def test_trial_cli_refuses_with_one_line_exit_2_and_no_file(cli, tmp_path, args, words):
    out = tmp_path / "t.nc"
    r = cli("trial", *args, "--speed", "2.5", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0]
    assert list(tmp_path.iterdir()) == []


# -- fits with one direction per trial ----------------------------------------------------
def test_lambda_fit_recovers_lambda_from_trials_struck_along_several_directions(robot):
    from campaign.joints.lambda_fit import LambdaFit

    lam = np.array([2.0, 3.0, 0.8])
    rng = np.random.default_rng(3)
    qp = np.array([[0, 150, 90], [45, 120, 135], [-45, 180, 0], [0, 90, 90], [30, 160, 60], [-30, 130, 100]], float)
    D = np.array([direction_from_azimuth(a) for a in rng.uniform(-180, 180, len(qp))])
    Q = np.array([paper_q(q) for q in qp])
    m = np.array([effective_mass(robot, q, n, lam) for q, n in zip(Q, D, strict=True)])
    est = LambdaFit(robot, n_bootstrap=0, warn=False).fit(Q, m, directions=D)
    assert np.allclose(est.lambda_, lam, rtol=1e-6)
    assert np.allclose(est.predict(Q, directions=D), m, rtol=1e-9)
    assert est.directions_.shape == (len(qp), 3) and est.condition_number_ < 100


# -- the design ---------------------------------------------------------------------------
def test_error_model_fit_recovers_its_coefficients_from_seeded_errors():
    from campaign.design.error_model import ErrorModel

    # both terms matter over this range: b x runs from 0.5 a to 8 a
    rng = np.random.default_rng(0)
    n = 20000
    mt = rng.uniform(5, 80, n)
    v = rng.uniform(1.0, 2.5, n)
    truth = ErrorModel(a=0.004, b=2.5e-4)
    mi = mt * np.exp(rng.normal(0, np.sqrt(truth.variance(mt / 0.7, v))))
    fit = ErrorModel.fit(mi, mt, np.full(n, 0.7), v)
    assert fit.a == pytest.approx(truth.a, rel=0.1) and fit.b == pytest.approx(truth.b, rel=0.1)
    ratio = fit.variance(mt / 0.7, v) / truth.variance(mt / 0.7, v)
    assert np.all(np.abs(ratio - 1) < 0.15)


def test_design_information_is_the_sum_of_finite_difference_sensitivities(robot):
    from campaign.design.designer import ExperimentDesign
    from campaign.design.error_model import ErrorModel

    lam = np.array([19.82, 4.62, 0.80])
    em = ErrorModel(a=0.01, b=1e-4)
    qp = np.array([[45, 120, 135], [-45, 90, 90], [0, 180, 0]], float)
    D = np.array([direction_from_azimuth(a) for a in (-120.0, -30.0, 60.0)])
    est = ExperimentDesign(n_poses=3, lambda_prior=lam, speeds=(1.5, 2.5), trials_per_speed=2, error_model=em,
                           m_b=0.72, robot=robot)
    res = est.evaluate(qp, D)
    F = np.zeros((3, 3))
    h = 1e-6
    for q, n in zip(qp, D, strict=True):
        m0 = effective_mass(robot, paper_q(q), n, lam)
        s = np.array([(math.log(effective_mass(robot, paper_q(q), n, lam * np.exp(h * np.eye(3)[j]))) - math.log(m0)) / h
                      for j in range(3)])
        w = sum(2 / em.variance(m0 / 0.72, v) for v in (1.5, 2.5))
        F += w * np.outer(s, s)
    assert np.allclose(res["information"], F, rtol=1e-4)
    sd = np.sqrt(np.diag(np.linalg.inv(F)))
    assert np.allclose(res["relative_ci"], np.expm1(1.959963984540054 * sd), rtol=1e-3)


def test_z95_is_the_normal_quantile_of_a_95_percent_interval():
    from scipy.stats import norm

    from campaign.core.stats import Z95

    assert Z95 == float(norm.ppf(0.975))


def test_design_beats_the_paper_design_on_a_small_grid(robot, tmp_path):
    from campaign.design.candidates import feasible, grid_candidates, paper_design
    from campaign.design.designer import ExperimentDesign
    from campaign.design.error_model import ErrorModel

    Q, D = grid_candidates(q1=(0.0,), q2=(90.0, 135.0, 180.0), q3=(0.0, 90.0, 135.0), azimuths=(0.0, 60.0, 120.0))
    ok, reasons = feasible(robot, Q, D, speed=2.5)
    assert ok.any() and all((r == "") == o for r, o in zip(reasons, ok, strict=True))
    em = ErrorModel(a=0.01, b=1e-4)
    est = ExperimentDesign(n_poses=4, lambda_prior=[19.82, 4.62, 0.80], error_model=em, m_b=0.72, robot=robot)
    est.fit(Q[ok], D[ok])
    paper = est.evaluate(*paper_design())
    assert len(set(est.chosen_.tolist())) == 4
    assert np.all(est.relative_ci_ < np.array(paper["relative_ci"]))
    assert est.condition_number_ < paper["condition_number"] / 10
    # the exchange stops at a local optimum: no single swap of a chosen pose is better
    from campaign.design.designer import _arrays, _criterion, _rows
    S, m = _rows(*_arrays(robot, Q[ok], D[ok]), np.array([19.82, 4.62, 0.80]))
    Fi = est._information(S, m)
    best = est.criterion_value_
    assert best == pytest.approx(_criterion(est.information_, "D"))
    for k in est.chosen_:
        for i in range(len(Fi)):
            if i not in est.chosen_:
                assert _criterion(est.information_ - Fi[k] + Fi[i], "D") <= best + 1e-9


def test_candidates_of_the_same_measurement_are_offered_once(robot):
    from campaign.design.designer import ExperimentDesign
    from campaign.design.error_model import ErrorModel

    # m* is even in n, and unchanged when the arm and n turn together about joint 1
    q, az = np.array([-45.0, 180.0, 0.0]), -120.0
    twins = [(q, az), (q, az + 180.0), (q + [90.0, 0, 0], az + 90.0), (q + [90.0, 0, 0], az - 90.0)]
    Q = np.array([t[0] for t in twins] + [[0.0, 135.0, 135.0], [0.0, 90.0, 90.0], [0.0, 225.0, 105.0]])
    D = np.array([direction_from_azimuth(a) for a in [t[1] for t in twins] + [0.0, 0.0, 0.0]])
    lam = [19.82, 4.62, 0.80]
    m = [effective_mass(robot, paper_q(qp), n, lam) for qp, n in zip(Q[:4], D[:4], strict=True)]
    assert np.allclose(m, m[0], rtol=1e-9)
    kw = dict(n_poses=4, lambda_prior=lam, error_model=ErrorModel(a=0.01, b=1e-4), m_b=0.72, robot=robot)
    est = ExperimentDesign(**kw).fit(Q, D)
    assert est.n_offered_ == 4 and sorted(est.chosen_.tolist()) == [0, 4, 5, 6]     # the first twin only
    with pytest.raises(InputError, match="4 different measurements"):
        ExperimentDesign(**{**kw, "n_poses": 5}).fit(Q, D)
    # offered every candidate, the D-optimal design repeats its best measurement
    rep = ExperimentDesign(**kw, repeat_information=True).fit(Q, D)
    assert rep.n_offered_ == len(Q) and len(set(np.round(rep.m_eff_, 9))) < 4


def test_design_cli_writes_json_and_markdown_from_a_candidate_file(cli, tmp_path):
    cand = tmp_path / "c.csv"
    cand.write_text("q1,q2,q3,azimuth\n0,90,90,0\n45,180,0,-120\n45,120,135,-120\n0,150,90,90\n0,120,135,180\n"
                    "-45,180,0,60\n", encoding="utf-8")
    r = cli("design", "--k", "3", "--candidates", str(cand), "--json", str(tmp_path / "d.json"), "--md",
             str(tmp_path / "d.md"), "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads((tmp_path / "d.json").read_text())
    assert set(d["classes"]) == {"zero_low", "high"}
    for cls in d["classes"].values():
        assert len(cls["designed"]["q_paper_deg"]) == 3 and len(cls["paper"]["q_paper_deg"]) == 3
    md = (tmp_path / "d.md").read_text()
    assert "paper (configurations 1-3" in md
    assert "m* is even in n" in md and "only the first is offered" in md and not d["repeat_information"]
    bad = cli("design", "--candidates", str(tmp_path / "missing.csv"), cwd=tmp_path)
    assert bad.returncode == 2 and "does not exist" in bad.stderr


def _design(argv: list[str], folder, monkeypatch, capsys) -> dict[str, dict]:
    """Run ``campaign ARGV`` (a design) through :func:`campaign.cli.main.main` and read its printed
    design: ``{"criterion": its line, class: {"header", "poses": [(q, azimuth)], "cond": {design: number}}}``."""
    from campaign.cli.main import main

    assert argv[0] == "design"
    monkeypatch.chdir(folder)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    status = main(argv)
    out, err = capsys.readouterr()
    assert status == 0 and err == "", err
    lines = out.splitlines()
    assert lines[0] == "# Experiment design for lambda"
    found: dict = {"criterion": lines[2]}
    for line in lines[3:]:
        if line.startswith("## "):
            cls = found.setdefault(line.split()[1], {"header": line, "poses": [], "cond": {}})
        elif line.startswith("| ") and line[2].isdigit():                   # | pose | q | azimuth | ...
            cells = [c.strip() for c in line.strip("|").split("|")]
            cls["poses"].append((cells[1], float(cells[2])))
        elif line.startswith(("| paper ", "| designed ")):
            cells = [c.strip() for c in line.strip("|").split("|")]
            cls["cond"][cells[0].split()[0]] = float(cells[2])
    assert set(found) == {"criterion", "zero_low", "high"}, out
    return found


def test_design_e_optimal_on_random_candidates_improves_on_the_paper_for_both_classes(tmp_path, monkeypatch, capsys):
    d = _design(["design", "--criterion", "E", "--candidates", "random", "--n-random", "2000", "--seed", "0"], tmp_path,
                monkeypatch, capsys)
    assert d["criterion"].startswith("Criterion E-optimal, K = 6 poses from 2000 candidates")
    for cls in ("zero_low", "high"):
        assert len(d[cls]["poses"]) == 6
        assert d[cls]["cond"]["designed"] < d[cls]["cond"]["paper"] / 10, d[cls]


def test_design_at_a_fitted_prior_uses_it_for_its_class_only(tmp_path, monkeypatch, capsys):
    d = _design(["design", "--prior", "high=2.34,3.55,3.19"], tmp_path, monkeypatch, capsys)
    assert "prior lambda = [2.34, 3.55, 3.19] kg m^2" in d["high"]["header"]
    table3 = load_paper()["table3"]["zero_low"]
    assert f"prior lambda = [{', '.join(f'{v:g}' for v in table3)}] kg m^2" in d["zero_low"]["header"]
    assert all(len(d[c]["poses"]) == 6 and d[c]["cond"]["designed"] < d[c]["cond"]["paper"] for c in ("zero_low", "high"))


def test_design_repeating_information_strikes_three_high_poses_along_n_and_minus_n(tmp_path, monkeypatch, capsys):
    """What the guide says of ``campaign design --k 6 --repeat-information`` (m* is even in n)."""
    d = _design(["design", "--k", "6", "--repeat-information"], tmp_path, monkeypatch, capsys)
    assert "all offered" in d["criterion"]
    poses = d["high"]["poses"]
    assert len(poses) == 6 and len({q for q, _ in poses}) == 3
    for q in {q for q, _ in poses}:
        a, b = sorted(az for p, az in poses if p == q)
        assert math.isclose(b - a, 180.0), (q, a, b)


# -- lambda + Coulomb impulse -------------------------------------------------------------
def test_apparent_mass_without_friction_is_eq_11_and_the_fit_recovers_its_parameters(robot):
    from campaign.joints.coulomb import CoulombLambdaFit, apparent_mass
    from campaign.joints.lambda_fit import design_arrays

    lam, kappa = np.array([1.0, 2.0, 0.8]), np.array([0.1, 0.05, 0.02])
    qp = np.array([[0, 150, 90], [45, 120, 135], [-45, 180, 0], [0, 90, 90], [30, 160, 60], [-30, 130, 100]], float)
    D = np.array([direction_from_azimuth(a) for a in (10.0, -120.0, 60.0, 0.0, 90.0, -60.0)])
    Q = np.array([paper_q(q) for q in qp])
    H, Jn = design_arrays(robot, Q, D)
    m0 = apparent_mass(H, Jn, lam, np.zeros(3), speed=1.5, e=0.55, m_b=0.72)
    assert np.allclose(m0, [effective_mass(robot, q, n, lam) for q, n in zip(Q, D, strict=True)], rtol=1e-12)
    Q2, D2 = np.vstack([Q, Q]), np.vstack([D, D])
    v = np.repeat([1.5, 2.5], len(Q))
    m = apparent_mass(*design_arrays(robot, Q2, D2), lam, kappa, speed=v, e=0.55, m_b=0.72)
    assert np.all(m > np.concatenate([m0, m0]))       # friction makes the arm look heavier
    fit = CoulombLambdaFit(robot).fit(Q2, D2, m, speed=v, e=np.full(len(v), 0.55), m_b=np.full(len(v), 0.72))
    assert np.allclose(fit.lambda_, lam, rtol=1e-4) and np.allclose(fit.kappa_, kappa, rtol=1e-3)


# -- the designed campaign's workflow -------------------------------------------------------
def test_snakemake_designed_plans_its_jobs(tmp_path):
    """In a folder laid out like the repository's root (its config/), nothing written there."""
    (tmp_path / "config").symlink_to(ROOT / "config")
    r = snakemake_forks.run(["-s", str(ROOT / "Snakefile"), "designed", "-n", "--directory", str(tmp_path)],
                            cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    out = r.stdout + r.stderr
    for rule, count in (("designed_plan", 1), ("designed_trials", 9), ("designed_report", 1)):
        assert any(line.split() == [rule, str(count)] for line in out.splitlines()), out[-2000:]
