"""The planner's linearisation against the arm's full nonlinear dynamics, on the rig's worst cell.

The planner's structure term (``campaign.plan.post_contact``) is linear about the struck pose, so
its peaks are even in the impact direction n, while on the rig candidates that differ only by
the sign of n measure apart. This script integrates a nonlinear twin of exactly the planner's
system: the same arm on the same free base (Pinocchio's free-flyer model, ABA), the structure's
stiffness and damping on the base's displacement from its start, the servo's proportional and
derivative gains plus the joints' viscous friction, gravity with the pre-impact holding torques,
and the same contact pulse (eq 14's impulse, the contact law's duration and shape) as a force
along n at the impact frame. No Coulomb friction, as in the planner. The twin's peaks are set
beside the rig's and the planner's for configuration 1's point, the space-class structure and
the heavier object, with the rig as calibrated and with its Coulomb friction and gravity off.

Usage::

    python benchmarks/plan_nonlinear_twin.py                               # print the table
    python benchmarks/plan_nonlinear_twin.py --readme benchmarks/README.md # and record it
"""

from __future__ import annotations

import argparse
import datetime
import platform
import sys
from pathlib import Path

import numpy as np

HEADING = "## Impact planner's linearisation against the nonlinear arm"
#: rig settings compared: as calibrated, and without the Coulomb friction the twin lacks and gravity
SETTINGS = (("as calibrated", {}), ("Coulomb friction and gravity off", {"arm.coulomb_scale": 0.0, "gravity": 0.0}))


def twin_peak(planner, i: int, g: int, d: int, *, dt: float = 2e-4) -> float:
    """Peak norm of the base translation over one first-mode period [m] for the fitted
    ``planner``'s candidate (pose ``i``, gain class ``g``, direction ``d``), with the arm's full
    nonlinear dynamics (classical RK4 on the configuration manifold, step ``dt`` [s])."""
    import pinocchio as pin

    from campaign.model.robot.floating import attach_to_floating_base
    from campaign.rig.contact import Contact, pulse_shape

    P = planner.predictions_
    frobot = attach_to_floating_base(planner.robot, planner.beam.base_body())
    model = frobot.model
    model.gravity.linear = np.array([0.0, 0.0, -float(planner.arm.gravity)])
    data, fid = model.createData(), frobot.impact_frame_id
    K, B = np.asarray(planner.beam.stiffness), np.asarray(planner.beam.damping)
    kp, damping, _ = planner.arm.matrices(planner.gain_classes_, planner.robot.nv)
    kp, damping = kp[g], damping[g]
    c = Contact(planner.contact_stiffness, planner.contact_exponent, planner.restitution)
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
        from campaign.core.errors import SimulationError
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


def compare(speed: float, head_mass: float, *, n_dirs: int = 4, dt: float = 2e-4) -> tuple[list[str], list[dict]]:
    """The table's rows and their numbers: per rig setting, Spearman of the planner and of the twin
    against the rig, the largest +-n difference of each, how many of the rig's +-n pairs (over 1 %
    apart) the twin has larger on the same side, and the twin over the planner."""
    import plan_rig_check as prc

    from campaign.model.paper import load_paper
    from campaign.plan.factory import build_planner
    from campaign.plan.directions import horizontal_directions

    table3 = {k: [float(v) for v in lam] for k, lam in load_paper()["table3"].items()}
    name = "config 1 wrist centre"
    point = prc.contact_points()[name]
    directions = horizontal_directions(n_dirs)
    lines = ["| rig | candidates | Spearman: planner | Spearman: nonlinear twin | largest +-n difference: rig | "
             "planner | twin | +-n pairs over 1 % apart on the rig: twin larger on the same side | twin / planner |",
             "|---|---|---|---|---|---|---|---|---|"]
    stats = []
    for setting, over in SETTINGS:
        params = {"pendulum.head_mass": head_mass, **over}
        row = prc.check_point(name, point, directions=directions, speed=speed, params=params,
                              bases=(("flexible", "space_class"),))[0]
        planner = build_planner(base="flexible", lambdas=table3, speed=speed, mass=prc.hammer_mass(params),
                                objective="displacement", structure="space_class", params=params)
        planner.fit(point, directions)
        names = planner.gain_classes_
        meas, pred, twin = {}, {}, {}
        for cand in row["cands"]:
            key = (cand["branch"], cand["gain"], cand["d"])
            g = names.index(cand["gain"]) if cand["gain"] in names else names.index(prc.GAIN_CLASS[cand["gain"]])
            meas[key], pred[key] = cand["measured"], cand["predicted"]
            twin[key] = twin_peak(planner, cand["branch"] - 1, g, cand["d"], dt=dt)
        keys = sorted(meas)
        m = np.array([meas[k] for k in keys])
        ratio = np.array([twin[k] / pred[k] for k in keys])
        a = prc.rank_scores([pred[k] for k in keys], m)
        b = prc.rank_scores([twin[k] for k in keys], m)
        agree, pairs = same_side(meas, twin, n_dirs)
        stats.append({"planner": a["spearman"], "twin": b["spearman"], "agree": agree, "pairs": pairs})
        lines.append(f"| {setting} | {len(keys)} | {a['spearman']:.2f} | {b['spearman']:.2f} | "
                     f"{100 * pair_difference(meas, n_dirs):.1f} % | {100 * pair_difference(pred, n_dirs):.1f} % | "
                     f"{100 * pair_difference(twin, n_dirs):.1f} % | {agree} of {pairs} | "
                     f"{ratio.min():.2f}-{ratio.max():.2f} |")
    return lines, stats


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--speed", type=float, default=2.0, help="impact speed [m/s] (default 2.0)")
    parser.add_argument("--head-mass", type=float, default=5.0, help="pendulum head mass [kg] (default 5)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    if not (np.isfinite(args.speed) and args.speed > 0):
        parser.exit(2, f"--speed = {args.speed!r} must be > 0\n")
    if not (np.isfinite(args.head_mass) and args.head_mass > 0):
        parser.exit(2, f"--head-mass = {args.head_mass!r} must be > 0\n")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import plan_rig_check as prc

    from campaign import __version__

    m_b = prc.hammer_mass({"pendulum.head_mass": args.head_mass})
    table, stats = compare(args.speed, args.head_mass)
    agree, pairs = sum(x["agree"] for x in stats), sum(x["pairs"] for x in stats)
    better = [x for x in stats if x["twin"] > x["planner"]]
    body = "\n".join([
        f"Configuration 1's point, the space-class structure, m_b = {m_b:.3g} kg at {args.speed:g} m/s, every "
        "branch x gain set x 4 horizontal directions (the rig check's cell where the planner's Spearman is "
        "lowest): the rig, the planner (linear about the struck pose, `campaign.plan.post_contact`) and a nonlinear "
        "twin of the planner's system (the same arm on the same free base with Pinocchio's full nonlinear "
        "dynamics, the same structure, servo PD, viscous friction, gravity and contact pulse; no Coulomb "
        "friction, as in the planner). `largest +-n difference`: between two candidates that differ only by "
        "the sign of n.",
        "",
        *table,
        "",
        f"The twin has the larger peak on the rig's side in {agree} of the {pairs} +-n pairs that differ by over "
        "1 % on the rig, where the planner predicts every pair equal: the differences come from the arm's "
        "nonlinear dynamics over its post-impact excursion. "
        + ("It ranks the candidates no better than the planner in any setting: its other differences from the "
           "rig (the contact given as the planner's pulse, not coupled to the hammer; no Coulomb friction, "
           "which on the rig shrinks the +-n differences) weigh as much, so modelling the sign alone does not "
           "lift the ranking." if not better else
           f"It ranks the candidates better than the planner in {len(better)} of the {len(stats)} settings."),
        "",
        f"Python {platform.python_version()}, numpy {np.__version__}, campaign {__version__}; "
        f"{datetime.date.today().isoformat()}. Record: `.venv/bin/python benchmarks/plan_nonlinear_twin.py "
        "--readme benchmarks/README.md`.",
    ])
    print(body)
    if args.readme is not None:
        from campaign.bench import write_section
        write_section(args.readme, HEADING, body)
        print(f"\nwrote the section '{HEADING}' of {args.readme}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
