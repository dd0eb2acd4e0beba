"""``campaign trial``: simulate one trial of the VES-II and write its file."""

from __future__ import annotations

import time

from ..archive import TRIAL_BYTES, write_trial
from ..core.files import check_output_file
from ..core.vocabulary import FIXED, ZERO, bases, gain_sets
from ..model.conventions import angle_count
from ..plan.stroke import check_scene_stroke
from ..rig import simulate
from ..scene.description import make_scene, rig_values
from .args import key_value, parse_vector
from .commands import HELP


def register(sub) -> None:
    p = sub.add_parser(
        "trial",
        help=HELP["trial"],
        description="Simulate one trial of the simulated VES-II (PUMA 560 + pendulum impact device) and write "
        "its raw sensor channels (group /measured) and the simulator truth (group /truth) to one file. "
        "Rig parameters come from config/rig.yaml (SI units); --set overrides any of them.",
    )
    p.add_argument("--base", choices=bases(), default=FIXED,
                   help="ground-fixed base, or the flexible long-reach base emulated by the VES (default: fixed)")
    pose = p.add_mutually_exclusive_group()
    pose.add_argument("--config", type=int, default=None, metavar="N",
                      help="arm configuration of the robot (the PUMA 560's: the paper's Table 1, 1, 2 or 3; "
                           "default 1)")
    pose.add_argument("--q", default=None, metavar="Q1,Q2,Q3",
                      help="any arm pose instead, one angle per joint of the robot, in its own angles [deg] (the "
                           "PUMA 560's are the paper's: q_DH = q + (0, 0, -90) deg); a negative first angle works "
                           "as it is (--q -10,150,90)")
    p.add_argument("--direction", default=None, metavar="NX,NY,NZ",
                   help="impact direction n in the arm's base frame: a horizontal unit vector (the hammer moves "
                        "horizontally at the bottom of its swing; default the paper's -x). The pendulum is placed to "
                        "strike the impact point along n; a pose or direction it cannot strike is refused")
    p.add_argument("--gain", choices=gain_sets(), default=ZERO,
                   help="servo gain set of Table 1, in the paper's controller counts (default zero)")
    p.add_argument("--speed", type=float, required=True, metavar="V",
                   help="hammer speed along the impact direction at the touch [m/s] (the paper: 1.0-2.5)")
    p.add_argument("--scene", choices=("default", "ideal"), default="default",
                   help="'ideal' switches off gravity, friction, servo and noise and uses a stiff ~1 ms contact "
                        "with dense sampling, to check the simulator against the Ex-IIT closed forms")
    p.add_argument("--repeat", type=int, default=0, metavar="R", help="repeat index of the cell (default 0)")
    p.add_argument("--seed", type=int, default=None, metavar="S",
                   help="RNG seed of the sensors and the touch instant (default: derived from the cell)")
    p.add_argument("--rig", default=None, metavar="PATH", help="rig parameter file (default config/rig.yaml)")
    p.add_argument("--set", dest="params", type=key_value, action="append", default=[], metavar="KEY=VALUE",
                   help="override a rig parameter by dotted key, e.g. --set contact.stiffness=2000 (SI units)")
    p.add_argument("--out", required=True, metavar="PATH", help="trial file to write (.nc); written atomically")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args) -> int:
    check_output_file(args.out, need=TRIAL_BYTES[args.base])

    q_paper = None
    if args.q is not None:
        # as many angles as the scene's robot has joints (rig file and --set robot=...)
        robot = rig_values(rig=args.rig, params=dict(args.params))["robot"]
        q_paper = parse_vector(args.q, option="--q", size=angle_count(robot), units="deg")
    direction = None if args.direction is None else parse_vector(args.direction, option="--direction", size=3)
    config = args.config if args.config is not None else (0 if q_paper is not None else 1)
    scene = make_scene(base=args.base, config=config, gain=args.gain, speed=args.speed, repeat=args.repeat,
                       seed=args.seed, scene=args.scene, rig=args.rig, params=dict(args.params),
                       q_paper_deg=q_paper, direction=direction)
    check_scene_stroke(scene)
    t0 = time.perf_counter()
    tree = simulate(scene)
    t1 = time.perf_counter()
    path = write_trial(tree, args.out)
    t2 = time.perf_counter()
    if not args.quiet:
        tr = tree["truth"]
        print(f"wrote {path}: {scene.cell} ({scene.name} scene, seed {scene.seed}); "
              f"contact {1e3 * float(tr.contact_end - tr.contact_start):.1f} ms, peak {float(tr.peak_force):.1f} N; "
              f"simulated in {1e3 * (t1 - t0):.0f} ms, written in {1e3 * (t2 - t1):.0f} ms")
    return 0
