"""``campaign map``: the planner's maps (workspace and direction), as figures.

Examples
--------
::

    campaign map workspace --out map.png
    campaign map directions --config 2 --out dirs.png --fit results/full/fit/lambda_high.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..core.errors import InputError
from ..core.files import check_output_file
from ..core.vocabulary import FLEXIBLE, bases
from ..model.conventions import angle_count
from ..model.paper import load_paper
from ..model.robot import load_robot
from ..plan import grid_points
from ..plan.factory import planner_model
from ..report.figures import plan_maps
from ..scene.description import rig_values
from .args import parse_named_lambdas, parse_vector
from .commands import HELP

__all__ = ["register", "run"]


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
--fit and --lambda.
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
    p.add_argument("--resolution", type=float, default=0.05, help="workspace grid step [m] (default 0.05)")
    p.add_argument("--y", type=float, default=None, help="plane of the workspace map, y [m] (default: the paper's)")
    p.add_argument("--config", default="1", help="paper configuration of the direction map (default 1)")
    p.add_argument("--q", metavar="Q1,Q2,Q3", default=None,
                   help="pose of the direction map, paper angles [deg] (instead of --config)")
    p.add_argument("--rig", metavar="YAML", default=None, help="rig parameter file (default config/rig.yaml)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Entry point of ``campaign map``."""
    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise InputError(f"--out {args.out}: the figure must be a .png file (a .pdf is written beside it)")
    pdf = out.with_suffix(".pdf")
    check_output_file(args.out, option="--out")     # as typed: a trailing slash names a folder
    check_output_file(pdf, option="--out's PDF")
    if not (args.resolution > 0):
        raise InputError(f"--resolution {args.resolution:g}: must be > 0 m")
    if args.kind == "workspace":
        grid_points(args.resolution, key="--resolution")    # before the model is loaded
    nv = angle_count(rig_values(rig=args.rig)["robot"])     # joints of the planner's robot
    model, lambdas = planner_model(model=args.model, fits=args.fit, named=parse_named_lambdas(args.lambdas, nv=nv),
                                   rig=args.rig, nv=nv)
    if args.kind == "workspace":
        line = plan_maps.make_workspace(out, pdf, lambdas=lambdas, model=model, rig=args.rig, resolution=args.resolution,
                                        base=args.base, y=args.y)
    else:
        q = None
        config = None
        if args.q is not None:
            robot = load_robot(load_paper()["robot"])
            q = robot.q_from_angles(parse_vector(args.q, option="--q", size=robot.nv, units="deg"), what=f"--q {args.q}")
        else:
            table = load_paper()["configurations"]
            if not args.config.isdigit() or int(args.config) not in table:
                raise InputError(f"--config {args.config}: unknown configuration; known: {sorted(table)}")
            config = int(args.config)
        line = plan_maps.make_directions(out, pdf, lambdas=lambdas, model=model, rig=args.rig, config=config, q=q, base=args.base)
    print(f"wrote {out} and {pdf}: {line}")
    return 0
