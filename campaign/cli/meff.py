"""``campaign meff``: the effective mass of the arm's tip along an impact direction (eq 11).

Evaluates the Ex-IIT of the PUMA 560, or of another robot (``--robot``), (eq 7 on a fixed
base, eq 8 on a flexible base) at one configuration, or reproduces the m1, m2 and m3
columns of the paper's Table 2 next to the published values. Everything the command needs
is read from ``config/`` and the robot's drive file: the paper's impact direction and
Table 3 lambda from ``paper.yaml``, the robot's configurations and angle convention from
its drive file, the flexible base body from ``rig.yaml``.

Examples
--------
::

    campaign meff --config 1
    campaign meff --q 0,150,90 --lambda 19.82,4.62,0.80 --json
    campaign meff --robot planar2 --config 2
    campaign meff --config 2 --base flexible
    campaign meff --table
    campaign meff --config 2 --model --gain high --speed 2.5 --base flexible
"""

from __future__ import annotations

import argparse
import json
import math
import re

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, FLEXIBLE, bases, gain_sets
from ..model.conventions import configurations
from ..model.exiit import unit_direction
from ..model.paper import impact_direction, load_paper
from ..model.robot import load_robot
from ..model.table2 import table2_column_classes, table2_rows
from ..rig.base_mass import mass_on_base
from .args import parse_vector
from .commands import HELP
from .meff_model import check_model_options, run_model

__all__ = ["register", "run", "format_table2"]


DESCRIPTION = """\
Effective mass m* = 1 / (n^T G*_33 n) of the robot's impact point (the PUMA 560's: the
wrist centre) along the impact direction n (paper, eq 11), with G* from eq 7 (fixed base)
or eq 8 (flexible base), or the paper's Table 2 reproduced with --table.

Units: joint angles in degrees, one per joint, in the robot's own convention (the PUMA
560's: the paper's, Table 1), mapped to the model's angles as q = angle + angle_offset_deg
of the robot's drive file (the PUMA 560's: 0, 0, -90 deg to its DH angles); Virtual Rotor
Inertia lambda in kg m^2 (diagonal, one value per joint); the direction n is
dimensionless and normalised; m* in kg. Joint limits are inclusive (the PUMA 560's
configuration 3 sits exactly on joint 3's +45 deg DH limit).

Give comma-separated values without spaces. Values starting with '-' work as they are
(--direction -1,0,0), or write them as --q=-10,150,90.
"""

EPILOG = """\
flexible base: the arm stands on a free rigid body (eq 8; in the impulsive phase the
beam's spring and damper transmit no impulse): the emulated base of the rig, i.e. the
platform (flexible.platform_mass [kg], flexible.platform_inertia [kg m^2]) plus the beam's
tip share of its mass (flexible.beam_mass [kg], flexible.beam_length [m]; consistent
Hermite tip mass, campaign/rig/beam.py), all from config/rig.yaml, with the arm's base
frame flexible.mount_height [m] above the beam tip.

output: one line per quantity; with --json one JSON object with "m_eff" [kg] (null when
m* is infinite, i.e. n leaves the range of G*_33: then "m_eff_is_infinite" is true).
--table prints, for configurations 1-3: m1 (lambda = 0), m2 (Table 3 lambda of the
Zero/Low gains) and m3 (Table 3 lambda of the High gains), each with the paper's value
and the relative difference (model - paper) / paper.

--model FILE predicts instead with a saved response model (--model alone: the one the
repository ships, config/response_model.json, fitted by the designed campaign: the joints' damping and Coulomb
friction over the contact law's pulse, the servo's gains of --gain): m* as eq 10 measures it
for an object of --speed (the rig's hammer, or a free object of --mass), with its 95 %
interval; on the flexible base the named --structure (default the rig file's) through the
VES-II loop, and the structure's peak base displacement. The model holds where it was
fitted: a speed, gain set, object mass, direction (horizontal on this rig), structure or
predicted m* outside its domain (the model file's "domain") is refused with one line naming
the bound and the value, unless --extrapolate is given: then a warning on stderr and an
interval widened for the distance outside (user guide, The response model). Where m* has no
value it says which: the tip recoils (moves backward at the contact's end: "m_eff_state":
"recoil") or does not move along n ("unbounded", "m_eff_is_infinite": true).

exit status: 0 on success, 2 on bad input (one line on stderr naming the value), including a
model file that is corrupted, malformed, out of range, edited after its fit or fitted for
another robot or rig file, and a prediction outside the model's domain.
"""

def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``meff`` subcommand to the ``campaign`` command's subparsers."""
    p = subparsers.add_parser(
        "meff", help=HELP["meff"], description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--config", metavar="N",
                      help="configuration of the robot (the PUMA 560's: the paper's Table 1, 1, 2 or 3)")
    what.add_argument("--q", metavar="Q1,Q2,Q3",
                      help="joint angles [deg], one per joint, in the robot's convention (the PUMA 560's: the "
                           "paper's, q3 from the straight elbow)")
    what.add_argument("--table", action="store_true",
                      help="reproduce Table 2 (m1, m2, m3 of configurations 1-3) beside the paper's "
                           "values; fixed base, the paper's n and Table 3 lambda")
    p.add_argument("--lambda", dest="lam", metavar="L1,L2,L3",
                   help="Virtual Rotor Inertia, diagonal [kg m^2], each >= 0 (default: 0,0,0)")
    p.add_argument("--direction", metavar="X,Y,Z",
                   help="impact direction n in the arm's base frame, normalised "
                        "(default: the paper's n = -1,0,0 from config/paper.yaml)")
    p.add_argument("--robot", default=None, metavar="NAME",
                   help="a shipped robot (puma560, planar2) or the folder or drive file of one "
                        "(default: the paper's robot, config/paper.yaml)")
    p.add_argument("--base", choices=bases(), default=None,
                   help="fixed: ground-fixed arm (eq 7, default); flexible: arm on the emulated "
                        "base body of config/rig.yaml (eq 8, see below)")
    p.add_argument("--model", metavar="FILE", nargs="?", const="",
                   help="predict with a saved response model (alone: the shipped config/response_model.json); "
                        "needs --gain and --speed")
    p.add_argument("--gain", choices=gain_sets(), default=None, help="gain set of the servo (with --model)")
    p.add_argument("--speed", type=float, default=None, help="object speed along n [m/s] (with --model)")
    p.add_argument("--mass", type=float, default=None,
                   help="a free object's mass [kg] (with --model; default the rig's pendulum hammer)")
    p.add_argument("--structure", default=None,
                   help="the flexible base's named structure of config/rig.yaml (with --model --base flexible)")
    p.add_argument("--extrapolate", action="store_true",
                   help="predict outside the model's domain (with --model): a warning and a wider interval")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.set_defaults(func=run)
    return p


# -- parsing --------------------------------------------------------------------------
def _arm_q(args, robot):
    """(config or None, the robot's angles [deg], model angles [rad]) from --config / --q."""


    if args.config is not None:
        table = configurations(robot.source)
        key = args.config.strip()
        if not re.fullmatch(r"[0-9]+", key) or int(key) not in table:
            raise InputError(f"--config {args.config}: unknown configuration; known: {sorted(table)}")
        config = int(key)
        q_paper = [float(v) for v in table[config]]
        option = f"--config {config}"
    else:
        config = None
        q_paper = parse_vector(args.q, option="--q", size=robot.nv, units="deg")
        option = f"--q {args.q}"
    try:
        q = robot.q_from_angles(q_paper, what=option)
    except ValueError as exc:
        raise InputError(f"{exc} ({robot.name}'s angles map to its model's as q + "
                         f"{robot.angle_offset_deg.tolist()} deg)") from None
    return config, q_paper, q


def _lambda(args, nv: int) -> list[float]:

    if args.lam is None:
        return [0.0] * nv
    lam = parse_vector(args.lam, option="--lambda", size=nv, units="kg m^2")
    for i, v in enumerate(lam, start=1):
        if v < 0:
            raise InputError(f"--lambda {args.lam}: lambda_{i} = {v:g} kg m^2 is negative (must be >= 0)")
    return lam


def _direction(args) -> list[float]:


    if args.direction is None:
        return impact_direction().tolist()
    n = np.asarray(parse_vector(args.direction, option="--direction", size=3))
    if not np.any(n):
        raise InputError(f"--direction {args.direction}: the zero vector has no direction")
    return unit_direction(n).tolist()


# -- output -----------------------------------------------------------------------------
def format_table2(rows: list[dict]) -> str:
    """Plain-text Table 2: configurations as rows, model / paper / difference per column."""
    columns = [c for c, _ in table2_column_classes()]
    by = {(r["config"], r["column"]): r for r in rows}
    configs = sorted({r["config"] for r in rows})
    lines = ["Table 2: effective mass m* [kg] of the tip along the paper's n, fixed base (eq 7, 11)"]
    for column, gain_class in table2_column_classes():
        lam = by[(configs[0], column)]["lambda"]
        source = "zero" if gain_class is None else f"the paper's Table 3, {gain_class} gains"  # not a vocabulary name
        lines.append(f"  {column}: lambda = {_fmt(lam)} kg m^2 ({source})")
    lines.append("")
    head = "config" + "".join(f"  {c + ' model':>9} {c + ' paper':>9} {'diff':>7}" for c in columns)
    lines.append(head)
    lines.append("-" * len(head))
    for cfg in configs:
        cells = []
        for c in columns:
            r = by[(cfg, c)]
            cells.append(f"  {r['model']:9.2f} {r['paper']:9.2f} {100 * r['rel_diff']:+6.1f}%")
        lines.append(f"{cfg:>6}" + "".join(cells))
    worst = max(rows, key=lambda r: abs(r["rel_diff"]))
    lines.append("")
    lines.append(f"largest |difference|: {100 * abs(worst['rel_diff']):.1f}% "
                 f"({worst['column']}, configuration {worst['config']})")
    return "\n".join(lines)


def _fmt(values, spec: str = "g") -> str:
    return "[" + ", ".join(format(float(v), spec) for v in values) + "]"


def _json_number(x: float):
    return float(x) if math.isfinite(x) else None


def run(args) -> int:
    """Entry point of ``campaign meff`` (see ``campaign meff --help``)."""


    paper = load_paper()
    check_model_options(args)
    if args.table:
        extra = [f"{opt} {val}" for opt, val in (("--lambda", args.lam), ("--direction", args.direction),
                                                 ("--robot", args.robot)) if val is not None]
        if args.base == FLEXIBLE:
            extra.append("--base flexible")
        if extra:
            raise InputError(f"--table reproduces the paper's Table 2 (fixed base, the paper's n and "
                             f"Table 3 lambda) and takes no {', '.join(extra)}")
        rows = table2_rows()
        if args.json:
            print(json.dumps({"table": "2", "units": "kg", "base": FIXED, "robot": paper["robot"],
                              "direction": impact_direction().tolist(), "rows": rows}))
        else:
            print(format_table2(rows))
        return 0

    robot = load_robot(paper["robot"] if args.robot is None else args.robot)
    config, q_paper, q = _arm_q(args, robot)
    n = _direction(args)
    if args.model is not None:
        return run_model(args, robot=robot, config=config, q_paper=q_paper, q=q, n=n)
    lam = _lambda(args, robot.nv)
    base = args.base or FIXED
    m = mass_on_base(robot, q, lam=lam, n=n, base=base)
    infinite = math.isinf(m)
    if args.json:
        print(json.dumps({
            "m_eff": _json_number(m), "m_eff_is_infinite": infinite, "units": "kg",
            "base": base, "config": config, "q_paper_deg": q_paper, "q_dh_rad": np.asarray(q).tolist(),
            "lambda": lam, "direction": n, "robot": robot.name,
        }))
        return 0
    where = f", configuration {config}" if config is not None else ""
    value = "inf (n leaves the range of G*_33: the tip cannot move along n)" if infinite else f"{m:.6g}"
    print(f"m*        = {value} kg")
    print(f"base      = {base} (eq {'7' if base == FIXED else '8'})")
    convention = "paper" if robot.name == paper["robot"] else f"{robot.name}'s angles"
    print(f"arm       = {robot.name}{where}, q = {_fmt(q_paper)} deg ({convention}) = "
          f"{_fmt(np.degrees(q))} deg ({'DH' if robot.name == paper['robot'] else 'model'})")
    print(f"lambda    = {_fmt(lam)} kg m^2")
    print(f"direction = {_fmt(n, '.6g')}")
    return 0
