"""The planner's linearisation against the arm's full nonlinear dynamics, on the rig check's worst cell.

The planner's structure term (:mod:`campaign.plan.post_contact`) is linear about the struck
pose, so its peaks are even in the impact direction n, while on the rig candidates that
differ only by the sign of n measure apart. The nonlinear twin integrates exactly the
planner's system with the arm's full dynamics: the same arm on the same free base
(Pinocchio's free-flyer model, ABA), the structure's stiffness and damping on the base's
displacement from its start, the servo's proportional and derivative gains plus the joints'
viscous friction, gravity with the pre-impact holding torques, and the same contact pulse
(eq 14's impulse, the contact law's duration and shape) as a force along n at the impact
frame; no Coulomb friction, as in the planner. Its peaks are set beside the rig's and the
planner's for configuration 1's point, the space-class structure and the heavier object,
with the rig as calibrated and with its Coulomb friction and gravity off (``twin.csv``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from ..core.errors import SimulationError
from ..core.vocabulary import FLEXIBLE, HIGH, SPACE_CLASS, ZERO
from ..model.paper import load_paper
from ..model.robot.floating import attach_to_floating_base
from ..plan.directions import horizontal_directions
from ..plan.factory import build_planner
from ..rig.contact import ContactLaw, pulse_shape
from . import plan_rig_check as prc
from .common import Log, quiet, write_csv

__all__ = ["SETTINGS", "twin_peak", "pair_difference", "same_side", "compare", "run"]

#: rig settings compared: as calibrated, and without the Coulomb friction the twin lacks and gravity
SETTINGS = (("as calibrated", {}), ("Coulomb friction and gravity off", {"arm.coulomb_scale": 0.0, "gravity": 0.0}))
COLUMNS = ("rig", "candidates", "spearman_planner", "spearman_twin", "largest_pm_n_difference_rig",
           "largest_pm_n_difference_planner", "largest_pm_n_difference_twin", "pairs_over_1pct", "twin_same_side",
           "twin_over_planner_min", "twin_over_planner_max")


def twin_peak(planner, i: int, g: int, d: int, *, dt: float = 2e-4) -> float:
    """Peak norm of the base translation over one first-mode period [m] for the fitted
    ``planner``'s candidate (pose ``i``, gain class ``g``, direction ``d``), with the arm's full
    nonlinear dynamics (classical RK4 on the configuration manifold, step ``dt`` [s])."""
    P = planner.predictions_
    frobot = attach_to_floating_base(planner.robot, planner.beam.base_body())
    model = frobot.model
    model.gravity.linear = np.array([0.0, 0.0, -float(planner.arm.gravity)])
    data, fid = model.createData(), frobot.impact_frame_id
    K, B = np.asarray(planner.beam.stiffness), np.asarray(planner.beam.damping)
    kp, damping, _ = planner.arm.matrices(planner.gain_classes_, planner.robot.nv)
    kp, damping = kp[g], damping[g]
    c = ContactLaw(planner.contact_stiffness, planner.contact_exponent, planner.restitution)
    _, shape = pulse_shape(c.damping, float(c.exponent))
    s = np.linspace(0.0, 1.0, shape.size)
    # the pulse carries eq 14's impulse exactly (as the planner's first-order hold does)
    T, n = float(P.contact_duration[i, g, d]), planner.directions_[d]
    scale = float(P.impulse[i, g, d]) / (T * float(np.sum(0.5 * (shape[1:] + shape[:-1]) * np.diff(s))))
    q0 = frobot.q_full(planner.q_[i])
    hold = np.array(pin.computeGeneralizedGravity(model, data, q0))   # the pre-impact equilibrium

    def acceleration(q, v, t):
        dx = pin.difference(model, q0, q)                  # base [u; theta], then the joints
        tau = hold.copy()
        tau[:6] -= K @ dx[:6] + B @ v[:6]
        tau[6:] -= kp * dx[6:] + damping * v[6:]
        if t < T:
            J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
            tau += J.T @ (n * scale * float(np.interp(t / T, s, shape)))
        return np.array(pin.aba(model, data, q, v, tau))

    q, v, peak = q0.copy(), np.zeros(model.nv), 0.0
    period = 1.0 / float(planner.frequency_[i, 0])
    for k in range(int(np.ceil(period / dt))):
        t = k * dt
        a1 = acceleration(q, v, t)
        v2 = v + 0.5 * dt * a1
        a2 = acceleration(pin.integrate(model, q, 0.5 * dt * v), v2, t + 0.5 * dt)
        v3 = v + 0.5 * dt * a2
        a3 = acceleration(pin.integrate(model, q, 0.5 * dt * v2), v3, t + 0.5 * dt)
        v4 = v + dt * a3
        a4 = acceleration(pin.integrate(model, q, dt * v3), v4, t + dt)
        q = pin.integrate(model, q, dt / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4))
        v = v + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        peak = max(peak, float(np.linalg.norm(q[:3] - q0[:3])))
    if not np.isfinite(peak):
        raise SimulationError(f"nonlinear twin diverged at pose {i}, gain class {g}, direction {d}")
    return peak


def pair_difference(values: dict, n_dirs: int) -> float:
    """Largest relative difference between two values whose keys ``(branch, gain, d)`` differ
    only by the sign of n (direction ``d`` and ``d + n_dirs / 2``)."""
    out = [abs(v / values[(b, gn, d + n_dirs // 2)] - 1) for (b, gn, d), v in values.items()
           if d < n_dirs // 2 and (b, gn, d + n_dirs // 2) in values]
    return max(out, default=float("nan"))


def same_side(rig: dict, model: dict, n_dirs: int, *, floor: float = 0.01) -> tuple[int, int]:
    """Of the +-n pairs whose rig values differ by more than ``floor`` (relative), how many the
    ``model`` has larger on the same side: (agreeing, pairs)."""
    agree = total = 0
    for (b, gn, d), v in rig.items():
        other = (b, gn, d + n_dirs // 2)
        if d < n_dirs // 2 and other in rig and abs(v / rig[other] - 1) > floor:
            total += 1
            agree += (v > rig[other]) == (model[(b, gn, d)] > model[other])
    return agree, total


def _values(row: dict, planner, *, dt: float) -> tuple[dict, dict, dict]:
    """{(branch, gain, direction): value} of the rig, the planner and the twin for a rig-check row."""
    names = planner.gain_classes_
    meas, pred, twin = {}, {}, {}
    for cand in row["cands"]:
        key = (cand["branch"], cand["gain"], cand["d"])
        g = names.index(cand["gain"]) if cand["gain"] in names else names.index(prc.GAIN_CLASS[cand["gain"]])
        meas[key], pred[key] = cand["measured"], cand["predicted"]
        twin[key] = twin_peak(planner, cand["branch"] - 1, g, cand["d"], dt=dt)
    return meas, pred, twin


def compare(speed: float, head_mass: float, *, n_dirs: int = 4, gains=tuple(prc.GAIN_CLASS), dt: float = 2e-4,
            log: Log = quiet) -> list[dict]:
    """Per rig setting: Spearman of the planner and of the twin against the rig, the largest +-n
    difference of each, how many of the rig's +-n pairs (over 1 % apart) the twin has larger on
    the same side, and the twin over the planner."""
    table3 = {k: [float(v) for v in lam] for k, lam in load_paper()["table3"].items()}
    name = "config 1 wrist centre"
    point = prc.contact_points()[name]
    directions = horizontal_directions(n_dirs)
    rows = []
    for setting, over in SETTINGS:
        params = {"pendulum.head_mass": head_mass, **over}
        row = prc.check_point(name, point, directions=directions, speed=speed, params=params, gains=gains,
                              bases=((FLEXIBLE, SPACE_CLASS),))[0]
        planner = build_planner(base=FLEXIBLE, lambdas=table3, speed=speed, mass=prc.hammer_mass(params),
                                objective="displacement", structure=SPACE_CLASS, params=params)
        planner.fit(point, directions)
        meas, pred, twin = _values(row, planner, dt=dt)
        keys = sorted(meas)
        m = np.array([meas[k] for k in keys])
        ratio = np.array([twin[k] / pred[k] for k in keys])
        agree, pairs = same_side(meas, twin, n_dirs)
        rows.append({"rig": setting, "candidates": len(keys),
                     "spearman_planner": prc.rank_scores([pred[k] for k in keys], m)["spearman"],
                     "spearman_twin": prc.rank_scores([twin[k] for k in keys], m)["spearman"],
                     "largest_pm_n_difference_rig": pair_difference(meas, n_dirs),
                     "largest_pm_n_difference_planner": pair_difference(pred, n_dirs),
                     "largest_pm_n_difference_twin": pair_difference(twin, n_dirs), "pairs_over_1pct": pairs,
                     "twin_same_side": agree, "twin_over_planner_min": ratio.min(), "twin_over_planner_max": ratio.max()})
        log(f"{setting}: Spearman planner {rows[-1]['spearman_planner']:.2f}, twin {rows[-1]['spearman_twin']:.2f}; "
            f"twin on the rig's side in {agree} of {pairs} pairs")
    return rows


def run(out_dir, *, quick: bool = False, log: Log = quiet) -> list[str]:
    """Run the study (2.0 m/s, head mass 5 kg, 4 directions; ``quick``: 2 directions, gain
    sets zero and high, a coarser twin step) and write ``twin.csv`` into ``out_dir``."""
    kw = dict(n_dirs=2, gains=(ZERO, HIGH), dt=5e-4) if quick else {}
    rows = compare(2.0, 5.0, log=log, **kw)
    return [write_csv(Path(out_dir) / "twin.csv", rows, COLUMNS)]
