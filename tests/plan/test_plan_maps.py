"""The planner's maps: workspace and direction maps agree with the planner and eq 7, and draw."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from campaign.cli.main import main
from campaign.model import exiit
from campaign.model.paper import configuration_q
from campaign.model.robot.ik import impact_point, position_branches
from campaign.plan.maps import direction_map, workspace_map
from campaign.report.figures import plan_maps
from campaign.rig.beam import Beam
from campaign.rig.contact import ContactLaw

LAMBDAS = {"zero_low": [19.82, 4.62, 0.80], "high": [53.18, 8.66, 2.83]}
KW = dict(lambdas=LAMBDAS, contact=ContactLaw(537.3, 0.737, 0.58), mass=0.7, speed=2.0, restitution=0.58)


@pytest.fixture(scope="module")
def beam():
    return Beam(EI=2.5e8, length=20.0, mass=200.0, damping_ratio=0.02, platform_mass=50.0)


@pytest.fixture(scope="module")
def wmap(puma, beam):
    return workspace_map(puma, direction=[-1, 0, 0], y=-0.15005, x_range=(-0.9, 0.9), z_range=(-0.9, 0.9),
                         resolution=0.3, beam=beam, **KW)


def test_workspace_map_keeps_the_best_and_worst_branch_of_each_point(puma, wmap):
    x, z = wmap["x"], wmap["z"]
    assert x.size == z.size == 7
    checked = 0
    for iz in range(0, z.size, 2):
        for ix in range(0, x.size, 2):
            ik = position_branches(puma, [x[ix], -0.15005, z[iz]])
            assert wmap["n_branches"][iz, ix] == ik.n_branches
            if ik.n_branches == 0:
                assert np.all(np.isnan(wmap["m_eff_best"][:, iz, ix]))
                continue
            for g, lam in enumerate(LAMBDAS.values()):
                m = [exiit.effective_mass(puma, q, (-1, 0, 0), lam) for q in ik.q]
                assert wmap["m_eff_best"][g, iz, ix] == pytest.approx(min(m), rel=1e-9)
                assert wmap["m_eff_worst"][g, iz, ix] == pytest.approx(max(m), rel=1e-9)
            checked += 1
    assert checked >= 3
    ok = np.isfinite(wmap["structure_peak_best"])
    assert np.all(wmap["structure_peak_best"][ok] <= wmap["structure_peak_worst"][ok])
    assert np.all(wmap["structure_peak_best"][ok] > 0)


def test_the_closed_form_map_is_the_iterative_solvers_map(puma, beam, wmap):
    # the PUMA's drive file declares the closed form; the same arm with the iterative solver
    newton = workspace_map(dataclasses.replace(puma, position_ik="iterative"), direction=[-1, 0, 0], y=-0.15005,
                           x_range=(-0.9, 0.9), z_range=(-0.9, 0.9), resolution=0.3, beam=beam, **KW)
    # x = 0 in the plane y = -d is the shoulder-singular line, where the shoulder's two branches
    # merge and Newton, its Jacobian singular, stops on near-duplicates of them
    off = ~np.isclose(wmap["x"], 0.0)
    assert np.all(wmap["n_branches"][:, ~off] <= newton["n_branches"][:, ~off])
    np.testing.assert_array_equal(newton["n_branches"][:, off], wmap["n_branches"][:, off])
    for key in ("m_eff", "m_eff_flexible", "structure_peak"):
        for end in ("best", "worst"):
            # Newton accepts a pose up to 1e-9 m off its target: m* moves by that through the
            # arm's conditioning (at most 1.2e-9 of m* measured over the full map's plane)
            np.testing.assert_allclose(wmap[f"{key}_{end}"][..., off], newton[f"{key}_{end}"][..., off], rtol=1e-7)


def test_direction_map_is_eq_7_along_each_direction(puma, beam):
    q = configuration_q(2)
    d = direction_map(puma, q, count=8, beam=beam, **KW)
    for k, a in enumerate(d["azimuth"]):
        n = [np.cos(a), np.sin(a), 0.0]
        for g, lam in enumerate(LAMBDAS.values()):
            assert d["m_eff"][g, k] == pytest.approx(exiit.effective_mass(puma, q, n, lam), rel=1e-9)
    assert np.all(d["m_eff_flexible"] < d["m_eff"])    # a free base can only lighten the tip


def test_maps_draw_with_units_and_the_paper_configurations(puma, wmap, beam):
    marks = plan_maps.paper_points(puma)
    assert np.allclose(marks[1], impact_point(puma, configuration_q(1)))
    fig = plan_maps.draw_workspace(wmap, marks=marks)
    labels = [ax.get_xlabel() for ax in fig.axes]
    assert "x [m]" in labels and any("[kg]" in ax.get_title() for ax in fig.axes)
    fig2 = plan_maps.draw_directions(direction_map(puma, configuration_q(1), count=12, beam=beam, **KW))
    assert any("[mm]" in ax.get_title() for ax in fig2.axes)
    plan_maps.style.plt.close("all")


@pytest.mark.parametrize("decades", [(1, 5), (0, 12)])
def test_direction_map_radial_labels_do_not_overlap(decades):
    # m* spanning decades, as near a direction at the edge of the range of G*
    az = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    m_eff = np.vstack([10 ** (decades[0] + (decades[1] - decades[0]) * np.sin(az) ** 2)] * 2)
    peak = 1e-3 * (2 + np.cos(az) ** 2) * np.array([[1.0], [2.5]])
    d = {"azimuth": az, "m_eff": m_eff, "m_eff_flexible": 0.9 * m_eff, "structure_peak": peak,
         "gain_classes": ["zero_low", "high"], "q": configuration_q(1)}
    fig = plan_maps.draw_directions(d)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes[:2]:     # m* and the peak displacement
        boxes = [t.get_window_extent(renderer) for t in ax.yaxis.get_ticklabels() if t.get_visible() and t.get_text()]
        assert len(boxes) >= 2
        for i, a in enumerate(boxes):
            for b in boxes[i + 1:]:
                assert not a.overlaps(b), (ax.get_title(), a, b)
    plan_maps.style.plt.close("all")


def test_map_cli_refuses_a_bad_output_name(capsys, tmp_path):
    status = main(["map", "directions", "--out", str(tmp_path / "x.jpg")])
    _, err = capsys.readouterr()
    assert status == 2 and "--out" in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_map_cli_writes_the_direction_map(capsys, tmp_path):
    out = tmp_path / "dirs.png"
    assert main(["map", "directions", "--config", "3", "--out", str(out), "--base", "fixed"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.with_suffix(".pdf").read_bytes()[:5] == b"%PDF-"


def test_a_grid_too_fine_is_refused_before_anything_is_allocated(capsys, tmp_path, monkeypatch):
    """``campaign map workspace --resolution 1e-6`` would need 4e12 points (tens of TiB): one
    line naming the resolution, exit 2, before the planner is built or a grid allocated."""
    from campaign.plan.grid import MAX_GRID_POINTS, grid_points

    assert grid_points(0.05) == 41 * 41 and grid_points(0.0025) <= MAX_GRID_POINTS
    with pytest.raises(ValueError, match=r"resolution = 1e-06 m gives a workspace grid of 2000001 x 2000001"):
        grid_points(1e-6)

    def no_planner(**kwargs):
        raise AssertionError("the planner was built for a grid that cannot be sampled")

    monkeypatch.setattr(plan_maps, "_setup", no_planner)
    status = main(["map", "workspace", "--resolution", "1e-6", "--out", str(tmp_path / "ws.png")])
    _, err = capsys.readouterr()
    assert status == 2 and "resolution" in err and len(err.strip().splitlines()) == 1, err
    assert not list(tmp_path.iterdir())
