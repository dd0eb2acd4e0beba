"""The elbow arm's closed-form inverse kinematics against Pinocchio's forward kinematics and the
iterative solver, on the planner map's grid and on random poses."""

from __future__ import annotations

import shutil

import numpy as np
import pinocchio as pin
import pytest

from campaign.core.tolerance import CROSS_PATH_RTOL
from campaign.model.paper import configuration_q
from campaign.model.robot import ROBOTS_DIR, load_robot
from campaign.model.robot.elbow import elbow_geometry
from campaign.model.robot.ik import impact_point, position_branches_many


def reach(puma) -> float:
    """The arm's reach [m]: the scale of its positions."""
    geo = elbow_geometry(puma.model, puma.impact_frame_id)
    return geo.l2 + geo.l3 + abs(geo.d)


def map_plane(puma, resolution: float) -> np.ndarray:
    """The workspace map's grid in the plane of the paper's configurations (targets, (M, 3))."""
    y = np.mean([impact_point(puma, configuration_q(c))[1] for c in (1, 2, 3)])
    axis = np.arange(-1.0, 1.0 + 0.5 * resolution, resolution)
    Z, X = np.meshgrid(axis, axis, indexing="ij")
    return np.stack([X.ravel(), np.full(X.size, y), Z.ravel()], axis=1)


def test_the_puma_is_solved_in_closed_form_and_the_planar_arm_iteratively(puma, planar, tmp_path):
    assert puma.position_ik == "elbow"          # its geometry is an elbow arm's
    assert planar.position_ik == "iterative"    # two joints
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "puma560", folder)
    with open(folder / "drives.yaml", "a") as fh:
        fh.write("position_ik: iterative\n")
    assert load_robot(folder).position_ik == "iterative"


def test_every_closed_form_branch_hits_its_target_by_pinocchio_forward_kinematics(puma):
    P = map_plane(puma, 0.05)
    res = position_branches_many(puma, P, method="elbow")
    data = puma.model.createData()
    hits = 0
    for p, r in zip(P, res, strict=True):
        for q in r.q:
            pin.framesForwardKinematics(puma.model, data, q)
            assert np.linalg.norm(data.oMf[puma.impact_frame_id].translation - p) <= CROSS_PATH_RTOL * reach(puma)
            assert np.all(q >= puma.q_lower) and np.all(q <= puma.q_upper)
            hits += 1
    assert hits > 2000       # the plane holds about 800 reachable points of up to 4 branches


def test_the_closed_form_finds_every_pose_within_the_limits_again(puma):
    rng = np.random.default_rng(11)
    Q = rng.uniform(puma.q_lower, puma.q_upper, size=(300, 3))
    P = np.array([impact_point(puma, q) for q in Q])
    counts = []
    for q, r in zip(Q, position_branches_many(puma, P, method="elbow"), strict=True):
        counts.append(r.n_branches)
        # the pose itself, to round-off amplified by how far it is from a singular one
        assert np.min(np.abs(r.q - q).max(axis=1)) < 1e-9
    assert max(counts) == 4


def test_the_closed_form_agrees_with_the_iterative_solver_on_the_map_grid(puma):
    P = map_plane(puma, 0.1)
    closed = position_branches_many(puma, P, method="elbow")
    newton = position_branches_many(puma, P, method="iterative")
    geo = elbow_geometry(puma.model, puma.impact_frame_id)
    # the shoulder-singular line (the target on the circle of radius d about z, r = 0): the
    # shoulder's two branches merge there and Newton's Jacobian is singular
    singular = np.abs(np.hypot(P[:, 0], P[:, 1]) - abs(geo.d)) < 1e-6
    assert singular.any() and not singular.all()
    data = puma.model.createData()
    compared = 0
    for c, n, on_line in zip(closed, newton, singular, strict=True):
        if on_line:
            # Newton stops there on near-duplicates of the closed form's poses
            assert c.n_branches <= n.n_branches
            for q in n.q:
                assert np.min(np.abs(c.q - q).max(axis=1)) < 1e-3
            continue
        assert c.n_branches == n.n_branches and c.reached_outside_limits == n.reached_outside_limits
        for q in c.q:
            k = np.argmin(np.abs(n.q - q).max(axis=1))
            # the same pose but for Newton's own error: the joint-space difference moves the
            # impact point by no more than Newton's residual (it accepts up to 1e-9 m)
            J = pin.computeFrameJacobian(puma.model, data, q, puma.impact_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
            assert np.linalg.norm(J @ (n.q[k] - q)) <= n.residual[k] + CROSS_PATH_RTOL * reach(puma)
            assert np.max(np.abs(n.q[k] - q)) < 1e-6
            compared += 1
    assert compared > 400


def test_a_drive_file_declaring_the_closed_form_of_an_arm_it_does_not_fit_is_refused(tmp_path):
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "planar2", folder)
    text = (folder / "drives.yaml").read_text()
    (folder / "drives.yaml").write_text(text + "position_ik: elbow\n")
    with pytest.raises(ValueError, match=r"drives.yaml: position_ik elbow needs 3 revolute active joints"):
        load_robot(folder)
    (folder / "drives.yaml").write_text(text + "position_ik: magic\n")
    with pytest.raises(ValueError, match=r"position_ik = 'magic' must be one of auto, iterative, elbow"):
        load_robot(folder)


def test_a_puma_with_a_tilted_first_axis_is_solved_iteratively_and_refused_the_closed_form(tmp_path):
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "puma560", folder)
    urdf = (folder / "puma560.urdf").read_text()
    first = urdf.index('<axis xyz="0 0 1"/>')
    (folder / "puma560.urdf").write_text(urdf[:first] + '<axis xyz="0 1 0"/>' + urdf[first + 19:])
    assert load_robot(folder).position_ik == "iterative"
    with open(folder / "drives.yaml", "a") as fh:
        fh.write("position_ik: elbow\n")
    with pytest.raises(ValueError, match=r"position_ik elbow does not fit this arm: joint 1 does not turn about"):
        load_robot(folder)
