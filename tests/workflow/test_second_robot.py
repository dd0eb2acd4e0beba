"""A second robot end to end: planar2 (two links, vertical joint axes) on the rig, through the
CLI and through its own reduced campaign (config/tests/planar2.yaml).

The campaign runs once for the module (about 20 s of CPU): 18 fixed-base trials, their
identification, the lambda fit of each gain class and Figure 7; the paper's products are
skipped with their reason. The CLI cases check that a pose has the robot's number of angles
and that a trial is the same whether ``campaign trial`` or the batched sweep simulates it.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from campaign.archive import verify
from campaign.cli.main import main
from campaign.identify.table import read_identification
from campaign.model.exiit import effective_mass
from campaign.model.robot import load_robot

import snakemake_forks

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "config" / "tests" / "planar2.yaml"
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
#: the paper's products a campaign of another robot skips
PAPER_PRODUCTS = ("fig4", "fig5", "fig6", "fig8", "fig9", "plan_maps", "table2", "table3", "table4")


def snakemake(workdir: Path, *args: str, configs=(CONFIG,), check: bool = True) -> subprocess.CompletedProcess:
    """Run the repository's workflow in ``workdir`` with ``configs`` (merged in order)."""
    cmd = [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), *args]
    for config in configs:
        cmd += ["--configfile", str(config)]
    proc = snakemake_forks.run(cmd[1:], cwd=workdir, timeout=600)   # the command, without loading Snakemake again
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-6000:]}")
    return proc


def planned_rules(proc: subprocess.CompletedProcess) -> set[str]:
    """The rules of the jobs a dry run lists."""
    return set(re.findall(r"^(?:local)?rule (\w+):$", proc.stdout + proc.stderr, re.M))


@pytest.fixture(scope="module")
def campaign_run(tmp_path_factory):
    """The planar2 reduced campaign, run once: (working folder, Snakemake's output)."""
    work = tmp_path_factory.mktemp("planar2_campaign")
    return work, snakemake(work, "--cores", "2")


@pytest.mark.slow
def test_the_campaign_makes_its_trials_identification_fits_and_figure_7(campaign_run):
    work, _ = campaign_run
    archive, results = work / "archive" / "planar2", work / "results" / "planar2"
    assert verify(archive) == []
    trials = sorted(archive.rglob("*.nc"))
    assert len(trials) == 18                      # configurations 1-3 x zero/low/high x 2 speeds
    with h5py.File(trials[0]) as f:
        assert f.attrs["robot"] == "planar2"
        assert f["measured"]["q_enc"].shape[1] == 2       # two joints, channel by channel
    rows = read_identification(sorted((results / "identify").rglob("*.csv")))
    assert len(rows) == 18 and not [r["reason"] for r in rows if r["excluded"]]
    for r in rows:
        assert r["robot"] == "planar2" and len(r["q_cmd"]) == 2
        assert 0.0 < r["e"] < 1.0 and math.isfinite(r["m_eff"]) and r["m_eff"] > 0.0, r
    png = results / "figures" / "fig7.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and (results / "figures" / "fig7.pdf").is_file()


@pytest.mark.slow
def test_the_fits_are_the_robots_and_high_gains_add_a_virtual_rotor_inertia(campaign_run):
    work, _ = campaign_run
    fits = {cls: json.loads((work / "results" / "planar2" / "fit" / f"lambda_{cls}.json").read_text())
            for cls in ("zero_low", "high")}
    robot = load_robot("planar2")
    for fit in fits.values():
        assert fit["robot"] == "planar2" and fit["configs"] == [1, 2, 3] and len(fit["lambda"]) == 2
    high = fits["high"]
    assert high["identifiable"] == [True, True]
    # the servo adds about as much as the forearm's own inertia (H22 ~ 0.165 kg m^2), far
    # beyond the direct drives' armature
    assert all(10 * a < lam < 1.0 for lam, a in zip(high["lambda"], robot.armature, strict=True)), high["lambda"]
    # a direct-drive arm with little friction shows none under Zero and Low gains
    assert max(fits["zero_low"]["lambda"]) < 0.01 < min(high["lambda"])


@pytest.mark.slow
def test_the_papers_products_are_skipped_with_their_reason(campaign_run):
    work, proc = campaign_run
    results = work / "results" / "planar2"
    for product in PAPER_PRODUCTS:
        assert (f"campaign planar2: skipping {product}: it needs the paper's robot puma560 (its configurations and "
                "published values; this campaign simulates planar2)") in proc.stderr, product
    assert not (results / "tables").exists()
    assert sorted(p.name for p in (results / "figures").iterdir()) == ["fig7.pdf", "fig7.png"]
    # asked for by name, a paper's product is refused with the same reason
    out = snakemake(work, "table2", "-n", check=False)
    assert out.returncode != 0
    assert "table2 cannot be made from campaign 'planar2': it needs the paper's robot puma560" in out.stdout + out.stderr


@pytest.mark.slow
def test_the_tables_command_refuses_another_robots_archive(campaign_run, tmp_path, capsys):
    work, _ = campaign_run
    assert main(["tables", str(work / "archive" / "planar2"), "--out", str(tmp_path / "tables")]) == 2
    assert "tables compares trials with the paper's puma560, this archive holds planar2 trials" in \
        capsys.readouterr().err
    assert not (tmp_path / "tables").exists()


def test_merged_over_the_full_configuration_it_sweeps_no_flexible_base(tmp_path):
    """``--configfile`` is merged over config/config.yaml key by key: ``flexible: null``
    switches off the PUMA's flexible sweep the full configuration lists."""
    proc = snakemake(tmp_path, "-n", configs=(REPO / "config" / "config.yaml", CONFIG))
    rules = planned_rules(proc)
    assert "simulate_fixed" in rules and "fixed_base" in rules and "/fit/lambda_" in proc.stdout
    assert not {r for r in rules if "flexible" in r}, rules


def test_a_configuration_the_robot_does_not_name_stops_the_start_up(tmp_path):
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["bases"]["fixed"]["configurations"] = [1, 4]
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    proc = snakemake(tmp_path, "-n", configs=(bad,), check=False)
    assert proc.returncode != 0
    assert ("configuration key bases.fixed.configurations: robot planar2 names no configuration [4] (its "
            "configurations: [1, 2, 3])") in proc.stdout + proc.stderr


def test_too_few_configurations_for_the_joints_skip_the_fit(tmp_path):
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["bases"]["fixed"]["configurations"] = [1]
    one = tmp_path / "one.yaml"
    one.write_text(yaml.safe_dump(cfg))
    proc = snakemake(tmp_path, "-n", configs=(one,))
    assert ("skipping the lambda fits: it needs bases.fixed with at least 2 configurations (robot planar2 has 2 "
            "joints, one lambda_j each)") in proc.stderr
    assert "fixed_base" in planned_rules(proc) and "/fit/lambda_" not in proc.stdout


# ------------------------------------------------------------------------------------------
# the CLI
# ------------------------------------------------------------------------------------------
def test_a_pose_has_the_robots_number_of_angles(tmp_path, capsys):
    out = tmp_path / "t.nc"
    assert main(["trial", "--set", "robot=planar2", "--q", "0,150,90", "--speed", "2.5", "--out", str(out)]) == 2
    assert "--q 0,150,90: expected 2 comma-separated values [deg], got 3" in capsys.readouterr().err
    assert not out.exists()
    assert main(["trial", "--set", "robot=planar2", "--q=-30,75", "--speed", "2.5", "--out", str(out)]) == 0
    with h5py.File(out) as f:
        assert f.attrs["robot"] == "planar2"
        np.testing.assert_array_equal(f["measured"]["q_cmd"][()], np.radians([-30.0, 75.0]))
    # the PUMA still takes the paper's three angles
    assert main(["trial", "--q", "0,150", "--speed", "2.5", "--out", str(out)]) == 2
    assert "--q 0,150: expected 3 comma-separated values [deg], got 2" in capsys.readouterr().err


def test_trial_and_sweep_give_the_same_trial(tmp_path, capsys):
    """The batched sweep integrates planar2's trials in lock-step; each is the trial
    ``campaign trial`` writes for its cell (the same content digests)."""
    args = ["--set", "robot=planar2", "--set", "controller.torque_per_unit=9.54259e-09"]
    assert main(["sweep", *args, "--configs", "3", "--gains", "high", "--speeds", "2.5", "--out",
                 str(tmp_path / "sweep"), "--quiet"]) == 0
    assert main(["trial", *args, "--config", "3", "--gain", "high", "--speed", "2.5", "--out",
                 str(tmp_path / "one.nc"), "--quiet"]) == 0
    with h5py.File(tmp_path / "sweep" / "fixed" / "config3" / "high" / "v2.500" / "r00.nc") as a, \
            h5py.File(tmp_path / "one.nc") as b:
        for group in ("measured", "truth"):
            assert a[group].attrs["content_sha256"] == b[group].attrs["content_sha256"], group


def test_meff_evaluates_the_robot_at_its_own_configurations(capsys):
    assert main(["meff", "--robot", "planar2", "--config", "2", "--lambda", "0.1,0.05", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    planar = load_robot("planar2")
    assert d["robot"] == "planar2" and d["q_paper_deg"] == [-45.0, 30.0]
    assert d["m_eff"] == pytest.approx(effective_mass(planar, np.radians([-45.0, 30.0]), (-1.0, 0.0, 0.0),
                                                      [0.1, 0.05]), rel=1e-12)
    assert main(["meff", "--robot", "planar2", "--config", "4"]) == 2
    assert "--config 4: unknown configuration; known: [1, 2, 3]" in capsys.readouterr().err
