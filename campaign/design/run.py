"""A design for every gain class, the paper's beside it, and its JSON and Markdown.

:func:`run_design` calibrates the error model (:func:`campaign.design.error_model.calibrate_error_model`),
draws the candidates the rig can strike (:mod:`campaign.design.candidates`) and fits an
:class:`campaign.design.designer.ExperimentDesign` per gain class, refitting without any chosen
pose whose rig cannot be assembled; :func:`write_design` writes the result
(:func:`design_markdown` its tables). ``campaign design`` and the designed campaign's plan
run it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.files import write_atomic
from ..model.paper import load_paper
from ..model.robot import load_robot
from ..rig.pendulum import Pendulum
from ..scene.description import load_rig
from .candidates import feasible, grid_candidates, paper_design, random_candidates, read_candidates, rig_refusal
from .designer import ExperimentDesign
from .error_model import calibrate_error_model

__all__ = ["run_design", "write_design", "design_markdown"]


def run_design(*, n_poses: int = 6, criterion: str = "D", candidates: str = "grid", n_random: int = 2000,
               seed: int = 0, speeds: Sequence[float] = (1.5, 2.5), repeats: int = 1,
               calibration: Sequence[str] | None = None, rig=None,
               lambda_prior: Mapping[str, Sequence[float]] | None = None,
               gain_classes: Mapping[str, Sequence[str]] | None = None,
               repeat_information: bool = False) -> dict[str, Any]:
    """Design poses and directions for every gain class; the paper's design evaluated beside.

    Parameters
    ----------
    n_poses, criterion
        :class:`~campaign.design.designer.ExperimentDesign` settings.
    candidates : str
        ``"grid"``, ``"random"`` (``n_random`` poses, ``seed``) or a CSV path
        (:func:`~campaign.design.candidates.read_candidates`).
    speeds, repeats
        Every pose is struck at each speed ``repeats`` times per gain set of its class.
    calibration : sequence of path-like, optional
        Identification tables for :func:`~campaign.design.error_model.calibrate_error_model`.
    rig : path-like, optional
        Rig parameter file.
    lambda_prior : mapping, optional
        Class -> lambda the design is optimal at; a class not given takes the paper's Table 3.
    gain_classes : mapping, optional
        Class -> gain sets; default the paper's.
    repeat_information : bool
        Offer candidates whose m* and sensitivities equal another's (a pose along -n, the
        arm and n turned together about joint 1; :class:`~campaign.design.designer.ExperimentDesign`),
        so that a design may choose one measurement twice. By default the first of each such
        group the rig can strike is offered, the others not.

    Returns
    -------
    dict
        JSON-safe: the settings, the error model, and per class the designed and the
        paper's numbers (:meth:`~campaign.design.designer.ExperimentDesign.evaluate`) and the chosen poses.
    """
    paper = load_paper()
    robot = load_robot(paper["robot"])
    p, _ = load_rig(rig)
    pend = Pendulum.from_values(p)
    errors = calibrate_error_model(calibration)
    if candidates == "grid":
        Q, D = grid_candidates()
    elif candidates == "random":
        Q, D = random_candidates(n_random, robot=robot, seed=seed)
    else:
        Q, D = read_candidates(candidates)
    ok, _ = feasible(robot, Q, D, speed=max(speeds), rig=rig)
    classes = dict(gain_classes or paper["gain_classes"])
    priors = {**paper["table3"], **dict(lambda_prior or {})}
    out: dict[str, Any] = {
        "criterion": criterion, "n_poses": int(n_poses), "candidates": str(candidates), "n_candidates": int(len(Q)),
        "n_feasible": int(ok.sum()), "repeat_information": bool(repeat_information),
        "speeds": [float(v) for v in speeds], "repeats": int(repeats),
        "hammer_mass": pend.m_b, "error_model": errors.to_dict(), "classes": {},
        "units": {"lambda": "kg m^2", "m_eff": "kg", "q_paper_deg": "deg", "azimuth_deg": "deg from -x about +z"},
    }
    Qp, Dp = paper_design()
    for name, gains in classes.items():
        est = ExperimentDesign(n_poses=n_poses, criterion=criterion, lambda_prior=priors[name], speeds=speeds,
                               trials_per_speed=int(repeats) * len(gains), error_model=errors, m_b=pend.m_b,
                               robot=robot, repeat_information=repeat_information)
        usable = ok.copy()
        refused = []
        for _ in range(4 * int(n_poses) + 1):
            # a refused candidate's twin of the same information can take its place
            idx = np.flatnonzero(usable)
            est.fit(Q[idx], D[idx])
            bad = [int(idx[i]) for i in est.chosen_
                   if rig_refusal(Q[idx[i]], D[idx[i]], gains=gains, speeds=speeds, rig=rig)]
            if not bad:
                break
            for b in bad:
                usable[b] = False
                refused.append({"q_paper_deg": Q[b].tolist(), "direction": D[b].tolist(),
                                "reason": rig_refusal(Q[b], D[b], gains=gains, speeds=speeds, rig=rig)})
        else:
            raise InputError(f"{name}: the rig refused every design tried ({len(refused)} poses refused)")
        out["classes"][name] = {
            "gains": list(gains), "lambda_prior": [float(x) for x in priors[name]],
            "trials_per_speed": int(repeats) * len(gains), "n_offered": est.n_offered_, "designed": est.summary_,
            "paper": est.evaluate(Qp, Dp), "refused_by_rig": refused,
        }
    return out


def write_design(result: Mapping[str, Any], *, out_json=None, out_md=None) -> str:
    """Write a :func:`run_design` result as JSON and/or Markdown (atomically); returns the Markdown."""
    md = design_markdown(result)

    def clean(x):
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    if out_json is not None:
        write_atomic(out_json, json.dumps(clean(result), indent=2, sort_keys=True) + "\n")
    if out_md is not None:
        write_atomic(out_md, md)
    return md


def design_markdown(result: Mapping[str, Any]) -> str:
    """Markdown tables of a :func:`campaign.cli.design` result (both gain classes)."""
    lines = ["# Experiment design for lambda", ""]
    em = result["error_model"]
    if result.get("repeat_information", True):
        same = ("; all offered, also those that repeat another's measurement: m* is even in n and unchanged by "
                "turning the arm and n together about joint 1, so a pose listed along n and -n is one measurement "
                "struck twice")
    else:
        same = ("; of those that give the same m* and sensitivities -- m* is even in n and unchanged by turning "
                "the arm and n together about joint 1 -- only the first is offered")
    lines += [f"Criterion {result['criterion']}-optimal, K = {result['n_poses']} poses from "
              f"{result['n_candidates']} candidates ({result['n_feasible']} the rig can strike{same}), speeds "
              f"{', '.join(f'{v:g}' for v in result['speeds'])} m/s. Error model {em['formula']}: a = {em['a']:.4g}, "
              f"b = {em['b']:.4g} m/s from {em['n_trials']} trials (identified vs true m*, rms {em['rms']:.3g}).", ""]
    for name, cls in result["classes"].items():
        lam = cls["lambda_prior"]
        lines += [f"## {name} (gains {', '.join(cls['gains'])}; prior lambda = "
                  f"[{', '.join(f'{x:g}' for x in lam)}] kg m^2, {cls['trials_per_speed']} trial(s) per pose and speed"
                  + (f"; {cls['n_offered']} different measurements offered)" if "n_offered" in cls else ")"),
                  "", "| pose | q paper [deg] | azimuth of n [deg] | m* [kg] | m*/m_b | "
                  "d ln m*/d ln lambda_1 | _2 | _3 |", "|---|---|---|---|---|---|---|---|"]
        d = cls["designed"]
        for i, (q, az, m, r, s) in enumerate(zip(d["q_paper_deg"], d["azimuth_deg"], d["m_eff"], d["m_ratio"],
                                                 d["sensitivity"], strict=True), 1):
            lines.append(f"| {i} | {', '.join(f'{x:g}' for x in q)} | {az:.1f} | {m:.3f} | {r:.2f} | "
                         + " | ".join(f"{x:.3f}" for x in s) + " |")
        lines += ["", "| design | poses | condition number | " + " | ".join(
            f"95 % CI lambda_{j + 1} [kg m^2] (+-%)" for j in range(len(lam))) + " |",
            "|---|---|---|" + "---|" * len(lam)]
        for label, key in (("paper (configurations 1-3, n = -x)", "paper"), ("designed", "designed")):
            e = cls[key]
            cells = [f"[{lo:.4g}, {hi:.4g}] (+-{100 * rel:.3g} %)" if math.isfinite(rel) else "unbounded"
                     for lo, hi, rel in zip(e["lambda_ci"][0], e["lambda_ci"][1], e["relative_ci"], strict=True)]
            lines.append(f"| {label} | {len(e['m_eff'])} | {e['condition_number']:.3g} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines) + "\n"
