"""``campaign meff --model FILE``: m* as eq 10 measures it, from a saved response model.

The model (:mod:`campaign.joints.modelfile`; the repository ships ``config/response_model.json``,
fitted by the designed campaign) predicts m* for a gain set and an impact speed, with its
95 % interval; on the flexible base also the structure's peak base displacement.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, FLEXIBLE
from ..joints.impacts import Impacts
from ..joints.modelfile import load_model, shipped_model_path
from ..joints.setting import Setting, display_path

__all__ = ["check_model_options", "run_model"]

#: options only the model's prediction takes
MODEL_OPTIONS = ("gain", "speed", "mass", "structure")


def check_model_options(args) -> None:
    """The model's options go together: --model needs --gain and --speed and takes no
    --lambda or --table; --gain, --speed, --mass and --structure need --model."""
    if args.model is None:
        given = [f"--{k}" for k in MODEL_OPTIONS if getattr(args, k, None) is not None]
        if given:
            raise InputError(f"{', '.join(given)} {'go' if len(given) > 1 else 'goes'} with --model FILE "
                             "(a saved response model)")
        return
    if args.table:
        raise InputError("--table reproduces the paper's Table 2 with eq 11 and takes no --model")
    if args.lam is not None:
        raise InputError("--model predicts with the fitted joint model; --lambda is eq 11's (give one of them)")
    for opt in ("gain", "speed"):
        if getattr(args, opt) is None:
            raise InputError(f"--model needs --{opt}")
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise InputError(f"--speed {args.speed:g}: the object's speed must be > 0 m/s")
    if args.mass is not None and not (math.isfinite(args.mass) and args.mass > 0):
        raise InputError(f"--mass {args.mass:g}: the object's mass must be > 0 kg")
    if args.structure is not None and args.base != FLEXIBLE:
        raise InputError("--structure names the flexible base's structure: give --base flexible too")


def _fmt(values, spec: str = "g") -> str:
    return "[" + ", ".join(format(float(v) + 0.0, spec) for v in values) + "]"


def run_model(args, *, robot, config, q_paper, q, n) -> int:
    """Predict with ``args.model`` at the DH pose ``q`` along ``n`` and print it."""
    setting = Setting.from_rig(structure=args.structure)
    path = args.model or shipped_model_path()
    shown = display_path(path) + (" (shipped)" if not args.model else "")
    if robot.name != setting.robot.name:
        # a response model predicts for the robot of the rig it was fitted on, never another
        raise InputError(f"--robot {args.robot}: --model {shown} predicts for the rig's robot "
                         f"{setting.robot.name!r} (config/rig.yaml), not {robot.name!r}; give no --robot, "
                         "or use eq 11 without --model")
    model = load_model(path, setting=setting)
    base = args.base or FIXED
    impacts = Impacts(q=np.asarray(q, float)[None], direction=np.asarray(n, float)[None], speed=float(args.speed),
                      gain=str(args.gain), mass=None if args.mass is None else float(args.mass),
                      pendulum=args.mass is None, base=base, structure=args.structure if base == FLEXIBLE else None)
    m, lo, hi = (float(x[0]) for x in model.predict_interval(impacts))
    extra = {}
    if hasattr(model, "respond"):
        r = model.respond(impacts)
        extra = {"contact_duration": float(r.duration[0, 0]), "impulse": float(r.impulse[0, 0])}
        if r.base_peak is not None:
            extra["peak_base_displacement"] = float(r.base_peak[0, 0])
    structure = setting.structure if base == FLEXIBLE else None
    coupling = ("VES loop" if setting.loop is not None else "ideal coupling") if base == FLEXIBLE else None
    mass = setting.hammer_mass if args.mass is None else float(args.mass)
    if args.json:
        print(json.dumps({
            "m_eff": m if math.isfinite(m) else None, "m_eff_is_infinite": not math.isfinite(m),
            "interval_95": [lo, hi] if math.isfinite(m) else None, "units": "kg", "base": base, "structure": structure,
            "model": display_path(path), "kind": model.kind, "gain": args.gain, "speed": float(args.speed),
            "object_mass": mass, "object": "the rig's hammer" if args.mass is None else "free object",
            "config": config, "q_paper_deg": q_paper, "q_dh_rad": np.asarray(q).tolist(), "direction": list(n),
            "robot": robot.name, **extra}))
        return 0
    where = f", configuration {config}" if config is not None else ""
    value = ("inf (the tip cannot move along n)" if not math.isfinite(m)
             else f"{m:.6g} kg, 95 % interval [{lo:.4g}, {hi:.4g}] kg")
    print(f"m*        = {value}")
    print(f"model     = {model.kind}, {shown}, fitted on {model.n_trials_} trials")
    print(f"base      = {base}" + (f" ({structure}, {coupling})" if structure else ""))
    print(f"arm       = {robot.name}{where}, q = {_fmt(q_paper)} deg (paper) = {_fmt(np.degrees(q))} deg (DH)")
    print(f"object    = {mass:.4g} kg at {float(args.speed):g} m/s, "
          + ("the rig's hammer" if args.mass is None else "a free object") + f"; gain set {args.gain}")
    print(f"direction = {_fmt(n, '.6g')}")
    if extra:
        print(f"contact   = {1e3 * extra['contact_duration']:.4g} ms, impulse {extra['impulse']:.4g} N s")
    if "peak_base_displacement" in extra:
        print(f"base peak = {1e3 * extra['peak_base_displacement']:.4g} mm (the structure's peak displacement)")
    return 0
