"""``campaign meff --model FILE``: m* as eq 10 measures it, from a saved response model.

The model (:mod:`campaign.joints.modelfile`; the repository ships ``config/response_model.json``,
fitted by the designed campaign) predicts m* for a gain set and an impact speed, with its
95 % interval; on the flexible base also the structure's peak base displacement. A
prediction outside the model's domain (:class:`campaign.joints.domain.Domain`: the speeds,
gain sets, object masses, directions, m* and structures it was fitted on) is refused unless
``--extrapolate`` is given: then a warning, and an interval widened for the distance outside.
Where m* has no value (the tip recoils, or does not move along n) it says which.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FIXED, FLEXIBLE
from ..joints.domain import m_eff_state, widen_interval, widening
from ..joints.impacts import Impacts
from ..joints.modelfile import load_model, shipped_model_path
from ..joints.setting import Setting, display_path

__all__ = ["check_model_options", "run_model"]

#: options only the model's prediction takes
MODEL_OPTIONS = ("gain", "speed", "mass", "structure")
#: what a refusal outside the domain adds
HINT = " (--extrapolate predicts anyway, with a warning and a wider interval)"
#: what m* is where it has no value
NO_VALUE = {"recoil": "none: the tip recoils (it moves backward, against n, at the contact's end), so eq 10's "
                      "m* = P / n.v_a would be negative and has no value",
            "unbounded": "unbounded: the tip does not move along n at the contact's end (eq 10's m* = P / n.v_a "
                         "is infinite)"}


def check_model_options(args) -> None:
    """The model's options go together: --model needs --gain and --speed and takes no
    --lambda or --table; --gain, --speed, --mass and --structure need --model."""
    if args.model is None:
        given = [f"--{k}" for k in MODEL_OPTIONS if getattr(args, k, None) is not None]
        if getattr(args, "extrapolate", False):
            given.append("--extrapolate")
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


def warn(excursions, *, widened: bool) -> None:
    """One warning line on stderr: what lies outside the model's domain."""
    if excursions:
        print("campaign meff: warning: extrapolating outside the model's domain: "
              + "; ".join(x.message for x in excursions) + ("; the interval is widened for it" if widened else ""),
              file=sys.stderr)


def _respond(model, impacts):
    """m* with its 95 % interval (or its state where it has no value) and the response's extras."""
    extra, state = {}, "finite"
    if hasattr(model, "respond"):
        r = model.respond(impacts)
        extra = {"contact_duration": float(r.duration[0, 0]), "impulse": float(r.impulse[0, 0]),
                 "tip_velocity": float(r.tip_velocity[0, 0])}
        if r.base_peak is not None:
            extra["peak_base_displacement"] = float(r.base_peak[0, 0])
        state = str(m_eff_state(r.m_eff, r.tip_velocity)[0, 0])
    if state != "finite":
        return state, math.nan, math.nan, math.nan, extra
    m, lo, hi = (float(x[0]) for x in model.predict_interval(impacts))
    state = str(m_eff_state([m], [1.0])[0])
    return (state, m, lo, hi, extra) if state == "finite" else (state, math.nan, math.nan, math.nan, extra)


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
    mass = setting.hammer_mass if args.mass is None else float(args.mass)
    structure = setting.structure if base == FLEXIBLE else None
    outside = model.domain_.check(speed=float(args.speed), gain=str(args.gain), mass=mass, direction=n, base=base,
                                  structure=structure, extrapolate=args.extrapolate, hint=HINT)
    impacts = Impacts(q=np.asarray(q, float)[None], direction=np.asarray(n, float)[None], speed=float(args.speed),
                      gain=str(args.gain), mass=None if args.mass is None else float(args.mass),
                      pendulum=args.mass is None, base=base, structure=args.structure if base == FLEXIBLE else None)
    state, m, lo, hi, extra = _respond(model, impacts)
    if state == "finite":
        outside += model.domain_.check(m_eff=m, extrapolate=args.extrapolate, hint=HINT)
        if outside:
            extra["interval_95_in_domain"] = [lo, hi]      # the model's own, before the widening
            lo, hi = (float(x) for x in widen_interval(m, lo, hi, widening(outside),
                                                            quantile=model.interval_quantile(0.95)))
    warn(outside, widened=state == "finite")
    coupling = ("VES loop" if setting.loop is not None else "ideal coupling") if base == FLEXIBLE else None
    if args.json:
        print(json.dumps({
            "m_eff": m if state == "finite" else None, "m_eff_state": state,
            "m_eff_is_infinite": state == "unbounded", "m_eff_note": NO_VALUE.get(state),
            "interval_95": [lo, hi] if state == "finite" else None, "units": "kg",
            "extrapolated": [x.message for x in outside], "base": base, "structure": structure,
            "model": display_path(path), "kind": model.kind, "gain": args.gain, "speed": float(args.speed),
            "object_mass": mass, "object": "the rig's hammer" if args.mass is None else "free object",
            "config": config, "q_paper_deg": q_paper, "q_dh_rad": np.asarray(q).tolist(), "direction": list(n),
            "robot": robot.name, **extra}))
        return 0
    where = f", configuration {config}" if config is not None else ""
    widened = " (widened: extrapolated)" if outside else ""
    value = NO_VALUE[state] if state != "finite" else f"{m:.6g} kg, 95 % interval [{lo:.4g}, {hi:.4g}] kg{widened}"
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
