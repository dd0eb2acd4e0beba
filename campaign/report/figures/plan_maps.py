"""The planner's maps: effective mass and structure excitation over the workspace and the directions.

* :func:`draw_workspace`: in a vertical plane of the arm's base frame (the plane of the
  paper's configurations by default), per gain class, m* (eq 7) of the best and the worst
  inverse-kinematics branch reaching each point, and on the flexible base the predicted peak
  base displacement of the structure's first bending pair (best and worst branch); the
  paper's configurations 1-3 are marked.
* :func:`draw_directions`: at one pose, m* (eq 7 fixed, eq 8 flexible) and the structure's
  predicted peak displacement against the horizontal impact direction (polar axes), per gain
  class: the direction of least excitation the paper leaves open.

The numbers come from :func:`campaign.plan.maps.workspace_map` and :func:`campaign.plan.maps.direction_map`.
"""

from __future__ import annotations

import os

import numpy as np

from ...core.vocabulary import FLEXIBLE
from ...model.paper import configuration_q, impact_direction, load_paper
from ...model.robot.ik import impact_point
from ...plan.factory import build_planner
from ...plan.grid import grid_points
from ...plan.maps import direction_map, workspace_map
from ...rig.contact import ContactLaw
from . import style

__all__ = ["draw_workspace", "draw_directions", "make_workspace", "make_directions", "workspace_figure",
           "directions_figure", "paper_points", "MAP_SPEED"]

#: the object's speed of the maps [m/s]
MAP_SPEED = 2.0

_CLASS_COLOR = ("#7570b3", "#d95f02", "#1b9e77", "#e7298a")


def paper_points(robot) -> dict[int, np.ndarray]:
    """Impact points [m] of the paper's configurations (Table 1), base frame."""

    return {int(c): impact_point(robot, configuration_q(c)) for c in sorted(load_paper()["configurations"])}


def draw_workspace(m: dict, *, marks: dict[int, np.ndarray] | None = None):
    """Figure of :func:`campaign.plan.maps.workspace_map`'s output; returns the matplotlib figure."""
    names = m["gain_classes"]
    panels = [("m_eff_best", "m* best branch [kg]"), ("m_eff_worst", "m* worst branch [kg]")]
    if "structure_peak_best" in m:
        panels += [("structure_peak_best", "peak base displacement,\nbest branch [mm]"),
                   ("structure_peak_worst", "peak base displacement,\nworst branch [mm]")]
    fig, axes = style.new_figure(len(names), len(panels), width=2.1 * len(panels) + 0.6,
                                 height=2.3 * len(names) + 0.4, sharex=True, sharey=True, squeeze=False)
    x, z = m["x"], m["z"]
    n = m["direction"]
    for key, label in panels:
        vals = m[key] * (1e3 if key.startswith("structure") else 1.0)
        finite = vals[np.isfinite(vals)]
        # one colour scale per column (both gain classes), log for m*: it spans decades
        lo, hi = (np.percentile(finite, 1), np.percentile(finite, 99)) if finite.size else (1.0, 2.0)
        for g, name in enumerate(names):
            ax = axes[g, [k for k, _ in panels].index(key)]
            data = np.ma.masked_invalid(vals[g])
            if key.startswith("m_eff"):
                from matplotlib.colors import LogNorm
                norm = LogNorm(vmin=max(lo, 1e-3), vmax=max(hi, lo * 1.01))
            else:
                from matplotlib.colors import Normalize
                norm = Normalize(vmin=lo, vmax=hi)
            # rasterised in the PDF: thousands of grid cells as vector quads cost seconds to
            # draw and megabytes to store, for no gain at print resolution
            im = ax.pcolormesh(x, z, data, shading="nearest", cmap="viridis", norm=norm, rasterized=True)
            for c, p in (marks or {}).items():
                ax.plot(p[0], p[2], marker="o", ms=5, mfc="white", mec="k", ls="none")
                ax.annotate(str(c), (p[0], p[2]), xytext=(3, 3), textcoords="offset points", fontsize=7)
            ax.plot(0, 0, marker="^", color="k", ms=5)
            ax.set_aspect("equal")
            if g == 0:
                ax.set_title(label)
            if g == len(names) - 1:
                ax.set_xlabel("x [m]")
            if key == panels[0][0]:
                ax.set_ylabel(f"{name}\nz [m]")
            if g == len(names) - 1:
                cb = fig.colorbar(im, ax=axes[:, [k for k, _ in panels].index(key)], shrink=0.8, location="bottom")
                from matplotlib.ticker import NullFormatter
                cb.ax.xaxis.set_minor_formatter(NullFormatter())   # log scale: label the decades only
    fig.suptitle(f"Impact planner over the plane y = {m['y']:.3f} m, n = ({n[0]:.2g}, {n[1]:.2g}, {n[2]:.2g}); "
                 "circles: the paper's configurations, triangle: arm base", fontsize=8.5)
    return fig


def draw_directions(d: dict, *, title: str = ""):
    """Figure of :func:`campaign.plan.maps.direction_map`'s output (polar axes); returns the figure."""
    has_structure = "structure_peak" in d
    fig = style.plt.figure(figsize=(6.5 if has_structure else 3.6, 3.4), layout="constrained")
    ax1 = fig.add_subplot(1, 2 if has_structure else 1, 1, projection="polar")
    az = np.append(d["azimuth"], d["azimuth"][0])
    # m* spans decades over the directions (it grows without bound where n nears the edge of
    # the range of G*): the radius is log10(m*), labelled in kg
    curves = [d["m_eff"]] + ([d["m_eff_flexible"]] if has_structure else [])
    finite = np.concatenate([c[np.isfinite(c)] for c in curves])
    lo, hi = np.floor(np.log10(finite.min())), np.ceil(np.log10(finite.max()))
    hi = max(hi, lo + 1)
    for g, name in enumerate(d["gain_classes"]):
        color = _CLASS_COLOR[g % len(_CLASS_COLOR)]
        eqs = ("", "") if d.get("predictor") == "model" else (" (eq 7)", " (eq 8)")
        ax1.plot(az, np.log10(np.append(d["m_eff"][g], d["m_eff"][g][0])), color=color, label=f"{name}, fixed{eqs[0]}")
        if has_structure:
            ax1.plot(az, np.log10(np.append(d["m_eff_flexible"][g], d["m_eff_flexible"][g][0])), color=color,
                     ls="--", label=f"{name}, flexible{eqs[1]}")
    ax1.set_rorigin(lo - 0.3 * (hi - lo))
    ax1.set_rlim(lo, hi)
    # a grid circle per decade; labels as powers of ten, on a diagonal ray (offset both ways from
    # their neighbours) and on every k-th decade only: the ray is about 60 points long, and
    # labels closer than about 20 points along it run into each other
    decades = np.arange(lo, hi + 0.5)
    label_every = max(1, int(np.ceil((hi - lo) / 2.5)))
    ax1.set_rticks(decades, [f"$10^{{{t:.0f}}}$" if round(t - lo) % label_every == 0 else "" for t in decades])
    ax1.set_rlabel_position(135.0)
    ax1.set_title("m* [kg, log radius] against the direction of n", fontsize=8.5)
    ax1.legend(loc="upper left", bbox_to_anchor=(-0.35, -0.05), fontsize=6.5, ncol=1)
    if has_structure:
        ax2 = fig.add_subplot(1, 2, 2, projection="polar")
        for g, name in enumerate(d["gain_classes"]):
            v = 1e3 * d["structure_peak"][g]
            ax2.plot(az, np.append(v, v[0]), color=_CLASS_COLOR[g % len(_CLASS_COLOR)], label=name)
        ax2.set_title("predicted peak base displacement [mm]", fontsize=8.5)
        ax2.set_rlabel_position(157.5)
        ax2.legend(loc="upper left", bbox_to_anchor=(0.85, -0.05), fontsize=6.5)
    q = np.degrees(d["q"])
    fig.suptitle(f"{title}q = ({q[0]:.0f}, {q[1]:.0f}, {q[2]:.0f}) deg (DH); azimuth from +x towards +y",
                 fontsize=8.5)
    return fig


def _setup(*, lambdas, model=None, rig=None, base=FLEXIBLE, speed=MAP_SPEED, structure=None):
    planner = build_planner(base=base, lambdas=lambdas, model=model, speed=speed, rig=rig, structure=structure)
    e = planner.restitution if planner.contact_restitution is None else planner.contact_restitution
    contact = ContactLaw(planner.contact_stiffness, planner.contact_exponent, e)
    kw = dict(lambdas=planner.lambdas, contact=contact, mass=planner.mass, speed=planner.speed,
              restitution=planner.restitution, beam=planner.beam, arm=planner.arm, model=model,
              pendulum=planner.pendulum, structure=planner.structure)
    return planner, kw


def workspace_figure(*, lambdas=None, model=None, rig=None, resolution: float = 0.05, base: str = FLEXIBLE,
                     y: float | None = None, structure: str | None = None) -> tuple[dict, dict[int, np.ndarray], str]:
    """The numbers of :func:`make_workspace`: the map (:func:`campaign.plan.maps.workspace_map`),
    the paper's configurations to mark and the summary line (the figure is drawn from the
    first two by :func:`draw_workspace`)."""
    grid_points(resolution)
    planner, kw = _setup(lambdas=lambdas, model=model, rig=rig, base=base, structure=structure)
    marks = paper_points(planner.robot)
    y = float(np.mean([p[1] for p in marks.values()])) if y is None else float(y)
    m = workspace_map(planner.robot, direction=impact_direction(), y=y, resolution=resolution, **kw)
    reach = int(np.count_nonzero(m["n_branches"]))
    return m, marks, (f"workspace map: {reach} of {m['n_branches'].size} points reachable in the plane "
                      f"y = {y:.4g} m, m* {np.nanmin(m['m_eff_best']):.3g}-{np.nanmax(m['m_eff_worst']):.3g} kg")


def make_workspace(png: str | os.PathLike, pdf: str | os.PathLike | None = None, *, lambdas=None, model=None,
                   rig=None, resolution: float = 0.05, base: str = FLEXIBLE, y: float | None = None,
                   structure: str | None = None) -> str:
    """Compute the workspace map (the paper's n and plane by default) with a response ``model`` or
    the gain classes' ``lambdas`` (:func:`campaign.plan.factory.planner_model`) and save it;
    returns a summary line. A grid over :data:`campaign.plan.grid.MAX_GRID_POINTS` is refused
    first (InputError)."""
    m, marks, line = workspace_figure(lambdas=lambdas, model=model, rig=rig, resolution=resolution, base=base, y=y,
                                      structure=structure)
    style.save(draw_workspace(m, marks=marks), png, pdf)
    return line


def directions_figure(*, lambdas=None, model=None, rig=None, config: int | None = 1, q=None, base: str = FLEXIBLE,
                      count: int = 72, structure: str | None = None) -> tuple[dict, str, str]:
    """The numbers of :func:`make_directions`: the map (:func:`campaign.plan.maps.direction_map`),
    the figure's title prefix and the summary line (the figure is :func:`draw_directions`)."""
    planner, kw = _setup(lambdas=lambdas, model=model, rig=rig, base=base, structure=structure)
    title = f"Configuration {config}: " if q is None else ""
    q = configuration_q(config) if q is None else np.asarray(q, dtype=float)
    d = direction_map(planner.robot, q, count=count, **kw)
    line = f"direction map: m* {np.min(d['m_eff']):.3g}-{np.max(d['m_eff']):.3g} kg (fixed base)"
    if "structure_peak" in d:        # the flexible base's panel: the structure's peak displacement
        peak = 1e3 * np.asarray(d["structure_peak"], dtype=float)
        where = structure or "the rig file's structure"
        line += f", structure peak {np.nanmin(peak):.3g}-{np.nanmax(peak):.3g} mm ({where})"
    return d, title, f"{line} over {count} directions"


def make_directions(png: str | os.PathLike, pdf: str | os.PathLike | None = None, *, lambdas=None, model=None,
                    rig=None, config: int | None = 1, q=None, base: str = FLEXIBLE, count: int = 72,
                    structure: str | None = None) -> str:
    """Compute the direction map at a paper configuration (or DH pose ``q`` [rad]) with a
    response ``model`` or the gain classes' ``lambdas`` and save it; returns a summary line."""
    d, title, line = directions_figure(lambdas=lambdas, model=model, rig=rig, config=config, q=q, base=base,
                                       count=count, structure=structure)
    style.save(draw_directions(d, title=title), png, pdf)
    return line
