"""``campaign map``: the planner's maps (workspace and direction), as figures.

Examples
--------
::

    campaign map workspace --out map.png
    campaign map directions --config 2 --out dirs.png --fit results/full/fit/lambda_high.json
    campaign map directions --config 2 --structure stiff_mast --out dirs.png
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..core.errors import InputError
from ..core.files import check_output_file
from ..core.vocabulary import FLEXIBLE, bases
from ..model.conventions import angle_count
from ..model.paper import impact_direction, load_paper
from ..model.robot import load_robot
from ..plan.factory import check_model_domain, planner_model
from ..plan.grid import grid_points
from ..report.figures import plan_maps
from ..scene.description import rig_values
from .args import parse_named_lambdas, parse_vector
from .commands import HELP
from .plan import check_structure

__all__ = ["register", "run"]

#: the workspace map's grid step when --resolution is not given [m]
DEFAULT_RESOLUTION = 0.05


DESCRIPTION = """\
workspace: in a vertical plane y = const of the arm's base frame (default: the plane of the
paper's configurations), every reachable point is solved for all its inverse-kinematics
branches; per gain class the figure shows m* (eq 7, along the paper's n) of the best and the
worst branch and, on the flexible base, the predicted peak base displacement of the
structure's first bending pair (best and worst branch). The paper's configurations 1-3 are
marked.

directions: at a pose (--config or --q), m* (eq 7 fixed, eq 8 flexible) and the predicted
peak base displacement against the horizontal impact direction, on polar axes.

Units: metres, kg, degrees (paper convention for --q, as in campaign meff). The predictions
as in campaign plan: the shipped response model (config/response_model.json; --model FILE
another) for the gain sets zero, low and high, or eq 7/8 with the gain classes' lambda of
--fit and --lambda. --structure NAME maps the flexible base on a named structure of the rig
file (default the file's own); a model maps only the structures of its domain (those it
was checked on), with the rig's hammer at 2 m/s along horizontal directions.
"""


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``map`` subcommand."""
    p = subparsers.add_parser("map", help=HELP["map"], description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("kind", choices=("workspace", "directions"), help="which map")
    p.add_argument("--out", required=True, metavar="PNG", help="figure file (PNG); a PDF is written beside it")
    p.add_argument("--base", choices=bases(), default=FLEXIBLE,
                   help="flexible (default) adds eq 8 and the structure's displacement")
    p.add_argument("--model", metavar="FILE", default=None,
                   help="a saved response model (default: the shipped config/response_model.json)")
    p.add_argument("--fit", action="append", default=[], metavar="JSON", help="campaign lambda fit; repeatable")
    p.add_argument("--lambda", dest="lambdas", action="append", default=[], metavar="NAME=L1,L2,L3",
                   help="a gain class and its diagonal lambda [kg m^2]; repeatable")
    p.add_argument("--resolution", type=float, default=None,
                   help=f"workspace grid step [m] (default {DEFAULT_RESOLUTION}; at most 0.5, for 5 points a side)")
    p.add_argument("--y", type=float, default=None, help="plane of the workspace map, y [m] (default: the paper's)")
    pose = p.add_mutually_exclusive_group()
    pose.add_argument("--config", default=None, help="paper configuration of the direction map (default 1)")
    pose.add_argument("--q", metavar="Q1,Q2,Q3", default=None,
                      help="pose of the direction map, paper angles [deg] (instead of --config)")
    p.add_argument("--structure", metavar="NAME", default=None,
                   help="a named structure of the rig file (flexible base; default the file's own)")
    p.add_argument("--rig", metavar="YAML", default=None, help="rig parameter file (default config/rig.yaml)")
    p.set_defaults(func=run)
    return p


def _check_kind_options(args) -> None:
    """An option of the other map is refused, not ignored."""
    other = (("--config", args.config), ("--q", args.q)) if args.kind == "workspace" else \
        (("--resolution", args.resolution), ("--y", args.y))
    given = [f"{option} {value:g}" if isinstance(value, float) else f"{option} {value}"
             for option, value in other if value is not None]
    if given:
        mine = "the workspace map's" if args.kind == "directions" else "the direction map's"
        raise InputError(f"{', '.join(given)}: {'is' if len(given) == 1 else 'are'} {mine}; "
                         f"map {args.kind} takes no {' or '.join(o for o, v in other if v is not None)}")


def run(args) -> int:
    """Entry point of ``campaign map``."""
    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise InputError(f"--out {args.out}: the figure must be a .png file (a .pdf is written beside it)")
    pdf = out.with_suffix(".pdf")
    check_output_file(args.out, option="--out")     # as typed: a trailing slash names a folder
    check_output_file(pdf, option="--out's PDF")
    _check_kind_options(args)
    resolution = DEFAULT_RESOLUTION if args.resolution is None else args.resolution
    if args.resolution is not None:
        if not (math.isfinite(args.resolution) and args.resolution > 0):
            raise InputError(f"--resolution {args.resolution:g}: must be a finite step > 0 m")
        grid_points(args.resolution, key="--resolution")
    if args.y is not None and not math.isfinite(args.y):
        raise InputError(f"--y {args.y}: the plane of the workspace map must be a finite y [m]")
    check_structure(args)
    nv = angle_count(rig_values(rig=args.rig)["robot"])     # joints of the planner's robot
    model, lambdas = planner_model(model=args.model, fits=args.fit, named=parse_named_lambdas(args.lambdas, nv=nv),
                                   rig=args.rig, nv=nv)
    if model is not None:
        check_model_domain(model, base=args.base, speed=plan_maps.MAP_SPEED, directions=impact_direction()[None],
                           structure=args.structure, rig=args.rig)
    if args.kind == "workspace":
        line = plan_maps.make_workspace(out, pdf, lambdas=lambdas, model=model, rig=args.rig, resolution=resolution,
                                        base=args.base, y=args.y, structure=args.structure)
    else:
        q = None
        config = None
        if args.q is not None:
            robot = load_robot(load_paper()["robot"])
            q = robot.q_from_angles(parse_vector(args.q, option="--q", size=robot.nv, units="deg"), what=f"--q {args.q}")
        else:
            table = load_paper()["configurations"]
            text = "1" if args.config is None else args.config.strip()
            if not (text.isascii() and text.isdigit()) or int(text) not in table:
                raise InputError(f"--config {args.config}: unknown configuration; known: {sorted(table)}")
            config = int(text)
        line = plan_maps.make_directions(out, pdf, lambdas=lambdas, model=model, rig=args.rig, config=config, q=q,
                                         base=args.base, structure=args.structure)
    print(f"wrote {out} and {pdf}: {line}")
    return 0
