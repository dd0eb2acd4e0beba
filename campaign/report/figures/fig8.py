"""Figure 8: the flexible-base set-up, drawn from the model and the rig parameters.

(a) The whole structure to scale: the vertical cantilever beam of length L clamped at its
foot, the emulated platform at its tip and the arm on top. (b) The top of the structure
enlarged: the platform, the 6-axis F/T sensor at the arm's base, and the arm in
configurations 1 and 2 (the flexible-base experiments of the paper) with the impact
direction n. The annotations (EI, L, beam and platform masses, first bending frequency with
the arm locked in each configuration) are computed from ``config/rig.yaml`` through
:class:`campaign.rig.beam.Beam`, the arm from its URDF.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import pinocchio as pin
from matplotlib.patches import Rectangle

from ...core.vocabulary import FLEXIBLE, LOW
from ...model.paper import configuration_q, impact_direction, load_paper
from ...model.robot import load_robot
from ...rig.beam import Beam
from ...scene.description import make_scene
from . import style
from .fig4 import arm_points

__all__ = ["arm_inertia_at_base", "draw", "make"]

#: configurations of the paper's flexible-base experiments (Table 4, Figure 9)
CONFIGS = (1, 2)
_ARM_COLOR = {1: "#225588", 2: "#d95f02"}


def arm_inertia_at_base(robot, q):
    """The locked arm as one rigid body, expressed in its base frame (``pinocchio.Inertia``)."""

    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, dtype=float))
    total = pin.Inertia.Zero()
    for j in range(1, model.njoints):
        total += data.oMi[j].act(model.inertias[j])
    return total


def draw(*, rig: str | os.PathLike | None = None, params: Mapping[str, Any] | None = None):
    """Draw Figure 8 from the rig parameters (``config/rig.yaml`` and overrides).

    Parameters
    ----------
    rig : path-like, optional
        Rig parameter file.
    params : mapping, optional
        Dotted-key rig parameter overrides (as the campaign's ``rig_params``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    paper = load_paper()
    scene = make_scene(base=FLEXIBLE, config=CONFIGS[0], gain=LOW, speed=1.0, rig=rig, params=params)
    beam = Beam.from_scene(scene)
    robot = load_robot(scene.p("robot"))
    n = impact_direction()
    L, h = beam.length, beam.mount_height
    mount = pin.SE3(np.eye(3), np.array([0.0, 0.0, h]))
    freqs = {c: beam.first_mode_frequency(tip=mount.act(arm_inertia_at_base(robot, configuration_q(c))))
             for c in CONFIGS}

    fig, (ax1, ax2) = style.new_figure(1, 2, width=7.0, height=4.0, gridspec_kw={"width_ratios": [1, 2.2]})
    # (a) to scale
    ax1.add_patch(Rectangle((-1.5, -0.8), 3.0, 0.8, facecolor="white", edgecolor="k", hatch="////", lw=0.6))
    ax1.plot([0, 0], [0, L], color="#555555", lw=4, solid_capstyle="butt", label="beam (cantilever)")
    ax1.add_patch(Rectangle((-0.3, L - 0.06), 0.6, 0.12, facecolor="#bbbbbb", edgecolor="k", lw=0.8))
    for c in CONFIGS:
        pts, _ = arm_points(robot, configuration_q(c))
        ax1.plot(pts[:, 0], pts[:, 2] + L + h, color=_ARM_COLOR[c], lw=1.5)
    xa = 0.1 * (L + 3.5)
    ax1.annotate("", xy=(xa, 0), xytext=(xa, L), arrowprops=dict(arrowstyle="<->", lw=0.8))
    ax1.text(xa * 1.15, L / 2, f"L = {L:g} m", rotation=90, va="center", ha="left")
    ax1.text(0.04, 0.5, f"EI = {beam.EI:.3g} N m$^2$\nbeam mass\n{beam.mass:g} kg", ha="left", va="center",
             transform=ax1.transAxes, fontsize=7.5)
    ax1.set_xlim(-0.5 * (L + 3.5), 0.25 * (L + 3.5))
    ax1.set_ylim(-1.0, L + 2.5)
    ax1.set_aspect("equal", adjustable="box")
    ax1.set_xlabel("x [m]")
    ax1.set_ylabel("height above the beam's foot [m]")
    ax1.set_title("(a) structure, to scale", loc="left")
    # (b) the top, enlarged: the arm's base frame is mount_height above the beam tip, where the
    # platform body (the emulated base) has its centre of mass
    ax2.plot([0, 0], [-0.6, 0], color="#555555", lw=8, solid_capstyle="butt")
    ax2.text(-0.06, -0.5, "beam (top)", ha="right", va="center", fontsize=7.5)
    ax2.add_patch(Rectangle((-0.3, -0.06), 0.6, 0.12, facecolor="#bbbbbb", edgecolor="k", lw=0.8, alpha=0.8))
    ax2.text(0.33, 0.0, f"platform {beam.platform_mass:g} kg\n(schematic; centre of mass\nat the beam tip)",
             ha="left", va="center", fontsize=7.5)
    ax2.plot([0], [h], marker="s", ms=7, color="#f2c14e", mec="k", ls="none",
             label=f"arm base: 6-axis F/T sensor, {h:g} m above the tip")
    for c in CONFIGS:
        pts, tip = arm_points(robot, configuration_q(c))
        ax2.plot(pts[:, 0], pts[:, 2] + h, "-o", color=_ARM_COLOR[c], lw=2.5, ms=3.5, mfc="white",
                 label=f"arm, configuration {c}")
        ax2.annotate("", xy=(tip[0] + 0.18 * n[0], tip[2] + h + 0.18 * n[2]), xytext=(tip[0], tip[2] + h),
                     arrowprops=dict(arrowstyle="-|>", color=_ARM_COLOR[c], lw=1.4, mutation_scale=10))
    ax2.text(-1.05, -0.22, "n (impact force)", ha="left", va="top", fontsize=7.5)
    modes = "\n".join(f"  arm locked in configuration {c}: {freqs[c]:.3f} Hz" for c in CONFIGS)
    ax2.text(0.08, -0.3, f"first bending mode (model):\n{modes}\n  beam + platform alone: "
             f"{beam.first_mode_frequency():.3f} Hz", fontsize=7, va="top", ha="left")
    ax2.set_xlim(-1.1, 1.2)
    ax2.set_ylim(-0.65, 0.65)
    ax2.set_aspect("equal", adjustable="box")
    ax2.set_xlabel("x [m]")
    ax2.set_ylabel("height above the beam tip [m]")
    ax2.set_title("(b) platform and arm, enlarged", loc="left")
    ax2.legend(loc="upper left", fontsize=7)
    fig.suptitle(f"Figure 8: flexible-base set-up emulated by the VES-II\n(vertical cantilever, EI = {beam.EI:.3g} "
                 f"N m$^2$; paper, section 4.2: {paper['beam_EI']:.3g} N m$^2$)", fontsize=9.5)
    return fig


def make(png: str | os.PathLike, pdf: str | os.PathLike | None = None, *, rig: str | os.PathLike | None = None,
         params: Mapping[str, Any] | None = None):
    """Draw Figure 8 and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw(rig=rig, params=params), png, pdf)
