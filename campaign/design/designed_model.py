"""The response model the designed campaign fits, saves and ships.

:func:`fit_model` fits :class:`campaign.joints.impedance_model.JointImpedance` (the joints'
damping and Coulomb friction over the contact) on the designed poses' fixed-base trials of
every gain set, measures its residual scatter on the plan's held-out poses (seeded random
poses none of the fits sees) struck on the flexible base under each named structure (the
scatter its intervals carry there: at random poses the flexible base's m* is identified
with about twice the fixed base's noise, up to +6 % at high gains, where its 50 Hz joint
samples leave the tip-space velocity model), and saves it as a model file
(:mod:`campaign.joints.modelfile`) with a Markdown summary. The workflow writes it to
``results/designed/model/response_model.json``; the repository ships the same file as
``config/response_model.json`` (the model the CLI and the planner use by default, beside
the rig file it was fitted for), which ``snakemake designed`` reproduces (bit for bit on the
machine that fitted it, within the tolerance policy on another) and checks
(:func:`compare_shipped`, :func:`model_differences`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.files import write_atomic
from ..core.tolerance import IDENTIFY_RTOL, Difference, compare
from ..core.vocabulary import FLEXIBLE
from ..identify.table import read_identification
from ..joints.impacts import Impacts
from ..joints.impedance_model import JointImpedance
from ..joints.modelfile import save_model, shipped_model_path
from ..joints.scatter import SMALL_MASS_REFERENCE, fit_scatter, tip_velocity_change
from ..joints.setting import Setting, display_path

__all__ = ["fit_model", "model_markdown", "compare_shipped", "model_differences"]


def fit_model(plan_json, fixed_tables: Sequence, flexible_tables: Mapping[str, Sequence], *, archive, out_json,
              out_md, check_tables: Sequence = ()) -> JointImpedance:
    """Fit the model on the designed trials (``fixed_tables``: identification CSVs of the
    designed role, every gain set), measure its scatter per structure on ``flexible_tables``
    (structure -> CSVs of the held-out poses on the flexible base), fit its scatter model on
    every residual (those, the designed trials' and the fixed-base ``check_tables``: the
    paper's and the held-out poses, which the fit does not see), save it and its summary."""
    with open(plan_json, encoding="utf-8") as fh:
        plan = json.load(fh)
    setting = Setting.from_rig(plan.get("rig"))
    fixed = Impacts.from_records(read_identification(fixed_tables))
    model = JointImpedance(setting).fit(fixed)
    model.structure_scatter_, model.structure_residuals_ = {}, {}
    spread = [_residuals(model, fixed, None)]
    if check_tables:
        spread.append(_residuals(model, Impacts.from_records(read_identification(check_tables)), None))
    for name, tables in sorted(flexible_tables.items()):
        imp = Impacts.from_records(read_identification(tables), structure=name)
        if imp.base != FLEXIBLE:
            raise InputError(f"structure {name}: its trials are not on the flexible base")
        spread.append(_residuals(model, imp, name))
        r = spread[-1][0]
        ok = np.isfinite(r)
        if not ok.any():
            raise InputError(f"structure {name}: no finite prediction to measure the scatter on")
        model.structure_scatter_[name] = float(np.sqrt(np.mean(r[ok] ** 2)))
        model.structure_residuals_[name] = {k: (float(x) if math.isfinite(x) else None)
                                            for k, x in zip(imp.keys, r, strict=True)}
        model.domain_ = model.domain_.with_structure(name, imp, masses=model._masses(imp))
    r, gains, dv, structures, psd, speed, m = (sum((list(part[j]) for part in spread), []) for j in range(7))
    model.scatter_model_ = fit_scatter(r, gains, dv, speed=speed, m_eff=m, structures=structures, parameter_sd=psd)
    save_model(model, out_json, archive=archive)
    write_atomic(out_md, model_markdown(model, archive=display_path(archive)))
    return model


def _residuals(model: JointImpedance, impacts: Impacts, structure: str | None):
    """``(ln m*_model - ln m*_identified, gain sets, predicted tip velocity change, structures,
    the parameters' sd, speeds, predicted m*)`` of ``impacts``."""
    m = model.predict(impacts)
    r = np.log(m) - np.log(impacts.m_eff)
    dv = tip_velocity_change(m, impacts.speed, model._masses(impacts), model.restitution_)
    return r, impacts.gain, dv, [structure] * len(impacts), model.parameter_sd(impacts), impacts.speed, m


def model_markdown(model: JointImpedance, *, archive: str | None = None) -> str:
    """The model's summary: its parameters with their 95 % intervals, the fit's residuals and
    the scatter per structure."""
    p = model.parameters()
    lo, hi = p["params_ci"]
    nv = len(p["damping"])
    lines = ["# Response model (joint impedance over the contact)", "",
             f"Fitted on {model.n_trials_} fixed-base trials of the designed campaign"
             + (f" ({archive})" if archive else "") + ", every gain set; the rig and robot it takes as known: "
             f"{model._the_setting().rig_file}, {model._the_setting().robot.name}.", "",
             "| parameter | value | 95 % interval | identifiable |", "|---|---|---|---|"]
    for j in range(nv):
        lines.append(f"| damping beta_{j + 1} [N m s/rad] | {p['damping'][j]:.4g} | [{lo[j]:.4g}, {hi[j]:.4g}] | "
                     f"{'yes' if p['identifiable'][j] else 'no'} |")
    lines.append(f"| Coulomb scale s (of the drive file's levels) | {p['friction_scale']:.4g} | [{lo[nv]:.4g}, "
                 f"{hi[nv]:.4g}] | {'yes' if p['identifiable'][nv] else 'no'} |")
    lines += ["", f"Restitution of eq 14: {p['restitution']:.4f} (the fitted trials' mean). Condition number of the "
              f"fit's Jacobian: {p['condition_number']:.3g}. Residuals ln(m*_model / m*_identified): rms "
              f"{model.rms_log_residual_:.4f}, scatter {model.residual_scatter_:.4f} (the intervals' part on the "
              "fixed base).", ""]
    sm = getattr(model, "scatter_model_", None)
    if sm is not None:
        lines += ["Scatter of ln m* the intervals carry (fitted on " f"{sm.n_residuals} residuals; "
                  "sigma^2 = a_g^2 + b_g^2 / dv^2 + h_g^2 / v^2 + d^2 (m_0 / m*)^2, on the flexible base "
                  "+ f_g^2 + c_s^2 / dv^2, dv the predicted tip velocity change, v the speed, "
                  f"m_0 = {SMALL_MASS_REFERENCE:g} kg; Student t with {sm.dof:.3g} degrees of freedom):", "",
                  "| gain set | floor a_g | velocity noise b_g [m/s] | speed noise h_g [m/s] | flexible base's floor "
                  "f_g |", "|---|---|---|---|---|"]
        lines += [f"| {g} | {sm.floor[g]:.4g} | {sm.velocity_noise[g]:.4g} | {sm.speed_noise[g]:.4g} | "
                  f"{sm.flexible_floor[g]:.4g} |" for g in sorted(sm.floor)]
        lines += ["", f"- small-m* share d = {sm.small_mass:.4g}"]
        lines += [f"- flexible base, {k}: c_s = {v:.4g} m/s" for k, v in sorted(sm.structure.items())] + [""]
    for name, s in sorted(getattr(model, "structure_scatter_", {}).items()):
        n = len(model.structure_residuals_.get(name, {}))
        lines.append(f"- flexible base, {name}: scatter {s:.4f} over {n} trials of the plan's held-out poses (the "
                     "intervals' part there).")
    return "\n".join(lines) + "\n"


def _leaves(value, path: str = "") -> dict:
    """``{path: value}`` of a model file's content: a dict opened key by key, a list of
    numbers (or of lists of numbers) kept whole as one array."""
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            out.update(_leaves(item, f"{path}/{key}"))
        return out
    return {path: value}


def model_differences(fitted: Mapping, shipped: Mapping) -> list[Difference]:
    """How a model refitted elsewhere differs from another, under the tolerance policy.

    Text, keys and shapes must be the same (the content digest aside); numbers agree within
    :data:`campaign.core.tolerance.IDENTIFY_RTOL` (the refit reads identified m*, which moves
    by that much across machines): residuals and scatters, logarithms of m* ratios, on the
    unit scale (their difference is a relative difference of m*), every other number on
    its own magnitude (an array on its largest element).

    Parameters
    ----------
    fitted, shipped : mapping
        Two model files' content (JSON).

    Returns
    -------
    list of Difference
        One per quantity, in the files' order.
    """
    # the digest is a checksum of the rest: a refit within the tolerance has another
    a, b = ({k: v for k, v in _leaves(doc).items() if not k.startswith("/digest/")} for doc in (fitted, shipped))
    found = [Difference(k, math.inf, 0.0, 0.0, note="only in one of the two") for k in sorted(set(a) ^ set(b))]
    for key in (k for k in a if k in b):
        log_ratio = any(word in key for word in ("residual", "scatter"))
        found.append(compare(a[key], b[key], name=key.lstrip("/"), rtol=IDENTIFY_RTOL,
                             scale=1.0 if log_ratio else None))
    return found


def compare_shipped(fitted_json, out_txt, *, shipped=None) -> bool:
    """Whether the model the campaign just fitted is the shipped one: byte for byte, or, when
    the bytes differ, the same numbers within the tolerance policy (:func:`model_differences`:
    a refit on another machine); writes the finding (a stale shipped model is reported, not an
    error: a changed campaign fits its own)."""
    shipped = shipped_model_path() if shipped is None else Path(shipped)
    a = Path(fitted_json).read_bytes()
    b = shipped.read_bytes() if shipped.is_file() else None
    same = a == b
    if same:
        text = f"identical: {display_path(fitted_json)} is byte for byte the shipped {display_path(shipped)}\n"
    elif b is None:
        text = f"differs: there is no shipped model {display_path(shipped)}\n"
    else:
        found = model_differences(json.loads(a), json.loads(b))
        beyond = [d for d in found if not d.ok]
        if not beyond:
            same = True
            closest = max(found, key=lambda d: d.largest / d.allowed if d.allowed > 0 else 0.0)
            text = (f"the same model: {display_path(fitted_json)} agrees with the shipped {display_path(shipped)} "
                    f"within the tolerance policy (its bytes differ: computed on another platform); largest: "
                    f"{closest}\n")
        else:
            text = (f"differs: {display_path(fitted_json)} is not the shipped {display_path(shipped)}; a campaign "
                    f"with the shipped settings reproduces it, so the rig, the robot, the code or the designed "
                    f"settings changed (copy the new file there to ship it); {len(beyond)} quantities beyond the "
                    f"tolerance policy, e.g. {beyond[0]}\n")
    write_atomic(out_txt, text)
    print(text, end="")
    return same
