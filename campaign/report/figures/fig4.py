"""Figure 4: the arm configurations of Table 1 and the impact direction, from the model.

A side view (x-z plane of the arm's base frame) of each configuration: a stick figure
through the origins of the model's body frames in kinematic order (the links the reduced
Pinocchio model carries, locked wrist included) ending at the impact point, with the
impact direction n drawn at the tip. Nothing is typed in: the joint angles come from
``config/paper.yaml``, the geometry from the robot's URDF through
:func:`campaign.model.robot.load_robot`.
"""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
from matplotlib.patches import Rectangle
from matplotlib.ticker import MultipleLocator

from ...model.paper import configuration_q, impact_direction, load_paper
from ...model.robot import load_robot
from . import style

__all__ = ["arm_points", "draw", "make"]


def arm_points(robot, q) -> tuple[np.ndarray, np.ndarray]:
    """Stick-figure points of the arm at joint angles ``q`` (DH, rad), base frame.

    Returns
    -------
    points : ndarray, shape (k, 3)
        Origins of the body frames in kinematic order, consecutive duplicates removed,
        starting at the base frame origin [m].
    tip : ndarray, shape (3,)
        The impact point [m].
    """
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, dtype=float))
    pin.updateFramePlacements(model, data)
    pts = [np.zeros(3)]
    for i, frame in enumerate(model.frames):
        if frame.type == pin.FrameType.BODY:
            p = np.array(data.oMf[i].translation)
            if np.linalg.norm(p - pts[-1]) > 1e-6:
                pts.append(p)
    tip = np.array(data.oMf[robot.impact_frame_id].translation)
    if np.linalg.norm(tip - pts[-1]) > 1e-6:
        pts.append(tip)
    return np.array(pts), tip


def draw(robot_name: str | None = None):
    """Draw Figure 4 (one panel per configuration of Table 1).

    Parameters
    ----------
    robot_name : str, optional
        Robot of :func:`campaign.model.robot.load_robot`; default the paper's (``paper.yaml``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    paper = load_paper()
    robot = load_robot(robot_name or paper["robot"])
    n = impact_direction()
    configs = sorted(paper["configurations"])
    names = {1: "intermediate", 2: "stretched", 3: "folded"}
    fig, axes = style.new_figure(1, len(configs), width=7.0, height=2.9, sharex=True, sharey=True)
    axes = np.atleast_1d(axes)
    reach = 0.0
    for ax, c in zip(axes, configs, strict=True):
        pts, tip = arm_points(robot, configuration_q(c))
        reach = max(reach, float(np.max(np.abs(pts[:, [0, 2]]))))
        ax.axvline(0.0, color=style.PAPER_COLOR, lw=0.6, ls=(0, (4, 3)), label="joint 1 axis")
        ax.plot(pts[:, 0], pts[:, 2], "-", color="#225588", lw=3.0, solid_capstyle="round", label="links")
        ax.plot(pts[:-1, 0], pts[:-1, 2], "o", ms=4.5, mfc="white", mec="#225588", mew=1.2, label="frames")
        ax.plot(tip[0], tip[2], "o", ms=6, color="#d95f02", label="impact point (wrist centre)")
        ax.add_patch(Rectangle((-0.08, -0.05), 0.16, 0.05, facecolor="white", edgecolor="k", hatch="////", lw=0.6,
                               label="base (fixed)"))
        # the hammer strikes along n: the force on the arm points along n
        length = 0.22
        ax.annotate("", xy=(tip[0] + length * n[0], tip[2] + length * n[2]), xytext=(tip[0], tip[2]),
                    arrowprops=dict(arrowstyle="-|>", color="#d95f02", lw=1.6, mutation_scale=12))
        ax.text(tip[0] + 0.5 * length * n[0], tip[2] + 0.5 * length * n[2] + 0.04, "n", color="#d95f02",
                ha="center", va="bottom", fontsize=10, fontstyle="italic")
        q = paper["configurations"][c]
        ax.set_title(f"Configuration {c} ({names.get(c, 'custom')})\n"
                     f"q = ({q[0]:g}, {q[1]:g}, {q[2]:g}) deg", fontsize=8.5)
        ax.set_xlabel("x [m]")
        ax.set_aspect("equal", adjustable="box")
    axes[0].set_ylabel("z [m]")
    lim = reach + 0.3
    axes[0].set_xlim(-lim, 0.35)
    axes[0].set_ylim(-0.45, 0.55)
    handles, labels = axes[0].get_legend_handles_labels()
    axes[0].xaxis.set_major_locator(MultipleLocator(0.5))
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), frameon=False)
    fig.suptitle(f"Figure 4: arm configurations (Table 1) and impact direction n = "
                 f"({n[0]:g}, {n[1]:g}, {n[2]:g}), {robot.name} model, side view", fontsize=9.5)
    return fig


def make(png: str | os.PathLike, pdf: str | os.PathLike | None = None, *, robot_name: str | None = None):
    """Draw Figure 4 and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw(robot_name), png, pdf)
