"""A seven-axis test arm and synthetic per-hit rows from it.

The arm has the joint layout of a KUKA LBR iiwa 7 (axes z, y, z, -y, z, y, z from the base;
0.34 m to the shoulder, 0.4 m upper arm and forearm, 0.126 m wrist to flange, a 0.105 m
stick) with round link masses and cylinder inertias of its own: a stand-in with the iiwa's
kinematic structure for tests, not a model of any real arm.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from campaign.design.recorded import HIT_COLUMNS
from campaign.model.exiit import effective_mass_batch

#: (joint axis, offset of the joint from the previous one along z [m], link mass [kg], link length [m])
_LINKS = (((0, 0, 1), 0.15, 4.0, 0.19), ((0, 1, 0), 0.19, 4.0, 0.21), ((0, 0, 1), 0.21, 3.0, 0.19),
          ((0, -1, 0), 0.19, 3.0, 0.21), ((0, 0, 1), 0.21, 2.0, 0.19), ((0, 1, 0), 0.19, 2.0, 0.081),
          ((0, 0, 1), 0.081, 1.0, 0.045))
_LIMITS_DEG = (170, 120, 170, 120, 170, 120, 175)

#: the two sessions' poses [deg] (the arm strikes along +y of its base)
POSES_DEG = {"config_1": (-11.0, 62.0, 29.0, -92.0, -102.0, -60.0, -58.0),
             "config_2": (-49.0, 86.0, 68.0, -87.0, -161.0, -54.0, -19.0)}
DIRECTION = (0.0, 1.0, 0.0)


def _inertia_xml(m: float, length: float, r: float = 0.06) -> str:
    ixx = m * (3 * r * r + length * length) / 12
    izz = m * r * r / 2
    return (f'<inertial><origin xyz="0 0 {length / 2:.6g}" rpy="0 0 0"/><mass value="{m:g}"/>'
            f'<inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{ixx:.6g}" iyz="0" izz="{izz:.6g}"/></inertial>')


def write_arm(folder: Path) -> Path:
    """Write the arm's URDF and drive file into ``folder``; returns the folder."""
    folder.mkdir(parents=True, exist_ok=True)
    parts = ['<?xml version="1.0"?>', '<robot name="seven_axis">',
             f'<link name="link_0">{_inertia_xml(5.0, 0.15, 0.1)}</link>']
    for i, (axis, dz, mass, length) in enumerate(_LINKS, start=1):
        lim = math.radians(_LIMITS_DEG[i - 1])
        parts.append(f'<joint name="j{i}" type="revolute"><parent link="link_{i - 1}"/><child link="link_{i}"/>'
                     f'<origin xyz="0 0 {dz:g}" rpy="0 0 0"/><axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
                     f'<limit lower="{-lim:.12g}" upper="{lim:.12g}" effort="100" velocity="3"/></joint>')
        parts.append(f'<link name="link_{i}">{_inertia_xml(mass, length)}</link>')
    parts.append("</robot>")
    (folder / "seven_axis.urdf").write_text("\n".join(parts) + "\n", encoding="utf-8")
    joints = "\n".join(f"  j{i}: {{Jm: 0.0, G: 1.0, B: 0.0, Tc_pos: 0.0, Tc_neg: 0.0, tau_max: 100.0, "
                       f"encoder_resolution: 1.0e-5}}" for i in range(1, 8))
    (folder / "drives.yaml").write_text(
        "robot: seven_axis\nurdf: seven_axis.urdf\n"
        f"active_joints: [{', '.join(f'j{i}' for i in range(1, 8))}]\nlocked_q: {{}}\n"
        "impact_frame: {name: impact_point, parent_frame: link_7, xyz: [0.0, 0.0, 0.15]}\n"
        f"joints:\n{joints}\n", encoding="utf-8")
    return folder


def hit_rows(robot, lam, *, poses_deg=POSES_DEG, direction=DIRECTION, hits: int = 12, jitter_deg: float = 0.3,
             noise: float = 0.02, seed: int = 0) -> list[dict]:
    """Per-hit rows with m* from eq 11 at ``lam``: ``hits`` per session, each pose jittered by
    ``jitter_deg`` (normal, per joint), m* scattered by ``noise`` (relative, normal), the
    interval +-2 noise, the logged m* the rigid-body model's."""
    rng = np.random.default_rng(seed)
    rows = []
    for session, pose in poses_deg.items():
        Q = np.radians(np.asarray(pose, float) + rng.normal(0.0, jitter_deg, (hits, robot.nv)))
        m_true = effective_mass_batch(robot, Q, direction, lam)
        m_rigid = effective_mass_batch(robot, Q, direction, None)
        m = m_true * (1.0 + noise * rng.normal(size=hits))
        for k in range(hits):
            row = {"hit": f"{session}-{k + 1}", "session": session, "object_mass": 1.915,
                   "n_x": direction[0], "n_y": direction[1], "n_z": direction[2], "speed": 1.4,
                   "m_eff": m[k], "m_eff_lo": m[k] * (1 - 2 * noise), "m_eff_hi": m[k] * (1 + 2 * noise),
                   "e": 0.35, "e_lo": 0.3, "e_hi": 0.4, "m_eff_logged": m_rigid[k], "flag": "ok"}
            row.update({f"q_{j + 1}": Q[k, j] for j in range(robot.nv)})
            rows.append(row)
    return rows


def write_rows(path: Path, rows: list[dict], nv: int = 7) -> Path:
    """Write per-hit rows as the CSV :func:`campaign.design.recorded.read_hit_rows` reads."""
    first, last = HIT_COLUMNS
    fields = [*first, *(f"q_{j + 1}" for j in range(nv)), *last]
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (repr(float(v)) if isinstance(v, (float, np.floating)) else v)
                             for k, v in row.items()})
    return path
