"""A simulated trial written in the air-hockey layout, with a real logger's quirks.

The rig's arm is struck by a pendulum hammer; the air-hockey robot strikes a box. In both a
body of known mass (the box; the hammer head, of effective mass ``m_b``) changes its
momentum by the contact's impulse while the arm's end effector changes its velocity, so
the export maps the hammer head to "the object": its position along its swing (the pivot
encoder's angle, through the pendulum's radius) in the arm's base frame, and the arm's
impact point to "the end effector". The rig's truth (true joint states, the hammer's angle)
is sampled at the logger's rate, then the logger's quirks are added: stale rows repeating
the previous end-effector pose, stamps off by a whole period, a jittered tick, and the
motion capture on its own clock, leading the robot's, with position noise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..core.files import write_atomic
from ..model import exiit_fixed, impact_jacobian, impact_point, load_robot
from .airhockey import ROBOT_COLUMNS, object_column

__all__ = ["export_airhockey", "truth_of"]

_EPOCH = 1.7e9


def _fmt(values) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(values))


def truth_of(trial: str | Path) -> dict[str, float]:
    """The rig's truth of a trial as the identification of a recorded hit names it: the hammer
    head as the object, ``m_eff`` = m_b (v_b - v_b') / (v_a' - v_a) and ``e`` (eq 12)."""
    with xr.open_dataset(trial, engine="h5netcdf", group="truth") as tr:
        tr.load()
    with xr.open_dataset(trial, engine="h5netcdf", group="measured") as me:
        me.load()
    mb = float(me.hammer_mass_eff)
    va, va2, vb, vb2 = (float(tr[k]) for k in ("v_a_pre", "v_a_post", "v_b_pre", "v_b_post"))
    return {"m_eff": mb * (vb - vb2) / (va2 - va), "e": (va2 - vb2) / (vb - va), "object_mass": mb,
            "speed": vb - va, "contact_start": float(tr.contact_start), "contact_end": float(tr.contact_end)}


def export_airhockey(trial: str | Path, folder: str | Path, *, hit: int = 1, rate: float = 200.0,
                     stale_fraction: float = 0.2, glitches: int = 2, clock_lead: float = 0.006,
                     mocap_noise: float = 5e-5, ee_noise: float = 1e-5, seed: int = 0, robot_name: str = "PUMA_560") -> tuple[Path, Path]:
    """Write a fixed-base trial's hit as ``<robot_name>_hit_<hit>.csv`` and ``object_1_hit_<hit>.csv``.

    Parameters
    ----------
    trial : path
        A trial file with its truth group (fixed base).
    folder : path
        Where the two files go (created).
    rate : float
        The logger's rate [Hz], for the robot and the motion capture.
    stale_fraction : float
        Fraction of robot rows that repeat the previous end-effector pose.
    glitches : int
        Robot stamps moved by one period (alternately later and earlier), data unchanged.
    clock_lead : float
        How much the motion capture's stamps lead the robot's [s].
    mocap_noise, ee_noise : float
        Standard deviation of the object's and the end effector's position noise per axis [m]
        (an arm at rest then logs no two equal poses, as a real one does not).
    seed : int
        Seed of the quirks and the noise.

    Returns
    -------
    (robot file, object file)
    """
    rng = np.random.default_rng(seed)
    with xr.open_dataset(trial, engine="h5netcdf", group="truth") as tr:
        tr.load()
    with xr.open_dataset(trial, engine="h5netcdf", group="measured") as me:
        me.load()
    with xr.open_dataset(trial, engine="h5netcdf") as root:
        robot = load_robot(str(root.attrs["robot"]))
    t_truth = np.asarray(tr.t_truth.values)
    q_truth, v_truth = np.asarray(tr.q.values), np.asarray(tr.v.values)
    n = np.asarray(me.impact_direction.values, float)
    radius = float(me.pendulum_radius)
    data = robot.model.createData()
    q_touch = np.array([np.interp(float(tr.contact_start), t_truth, q_truth[:, k]) for k in range(q_truth.shape[1])])
    touch = impact_point(robot, q_touch, data=data)
    period = 1.0 / rate
    # the rig stops following the hammer some time after the contact (its angle then stays put)
    moving = np.flatnonzero(np.asarray(tr.theta_dot.values) != 0.0)
    t_last = float(t_truth[moving[-1]]) if len(moving) else float(t_truth[-1])
    times = np.arange(t_truth[0] + period, min(t_truth[-1], t_last) - period, period)
    ticks = times + rng.normal(0.0, 2e-5, len(times))
    nj = q_truth.shape[1]
    q = np.array([np.interp(times, t_truth, q_truth[:, k]) for k in range(nj)]).T
    qd = np.array([np.interp(times, t_truth, v_truth[:, k]) for k in range(nj)]).T
    rows = []
    for k in range(len(times)):
        ee = impact_point(robot, q[k], data=data) + rng.normal(0.0, ee_noise, 3)
        J = impact_jacobian(robot.model, data, q[k], robot.impact_frame_id)[:3]
        g33 = exiit_fixed(robot, q[k], data=data)[:3, :3]
        rows.append({"q": q[k], "qd": qd[k], "ee": ee, "vee": J @ qd[k], "inertia": g33})
    stale = rng.random(len(rows)) < stale_fraction
    stale[:2] = False
    for k in np.flatnonzero(stale):
        for key in ("ee", "vee", "inertia"):
            rows[k][key] = rows[k - 1][key]
    stamps = _EPOCH + ticks
    for i, k in enumerate(rng.choice(np.arange(5, len(stamps) - 5), size=glitches, replace=False)):
        stamps[k] += period if i % 2 == 0 else -period
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    zeros = _fmt(np.zeros(nj))
    lines = [f"DesiredFlux,{float(tr.v_b_pre):.6g},HitTime,{_EPOCH + float(tr.contact_start):.7f},"
             f"DesiredPos,{_fmt(touch)}", ",".join(ROBOT_COLUMNS)]
    for stamp, r in zip(stamps, rows, strict=True):
        lines.append(",".join([robot_name, f"{stamp:.7f}", " " + _fmt(r["q"]), " " + _fmt(r["qd"]), zeros, zeros,
                               "  " + _fmt(r["ee"]), " 0 0 0 1", _fmt(r["vee"]), "0 0 0", "  " + _fmt(r["inertia"]),
                               zeros, "0"]))
    robot_file = write_atomic(folder / f"{robot_name}_hit_{hit}.csv", "\n".join(lines) + "\n")
    # the hammer head: angle theta from the bottom, positive along n; its arc in the vertical plane through n
    theta = np.interp(times, t_truth, np.asarray(tr.theta.values))
    head = (touch[None, :] + radius * np.sin(theta)[:, None] * n[None, :]
            + radius * (1.0 - np.cos(theta))[:, None] * np.array([0.0, 0.0, 1.0])[None, :])
    head = head + rng.normal(0.0, mocap_noise, head.shape)
    ostamps = _EPOCH + times - clock_lead + rng.normal(0.0, 2e-5, len(times))
    col = object_column(robot_name)
    olines = [f"RosTime,{col},Orientation{col[len('Position'):]}"]
    olines += [f"{s:.7f},{_fmt(p)}, 0 0 0 1" for s, p in zip(ostamps, head, strict=True)]
    object_file = write_atomic(folder / f"object_1_hit_{hit}.csv", "\n".join(olines) + "\n")
    return robot_file, object_file
