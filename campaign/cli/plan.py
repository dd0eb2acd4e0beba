"""``campaign plan``: every pose, gain class and direction to meet an object at a point, ranked.

Examples
--------
::

    campaign plan --point -0.6,-0.15,-0.15 --speed 2
    campaign plan --point -0.6,-0.15,-0.15 --horizontal 12 --base flexible --objective displacement
    campaign plan --point -0.6,-0.15,-0.15 --horizontal 8 --base flexible --structure stiff_mast
    campaign plan --point 0.5,0.3,0.2 --cone -1,0,0,30 --count 9 --fit results/full/fit/lambda_high.json --json
    campaign plan --point -0.6,-0.15,-0.15 --lambda zero_low=19.82,4.62,0.80 --lambda high=53.18,8.66,2.83
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from ..core.errors import InputError, SimulationError
from ..core.vocabulary import FIXED, FLEXIBLE, bases
from ..joints.modelfile import shipped_model_path
from ..joints.setting import display_path
from ..model.conventions import angle_count
from ..model.paper import impact_direction
from ..plan.directions import cone_directions, horizontal_directions, unit_directions
from ..plan.factory import build_planner, check_model_domain, planner_model
from ..plan.prediction import check_object
from ..scene.description import load_structures, rig_values
from .args import parse_named_lambdas, parse_vector
from .commands import HELP

__all__ = ["register", "run"]


DESCRIPTION = """\
Impact planner (paper, section 2: select configurations that reduce the impact). For a
contact point, finds every pose of the arm's positioning chain that puts the impact point
(the wrist centre) there within the joint limits (all inverse-kinematics branches, with
Pinocchio's kinematics), and predicts for each pose x gain set x impact direction n: m* as
eq 10 measures it, the impulse (eq 14), the post-impact joint velocities, the contact's
duration and peak force from the rig's contact law, and on the flexible base the base
momentum and the structure's peak base displacement. By default the predictions are the
shipped response model's (config/response_model.json, fitted by the designed campaign): the
arm's response to the contact law's pulse with the servo's gains, the joints' fitted damping
and Coulomb friction and, on the flexible base, the named structure through the VES-II loop.
With --lambda or --fit they are eq 7 (fixed) or eq 8 (flexible) with the given Virtual Rotor
Inertia per gain class. The candidates are ranked by --objective (smallest first).

Units: point in metres in the arm's base frame (DH frame 0); n is the direction of the
force on the arm (the object moves along n), normalised; object mass in kg, speed in m/s;
lambda in kg m^2; angles printed in degrees (DH).
"""

EPILOG = """\
predictions: --model FILE names another saved response model; --fit reads a lambda fit of a
campaign (results/<campaign>/fit/lambda_<class>.json, keys gain_class, lambda); --lambda
NAME=L1,L2,L3 names one directly (the paper's Table 3: zero_low=19.82,4.62,0.80 and
high=53.18,8.66,2.83). --fit and --lambda may repeat and replace the model. A model plans the
paper's gain sets zero, low and high (its eq 14 restitution the fitted trials' mean unless
--restitution is given; the object the rig's pendulum hammer unless --mass is given). A
model plans only inside its domain (the model file's "domain": the speeds, object masses,
directions, gain sets and structures it was fitted on; horizontal directions on this rig):
a --speed, --mass, direction or --structure outside it is refused with one line naming the
bound and the value, unless --extrapolate is given (then a warning on stderr).

contact and structure: the contact law F = k delta^p (1 + d ddelta/v0) with k, p from
config/rig.yaml (contact.stiffness, contact.exponent) and d solved for its restitution; its
pulse (shape and duration) is that of two free bodies of reduced mass m* m_b / (m* + m_b).
On the fixed base the peak force takes the arm's apparent mass over the compression instead
of m*: the force peaks about a quarter into the contact, before the servo's proportional and
derivative gains (the paper's Table 1 gains in joint units, controller.torque_per_unit of
config/rig.yaml) and the joints' damping have built up the resistance m* sums over the whole
contact. The flexible base is the rig's cantilever (flexible.* of config/rig.yaml). With a
model its peak displacement (x_b) is the structure's over one period of its first mode,
driven by the arm's response to the pulse: every candidate is ranked with the arm ideally
coupled to the structure, and the best 64 are predicted again through the VES-II loop as the
rig emulates it (--json: each candidate's coupling); --structure NAME plans on a named
structure of the rig file (its structures: section; with --base flexible);
with lambdas, that of the linearised arm on the structure pushed by eq 14's impulse spread
over the contact's pulse under the servo, the joints' viscous friction and gravity, and
--json also gives structure_peak_release (the structure's modes released with eq 8's base
velocity change alone); the paper's pooled class zero_low is planned as its gain sets zero
and low (same lambda, different servo). --json also gives contact_duration and
compression_mass (fixed base).

output: the best --top candidates (all with --top 0); --json prints every candidate.

exit status: 0 on success, 2 on bad input (one line on stderr naming the value), e.g. an
unreachable point, a zero direction, a negative mass, a model file that is corrupted or
fitted for another robot or rig file.
"""


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``plan`` subcommand to the ``campaign`` command's subparsers."""
    p = subparsers.add_parser("plan", help=HELP["plan"], description=DESCRIPTION, epilog=EPILOG,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--point", metavar="X,Y,Z", required=True, help="contact point in the arm's base frame [m]")
    dirs = p.add_mutually_exclusive_group()
    dirs.add_argument("--direction", metavar="X,Y,Z",
                      help="one impact direction n (default: the paper's n = -1,0,0 of config/paper.yaml)")
    dirs.add_argument("--horizontal", metavar="N", type=int,
                      help="N horizontal directions evenly spaced over 360 deg, starting at -x")
    dirs.add_argument("--cone", metavar="X,Y,Z,DEG",
                      help="the axis X,Y,Z and --count - 1 directions on the cone of half-angle DEG around it")
    p.add_argument("--count", type=int, default=None, help="directions of --cone, axis included (default 9)")
    p.add_argument("--mass", type=float, default=None,
                   help="object mass m_b [kg] (default: the rig hammer's effective mass, config/rig.yaml)")
    p.add_argument("--speed", type=float, default=2.0, help="object speed along n [m/s] (default 2.0)")
    p.add_argument("--restitution", type=float, default=None,
                   help="restitution e (default: contact.restitution of config/rig.yaml)")
    p.add_argument("--base", choices=bases(), default=FIXED,
                   help="fixed: ground-fixed arm (eq 7); flexible: on the rig's cantilever (eq 8)")
    p.add_argument("--structure", metavar="NAME", default=None,
                   help="a named structure of the rig file (with --base flexible; default the file's own)")
    p.add_argument("--extrapolate", action="store_true",
                   help="plan with the model outside its domain (speed, mass, directions): a warning instead of "
                        "a refusal")
    p.add_argument("--model", metavar="FILE", default=None,
                   help="a saved response model (default: the shipped config/response_model.json)")
    p.add_argument("--fit", action="append", metavar="JSON", default=[],
                   help="a campaign lambda fit (JSON with gain_class and lambda); repeatable")
    p.add_argument("--lambda", dest="lambdas", action="append", metavar="NAME=L1,L2,L3", default=[],
                   help="a gain class and its diagonal lambda [kg m^2]; repeatable")
    p.add_argument("--objective", choices=("impulse", "force", "displacement", "weighted"), default="impulse",
                   help="what the ranking minimises (displacement needs --base flexible; default impulse)")
    p.add_argument("--weights", metavar="WI,WF,WD", default=None,
                   help="weights of impulse, peak force, displacement in the weighted objective, each over "
                        "its largest candidate value (with --objective weighted only; default 1,1,1)")
    p.add_argument("--top", type=int, default=20, help="candidates printed (0: all; default 20)")
    p.add_argument("--rig", metavar="YAML", default=None, help="rig parameter file (default config/rig.yaml)")
    p.add_argument("--json", action="store_true", help="print one JSON object with every candidate")
    p.set_defaults(func=run)
    return p


#: the most impact directions one plan ranks: 3600 (0.1 deg apart on a fan) take about 2 s and
#: 200 MB; time and memory grow with the count (36 000: half a minute and 0.5 GB)
MAX_DIRECTIONS = 3600


def _direction_count(count: int, option: str) -> int:
    if count < 1:
        raise InputError(f"{option} {count}: need at least 1 direction")
    if count > MAX_DIRECTIONS:
        raise InputError(f"{option} {count}: at most {MAX_DIRECTIONS} directions (0.1 deg apart on a full "
                         "fan); the planner's time and memory grow with each")
    return count


def _directions(args):
    if args.count is not None and args.cone is None:
        raise InputError(f"--count {args.count}: counts the directions of --cone; give --cone X,Y,Z,DEG too")
    if args.horizontal is not None:
        return horizontal_directions(_direction_count(args.horizontal, "--horizontal"))
    if args.cone is not None:
        v = parse_vector(args.cone, option="--cone", size=4)
        count = _direction_count(9 if args.count is None else args.count, "--count")
        if not any(v[:3]):
            raise InputError(f"--cone {args.cone}: the zero vector has no direction")
        return cone_directions(v[:3], v[3], count)
    if args.direction is not None:
        n = np.asarray(parse_vector(args.direction, option="--direction", size=3))
        if not np.any(n):
            raise InputError(f"--direction {args.direction}: the zero vector has no direction")
        return unit_directions(n)
    return impact_direction()[None]


def check_structure(args) -> None:
    """--structure names one of the rig file's structures, on the flexible base."""
    if args.structure is None:
        return
    if args.base != FLEXIBLE:
        raise InputError(f"--structure {args.structure}: names the flexible base's structure; give --base flexible too")
    known = load_structures(args.rig)
    if args.structure not in known:
        raise InputError(f"--structure {args.structure}: not a structure of the rig file; it names {', '.join(sorted(known))}")


def structure_name(args) -> str | None:
    """The flexible base's structure (--structure, or the rig file's own); None on the fixed base."""
    if args.base != FLEXIBLE:
        return None
    return args.structure or str(rig_values(rig=args.rig)["flexible.structure"])


def _model_file(args) -> str:
    return args.model if args.model is not None else display_path(shipped_model_path())


def _predictor(args, model, planner) -> dict:
    """What the candidates were predicted with, for the JSON output."""
    if model is None:
        return {"lambdas": planner.lambdas}
    return {"model": {"file": _model_file(args), "kind": model.kind}, "gain_sets": list(planner.lambdas)}


def _fmt(v, spec=".1f"):
    # + 0.0 turns a negative zero into zero, so "-0.0" is never printed
    return "[" + ", ".join(format(float(x) + 0.0, spec) for x in v) + "]"


def run(args) -> int:
    """Entry point of ``campaign plan`` (see ``campaign plan --help``)."""
    point = parse_vector(args.point, option="--point", size=3, units="m")
    dirs = _directions(args)
    if args.mass is not None and not (math.isfinite(args.mass) and args.mass > 0):
        raise InputError(f"--mass {args.mass:g}: the object mass must be > 0 kg")
    if args.top < 0:
        raise InputError(f"--top {args.top}: must be >= 0")
    if args.weights is not None and args.objective != "weighted":
        raise InputError(f"--weights {args.weights}: weigh the weighted objective only; give --objective weighted "
                         f"too (the ranking is by {args.objective})")
    weights = parse_vector("1,1,1" if args.weights is None else args.weights, option="--weights", size=3)
    if args.objective == "displacement" and args.base != FLEXIBLE:
        raise InputError("--objective displacement needs --base flexible (a fixed base has no structure)")
    check_structure(args)
    nv = angle_count(rig_values(rig=args.rig)["robot"])     # joints of the planner's robot
    model, lambdas = planner_model(model=args.model, fits=args.fit, named=parse_named_lambdas(args.lambdas, nv=nv),
                                   rig=args.rig, nv=nv)
    if model is None and args.extrapolate:
        raise InputError("--extrapolate goes with a response model (the default, or --model); eq 7/8 with lambdas "
                         "has no domain")
    planner = build_planner(base=args.base, lambdas=lambdas, model=model, mass=args.mass, speed=args.speed,
                            restitution=args.restitution, objective=args.objective, weights=weights, rig=args.rig,
                            structure=args.structure)
    check_object(mass=planner.mass, speed=planner.speed, restitution=planner.restitution)
    if model is not None:
        outside = check_model_domain(model, base=args.base, speed=args.speed, mass=args.mass, directions=dirs,
                                     structure=args.structure, rig=args.rig, extrapolate=args.extrapolate,
                                     hint=" (--extrapolate plans anyway, with a warning)")
        if outside:
            print("campaign plan: warning: extrapolating outside the model's domain: "
                  + "; ".join(x.message for x in outside) + "; its predictions there are unchecked", file=sys.stderr)
    try:
        planner.fit(point, dirs)
    except SimulationError as exc:       # the contact model has no answer for this object: name it
        raise InputError(f"--mass {planner.mass:g} kg at --speed {planner.speed:g} m/s: the planner's contact "
                         f"model cannot predict this impact ({exc})") from None
    rows = planner.rows()
    if args.json:
        print(json.dumps({
            "point": point, "base": args.base, "structure": structure_name(args), "objective": args.objective,
            "weights": weights,
            "object_mass": planner.mass, "speed": planner.speed, "restitution": planner.restitution,
            **_predictor(args, model, planner), "branches_dh_deg": np.degrees(planner.q_).tolist(),
            "structure_frequency_hz": None if planner.frequency_ is None else planner.frequency_.tolist(),
            "units": {"m_eff": "kg", "impulse": "N s", "peak_force": "N", "tip_velocity": "m/s", "dq": "rad/s",
                      "base_velocity": "m/s, rad/s", "base_momentum": "N s", "structure_peak": "m",
                      "structure_peak_release": "m",
                      "q_dh_deg": "deg"},
            "candidates": rows,
        }))
        return 0
    flex = args.base == FLEXIBLE
    how = f"(eq {'8' if flex else '7'})" if model is None else "(response model)"
    where = f" ({structure_name(args)})" if flex else ""
    print(f"point      = {_fmt(point, '.4g')} m, base {args.base}{where} {how}")
    print(f"object     = {planner.mass:.4g} kg at {planner.speed:.4g} m/s, e = {planner.restitution:.4g}")
    if model is not None:
        print(f"model      = {model.kind}, {_model_file(args)}; gain sets {', '.join(planner.lambdas)}")
    else:
        print("gains      = " + "; ".join(f"{k} lambda {_fmt(v, 'g')} kg m^2" for k, v in planner.lambdas.items()))
    print(f"branches   = {len(planner.q_)} poses reach the point (DH deg):")
    for i, q in enumerate(planner.q_, start=1):
        print(f"  {i}: {_fmt(np.degrees(q))}")
    shown = rows if args.top == 0 else rows[:args.top]
    print(f"candidates = {len(rows)} (pose x gain x direction), best {len(shown)} by {args.objective}:")
    head = f"{'rank':>4} {'br':>2} {'gain':>9} {'az':>6} {'el':>5} {'m* kg':>8} {'I N s':>7} {'F N':>6} {'|dq| r/s':>8}"
    if flex:
        head += f" {'p_b N s':>7} {'x_b mm':>7}"
    print(head)
    print("-" * len(head))
    for r in shown:
        n = np.asarray(r["direction"])
        az = float(np.round(np.degrees(np.arctan2(n[1], n[0])), 6)) + 0.0
        el = float(np.round(np.degrees(np.arcsin(np.clip(n[2], -1, 1))), 6)) + 0.0
        m = "inf" if r["m_eff"] is None else f"{r['m_eff']:.3f}"
        line = (f"{r['rank']:>4} {r['branch']:>2} {r['gain_class'][:9]:>9} {az:6.1f} {el:5.1f} {m:>8} "
                f"{r['impulse']:7.4f} {r['peak_force']:6.2f} {np.linalg.norm(r['dq']):8.4f}")
        if flex:
            line += f" {r['base_momentum']:7.4f} {1e3 * r['structure_peak']:7.4f}"
        print(line)
    return 0
