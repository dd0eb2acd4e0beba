"""The robot loader: URDF + drive file -> reduced Pinocchio model with armature and impact frame.

References here are written independently of Pinocchio: the standard DH forward kinematics of
the PUMA 560 (Corke & Armstrong-Helouvry parameters, design section 3) and the planar arm's
trigonometry.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

from campaign.core.errors import InputError
from campaign.core.yamlfile import yaml_load
from campaign.model import conventions
from campaign.model.paper import configuration_q, load_paper, paper_offset_deg, paper_q
from campaign.model.robot import ROBOTS_DIR, load_robot

# Standard DH table of the PUMA 560 (alpha [rad], a [m], d [m]), joints 1-6.
PUMA_DH = [
    (np.pi / 2, 0.0, 0.0),
    (0.0, 0.4318, 0.0),
    (-np.pi / 2, 0.0203, 0.15005),
    (np.pi / 2, 0.0, 0.4318),
    (-np.pi / 2, 0.0, 0.0),
    (0.0, 0.0, 0.0),
]


def dh_transform(theta, alpha, a, d):
    """Standard DH: Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [0.0, sa, ca, d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def puma_wrist_centre(q3):
    """Origin of DH frame 6 with joints 4-6 at 0 [m]."""
    T = np.eye(4)
    for theta, (alpha, a, d) in zip(list(q3) + [0.0, 0.0, 0.0], PUMA_DH, strict=True):
        T = T @ dh_transform(theta, alpha, a, d)
    return T[:3, 3]


def drives(name):
    with open(ROBOTS_DIR / name / "drives.yaml") as fh:
        return yaml_load(fh)


def test_puma_is_reduced_to_the_three_active_joints(puma):
    assert puma.model.nq == puma.model.nv == 3
    assert puma.joint_names == ("j1", "j2", "j3")
    assert puma.model.frames[puma.impact_frame_id].name == "impact_point"


def test_puma_armature_and_friction_are_referred_to_the_joint_side(puma):
    spec = drives("puma560")["joints"]
    Jm = np.array([spec[j]["Jm"] for j in puma.joint_names])
    G = np.array([spec[j]["G"] for j in puma.joint_names])
    B = np.array([spec[j]["B"] for j in puma.joint_names])
    np.testing.assert_allclose(puma.armature, Jm * G**2, rtol=1e-15)
    np.testing.assert_allclose(puma.model.armature, Jm * G**2, rtol=1e-15)
    np.testing.assert_allclose(puma.viscous, B * G**2, rtol=1e-15)
    tc_neg = np.array([spec[j]["Tc_neg"] for j in puma.joint_names])
    np.testing.assert_allclose(puma.coulomb_neg, np.abs(tc_neg * G), rtol=1e-15)
    assert np.all(puma.coulomb_pos > 0) and np.all(puma.coulomb_neg > 0)


def test_locked_links_ride_on_link3(puma):
    """Reducing the model keeps the mass of links 4-6 (they are welded to link 3)."""
    urdf = ET.parse(ROBOTS_DIR / "puma560" / "puma560.urdf")
    total = sum(float(m.get("value")) for m in urdf.getroot().iter("mass"))
    assert pin.computeTotalMass(puma.model) == pytest.approx(total, rel=1e-14)


@pytest.mark.parametrize("seed", range(5))
def test_puma_impact_point_is_the_dh_wrist_centre(puma, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(puma.q_lower, puma.q_upper)
    data = puma.model.createData()
    pin.framesForwardKinematics(puma.model, data, q)
    np.testing.assert_allclose(data.oMf[puma.impact_frame_id].translation, puma_wrist_centre(q), atol=1e-12)


def test_paper_configurations_map_to_dh_angles():
    assert drives("puma560")["angle_offset_deg"] == [0.0, 0.0, -90.0]     # the PUMA's own convention
    assert "offset_deg" not in load_paper()                               # stated once, by the robot
    np.testing.assert_array_equal(paper_offset_deg(), [0.0, 0.0, -90.0])
    np.testing.assert_allclose(configuration_q(1), np.radians([0.0, 150.0, 0.0]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(configuration_q(3), paper_q([0.0, 135.0, 135.0]), rtol=0, atol=0)
    with pytest.raises(ValueError, match="unknown configuration 4"):
        configuration_q(4)


def test_joint_limits_are_inclusive(puma):
    """Configuration 3 sits exactly on joint 3's +45 deg DH limit and is accepted; a hair beyond is not."""
    q3 = configuration_q(3)
    assert q3[2] == pytest.approx(puma.q_upper[2], abs=1e-12)
    np.testing.assert_array_equal(puma.check_q(q3), q3)
    beyond = q3 + np.array([0.0, 0.0, 1e-6])
    with pytest.raises(ValueError, match=r"joint j3 angle 45\.0001 deg \(DH\) is outside"):
        puma.check_q(beyond)
    with pytest.raises(ValueError, match="must have 3 angles"):
        puma.check_q([0.0, 1.0])
    with pytest.raises(ValueError, match="not finite"):
        puma.check_q([0.0, np.nan, 0.0])


def test_planar_arm_loads_from_its_own_urdf_and_drive_file(planar):
    assert planar.model.nq == 2 and planar.joint_names == ("j1", "j2")
    spec = drives("planar2")["joints"]
    np.testing.assert_allclose(planar.armature, [spec["j1"]["Jm"], spec["j2"]["Jm"]], rtol=1e-15)
    data = planar.model.createData()
    rng = np.random.default_rng(7)
    for q in rng.uniform(-3.0, 3.0, size=(10, 2)):
        pin.framesForwardKinematics(planar.model, data, q)
        tip = [0.5 * np.cos(q[0]) + 0.4 * np.cos(q[0] + q[1]), 0.5 * np.sin(q[0]) + 0.4 * np.sin(q[0] + q[1]), 0.0]
        np.testing.assert_allclose(data.oMf[planar.impact_frame_id].translation, tip, atol=1e-14)


def test_a_robot_folder_outside_the_package_loads_the_same_way(tmp_path, planar):
    folder = tmp_path / "myarm"
    shutil.copytree(ROBOTS_DIR / "planar2", folder)
    for path in (folder, folder / "drives.yaml"):
        robot = load_robot(path)
        np.testing.assert_array_equal(robot.armature, planar.armature)
        assert robot.source == str(folder / "drives.yaml")


def test_unknown_robot_is_named(tmp_path):
    with pytest.raises(ValueError, match=r"unknown robot 'nosuchbot'.*planar2.*puma560"):
        load_robot("nosuchbot")


def test_a_joint_neither_active_nor_locked_is_an_error(tmp_path):
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "planar2", folder)
    text = (folder / "drives.yaml").read_text().replace("active_joints: [j1, j2]", "active_joints: [j1]")
    (folder / "drives.yaml").write_text(text)
    with pytest.raises(ValueError, match=r"joints \['j2'\] are neither active nor locked"):
        load_robot(folder)


# -- pose conventions: the angles a pose is given in, the numbered configurations ----------
def test_the_puma_takes_the_paper_angles_and_table_1(puma):
    np.testing.assert_array_equal(puma.angle_offset_deg, [0.0, 0.0, -90.0])
    assert conventions.configurations("puma560") == {int(k): v for k, v in load_paper()["configurations"].items()}
    for config, angles in conventions.configurations("puma560").items():
        np.testing.assert_array_equal(puma.q_from_angles(angles), configuration_q(config))
    assert conventions.angle_count("puma560") == 3


def test_the_second_robot_takes_its_own_angles_and_configurations(planar):
    np.testing.assert_array_equal(planar.angle_offset_deg, [0.0, 0.0])
    table = conventions.configurations("planar2")
    assert sorted(table) == [1, 2, 3] and all(len(q) == 2 for q in table.values())
    np.testing.assert_array_equal(planar.q_from_angles([-45.0, 30.0]), np.radians([-45.0, 30.0]))
    assert conventions.angle_count("planar2") == 2
    with pytest.raises(ValueError, match=r"robot planar2 takes 2 joint angles \(j1, j2\), got \[0.0, 150.0, 90.0\]"):
        planar.q_from_angles([0.0, 150.0, 90.0])


def test_an_angle_offset_shifts_the_model_angles_and_needs_one_per_joint(tmp_path):
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "planar2", folder)
    text = (folder / "drives.yaml").read_text()
    (folder / "drives.yaml").write_text(text.replace("angle_offset_deg: [0.0, 0.0]", "angle_offset_deg: [10.0, -90.0]"))
    arm = load_robot(folder)
    np.testing.assert_allclose(arm.q_from_angles([0.0, 120.0]), np.radians([10.0, 30.0]), rtol=0, atol=1e-15)
    assert conventions.angle_offset_deg(folder) == [10.0, -90.0]
    (folder / "drives.yaml").write_text(text.replace("angle_offset_deg: [0.0, 0.0]", "angle_offset_deg: [10.0]"))
    with pytest.raises(ValueError, match=r"angle_offset_deg must be 2 finite angles"):
        load_robot(folder)
    with pytest.raises(InputError, match=r"angle_offset_deg must be 2 finite numbers"):
        conventions.angle_offset_deg(folder)


def test_a_robot_without_an_offset_or_configurations_takes_its_model_angles(tmp_path):
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "planar2", folder)
    text = (folder / "drives.yaml").read_text()
    start, end = text.index("angle_offset_deg:"), text.index("units:")
    (folder / "drives.yaml").write_text(text[:start] + text[end:])
    np.testing.assert_array_equal(load_robot(folder).angle_offset_deg, [0.0, 0.0])
    assert conventions.configurations(folder) == {}


@pytest.mark.parametrize("configurations, message", [
    ("{1: [0.0]}", r"configuration 1 must be 2 finite numbers"),
    ("{0: [0.0, 1.0]}", r"configuration 0 is not a number >= 1"),
    ("[[0.0, 1.0]]", r"expected a mapping of configuration numbers"),
    ("no_such_file.yaml", r"'no_such_file.yaml' names .*no_such_file.yaml, which does not exist"),
])
def test_bad_configurations_are_named(tmp_path, configurations, message):
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "planar2", folder)
    text = (folder / "drives.yaml").read_text()
    start, end = text.index("configurations:"), text.index("units:")
    (folder / "drives.yaml").write_text(text[:start] + f"configurations: {configurations}\n" + text[end:])
    with pytest.raises(InputError, match=message):
        conventions.configurations(folder)
