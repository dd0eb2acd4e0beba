"""The impact planner's maps: m* and the structure's peak over the workspace and over the impact direction.

:func:`workspace_map` samples a vertical plane of the arm's base frame and keeps, per gain
class, the best and worst inverse-kinematics branch at each reachable point;
:func:`direction_map` sweeps the horizontal impact direction at one pose. Both predict with
:func:`campaign.plan.prediction.predict` (eq 7 on the fixed base; eq 8 and the structure's
peak on the flexible one); :mod:`campaign.report.figures.plan_maps` draws them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError
from ..model.robot import Robot
from ..model.robot.ik import position_branches_many
from .directions import horizontal_directions, unit_directions
from .grid import WORKSPACE_RANGE, grid_points
from .model_prediction import predict_model
from .prediction import pose_terms, predict

__all__ = ["workspace_map", "direction_map"]


def _quantities(robot, Q, n, *, model, names, lams, mass, speed, restitution, contact, beam, arm, pendulum,
                structure=None):
    """m* on the fixed base and, with ``beam``, on the flexible base with the structure's peak
    (N, G, D): from the response ``model`` when given, else eq 7/8 with ``lams``."""
    if model is not None:
        kw = dict(mass=mass, speed=speed, restitution=restitution, contact=contact, pendulum=pendulum)
        out = {"m_eff": predict_model(robot, Q, model, names, n, flexible=False, **kw).m_eff}
        if beam is not None:
            P = predict_model(robot, Q, model, names, n, flexible=True, structure=structure, **kw)
            out.update(m_eff_flexible=P.m_eff, structure_peak=P.structure_peak)
        return out
    out = {"m_eff": predict(pose_terms(robot, Q), lams, n, mass=mass, speed=speed, restitution=restitution,
                            contact=contact).m_eff}
    if beam is not None:
        P = predict(pose_terms(robot, Q, beam=beam), lams, n, mass=mass, speed=speed, restitution=restitution,
                    contact=contact, arm=arm, gain_names=names)
        out.update(m_eff_flexible=P.m_eff, structure_peak=P.structure_peak)
    return out


def workspace_map(robot: Robot, *, lambdas: Mapping[str, object], contact, mass: float, speed: float,
                  restitution: float, direction, y: float, x_range=WORKSPACE_RANGE, z_range=WORKSPACE_RANGE,
                  resolution: float = 0.05, beam=None, arm=None, model=None, pendulum: bool = True,
                  structure: str | None = None) -> dict:
    """m* (eq 7) and, on a flexible base, the structure's peak displacement over a vertical plane.

    The plane ``y = const`` of the arm's base frame is sampled every ``resolution`` metres;
    at each point every IK branch is evaluated, and the best (smallest) and worst branch of
    each quantity are kept per gain class. Unreachable points hold NaN (they are masked in
    the figures, never stored as numbers). ``arm``: the post-contact term of the structure's
    peak (:func:`campaign.plan.prediction.predict`). With a response ``model``
    (:func:`campaign.plan.model_prediction.predict_model`) the gain classes are the names of
    ``lambdas`` (gain sets) and its predictions replace eq 7/8.

    Returns
    -------
    dict
        ``x``, ``z`` [m] (grid axes), ``n_branches`` (nz, nx), ``gain_classes``; per quantity
        ``m_eff`` (fixed base, eq 7) and, with ``beam``, ``m_eff_flexible`` (eq 8) and
        ``structure_peak`` [m]: ``<q>_best`` and ``<q>_worst`` of shape (G, nz, nx).
    """
    grid_points(resolution, x_range, z_range)
    res = float(resolution)
    x = np.arange(x_range[0], x_range[1] + 0.5 * res, res)
    z = np.arange(z_range[0], z_range[1] + 0.5 * res, res)
    if x.size < 2 or z.size < 2:
        raise InputError(f"map range x {list(x_range)}, z {list(z_range)} m holds fewer than 2 points per axis")
    n = unit_directions(direction)
    names = list(lambdas)
    lams = [lambdas[k] for k in names]
    G = len(names)
    nb = np.zeros((z.size, x.size), dtype=int)
    owner, Q = [], []
    ZZ, XX = np.meshgrid(z, x, indexing="ij")
    points = np.stack([XX.ravel(), np.full(XX.size, float(y)), ZZ.ravel()], axis=1)
    for k, ik in enumerate(position_branches_many(robot, points)):
        iz, ix = divmod(k, x.size)
        nb[iz, ix] = ik.n_branches
        for q in ik.q:
            owner.append((iz, ix))
            Q.append(q)
    out = {"x": x, "z": z, "y": float(y), "n_branches": nb, "gain_classes": names, "direction": n[0],
           "predictor": "lambda" if model is None else "model"}
    if not Q:
        raise InputError(f"no point of the plane y = {y:g} m within x {list(x_range)}, z {list(z_range)} m "
                         "is reachable")
    Q = np.array(Q)
    owner = np.array(owner)
    quantities = {k: v[:, :, 0] for k, v in _quantities(
        robot, Q, n, model=model, names=names, lams=lams, mass=mass, speed=speed, restitution=restitution,
        contact=contact, beam=beam, arm=arm, pendulum=pendulum, structure=structure).items()}
    for name, vals in quantities.items():
        best = np.full((G, z.size, x.size), np.inf)
        worst = np.full((G, z.size, x.size), -np.inf)
        for g in range(G):
            np.minimum.at(best[g], (owner[:, 0], owner[:, 1]), vals[:, g])
            np.maximum.at(worst[g], (owner[:, 0], owner[:, 1]), vals[:, g])
        best[:, nb == 0] = np.nan
        worst[:, nb == 0] = np.nan
        out[f"{name}_best"], out[f"{name}_worst"] = best, worst
    return out


def direction_map(robot: Robot, q, *, lambdas: Mapping[str, object], contact, mass: float, speed: float,
                  restitution: float, count: int = 72, beam=None, arm=None, model=None, pendulum: bool = True,
                  structure: str | None = None) -> dict:
    """m* and the structure's peak displacement against the horizontal impact direction at a pose
    (``arm``: the post-contact term of the structure's peak, :func:`campaign.plan.prediction.predict`).

    Returns
    -------
    dict
        ``azimuth`` [rad] (from +x towards +y, ``count`` values), ``gain_classes``,
        ``m_eff`` (G, count) on the fixed base (eq 7); with ``beam`` also ``m_eff_flexible``
        (eq 8) and ``structure_peak`` [m].
    """
    q = np.asarray(q, dtype=float)
    n = horizontal_directions(count, start_deg=0.0)
    names = list(lambdas)
    lams = [lambdas[k] for k in names]
    out = {"azimuth": np.arctan2(n[:, 1], n[:, 0]) % (2 * np.pi), "gain_classes": names, "q": q,
           "predictor": "lambda" if model is None else "model"}
    out.update({k: v[0] for k, v in _quantities(
        robot, q[None], n, model=model, names=names, lams=lams, mass=mass, speed=speed, restitution=restitution,
        contact=contact, beam=beam, arm=arm, pendulum=pendulum, structure=structure).items()})
    return out
