"""An impact planner built from the rig's values: its contact law, hammer, structure and servo.

:func:`build_planner` reads the rig file once (:func:`campaign.scene.description.rig_values`,
with a named structure and overrides) and assembles an
:class:`campaign.plan.planner.ImpactPlanner` with the rig's contact law and object, the
structure's beam on the flexible base and the arm's servo, friction and gravity after the
impact (:class:`campaign.plan.post_contact.ArmAfterImpact`). The CLI, the maps and the
studies all build their planners here.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FLEXIBLE, gain_classes
from ..model.paper import load_paper
from ..model.robot import Robot, load_robot
from ..rig.beam import Beam
from ..rig.contact import ContactLaw
from ..rig.controller import joint_gains
from ..rig.pendulum import Pendulum
from ..scene.description import rig_values
from .planner import ImpactPlanner
from .post_contact import ArmAfterImpact

__all__ = ["planner_lambdas", "planner_model", "object_defaults", "lambdas_per_gain_set", "arm_after_impact",
           "build_planner", "check_model_domain"]


def planner_lambdas(*, fits: Sequence[str | Path] = (), named: Mapping[str, Sequence[float]] | None = None,
                    nv: int = 3) -> dict[str, list[float]]:
    """Gain classes and their lambda [kg m^2]: from lambda-fit JSONs (``fits``) and ``named``
    ones, or the paper's Table 3 when neither is given. A bad file is named (InputError)."""
    out: dict[str, list[float]] = {}
    for path in fits:
        try:
            doc = json.loads(Path(path).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"--fit {path}: no such file") from None
        except (OSError, ValueError) as exc:
            raise InputError(f"--fit {path}: not a readable JSON file ({exc})") from None
        if not isinstance(doc, dict) or "lambda" not in doc or "gain_class" not in doc:
            raise InputError(f"--fit {path}: not a lambda fit (needs keys gain_class and lambda)")
        lam = doc["lambda"]
        if not isinstance(lam, list) or len(lam) != nv or any(v is None for v in lam):
            raise InputError(f"--fit {path}: lambda = {lam!r} is not {nv} numbers")
        out[str(doc["gain_class"])] = [float(v) for v in lam]
    for name, lam in (named or {}).items():
        out[str(name)] = [float(v) for v in lam]
    if not out:
        out = {str(k): [float(v) for v in lam] for k, lam in load_paper()["table3"].items()}
        if any(len(lam) != nv for lam in out.values()):
            raise InputError(f"the paper's Table 3 lambda is for its {len(next(iter(out.values())))}-joint robot: "
                             f"give the lambda of this {nv}-joint robot (--fit or --lambda)")
    return out


def planner_model(*, model=None, fits: Sequence[str | Path] = (), named: Mapping[str, Sequence[float]] | None = None,
                  rig=None, nv: int = 3) -> tuple[Any, dict[str, list[float]] | None]:
    """What the planner predicts with: ``(model, None)``, the response model of the file
    ``model`` (default the shipped ``config/response_model.json``), or ``(None, lambdas)``
    when lambda fits or named lambdas are given (eq 7/8 with them, :func:`planner_lambdas`,
    ``nv`` lambdas each).
    A model file that is unreadable or fitted for another robot or rig is named (InputError)."""
    if fits or named:
        if model is not None:
            raise InputError("give either a response model (--model) or lambdas (--fit, --lambda), not both")
        return None, planner_lambdas(fits=fits, named=named, nv=nv)
    # here, not at the top: the model file's reader brings the identification and the archive
    # (about 0.3 s), which a job predicting with lambdas (the planner's maps) never needs
    from ..joints.modelfile import load_model, shipped_model_path

    return load_model(shipped_model_path() if model is None else model, rig=rig), None


def check_model_domain(model, *, base: str, speed: float, directions, mass: float | None = None,
                       structure: str | None = None, rig=None, extrapolate: bool = False, hint: str = "") -> list:
    """Refuse (:class:`campaign.joints.domain.OutsideDomain`, one line naming the bound and the
    value, then ``hint``) planning with a response ``model`` outside its domain: the object's
    ``speed`` and ``mass`` (default the rig's hammer), the ``directions``, the base and its
    named ``structure`` (default the rig file's), the gain sets of the paper's Table 1; with
    ``extrapolate`` return what lies outside instead (:meth:`campaign.joints.domain.Domain.check`)."""
    values = rig_values(rig=rig, params={"flexible.structure": structure} if structure else None)
    name = str(values["flexible.structure"]) if base == FLEXIBLE else None
    m = object_defaults(values)["mass"] if mass is None else float(mass)
    return model.domain_.check(speed=float(speed), mass=m, direction=directions, base=base, structure=name,
                               gain=[str(g) for g in load_paper()["gains"]], extrapolate=extrapolate, hint=hint)


def object_defaults(values: Mapping[str, Any]) -> dict[str, float]:
    """The object the planner assumes by default: the rig's hammer (its effective mass
    [kg]), the contact law's stiffness and exponent and its restitution."""
    contact = ContactLaw.from_values(values)
    return {"mass": Pendulum.from_values(values).m_b, "restitution": float(contact.restitution),
            "contact_stiffness": float(contact.stiffness), "contact_exponent": float(contact.exponent)}


def lambdas_per_gain_set(lambdas: Mapping[str, Sequence[float]]) -> dict[str, Sequence[float]]:
    """``lambdas`` with each of the paper's pooled gain classes (``zero_low``) split into its
    gain sets (``zero``, ``low``), each with the class's lambda: after the impact their servos
    differ, so the structure's response does too."""
    pooled = gain_classes()
    out: dict[str, Sequence[float]] = {}
    for name, lam in lambdas.items():
        members = pooled.get(name, (name,))
        for member in members if len(members) > 1 else (name,):
            if member == name or member not in lambdas:      # a set named on its own keeps its lambda
                out[str(member)] = lam
    return out


def arm_after_impact(values: Mapping[str, Any], robot: Robot) -> ArmAfterImpact:
    """The rig's arm after the impact: the servo of every gain set of the paper's Table 1 in
    joint units (:func:`campaign.rig.controller.joint_gains`: proportional and derivative)
    and of every single-set gain class, the joints' viscous friction (the drive file's times
    ``arm.viscous_scale``) and gravity."""
    gains = {}
    for name in load_paper()["gains"]:
        kp, kd, _ = joint_gains(str(name), values=values, robot=robot)
        gains[str(name)] = (kp, kd)
    for cls, members in gain_classes().items():
        if len(members) == 1 and cls not in gains:
            gains[cls] = gains[members[0]]
    return ArmAfterImpact(gains=gains, viscous=np.asarray(robot.viscous) * float(values["arm.viscous_scale"]),
                          gravity=float(values["gravity"]))


def build_planner(*, base: str, lambdas=None, model=None, mass=None, speed: float, restitution=None,
                  objective="impulse", weights=(1.0, 1.0, 1.0), rig=None, robot=None, structure=None, params=None,
                  post_contact: bool = True) -> ImpactPlanner:
    """An :class:`~campaign.plan.planner.ImpactPlanner` with the rig's contact law and structure.

    Parameters
    ----------
    base : {"fixed", "flexible"}
    lambdas : mapping, optional
        Gain class -> lambda [kg m^2] (:func:`planner_lambdas`): eq 7/8 with them.
    model : campaign.joints.impedance_model.JointImpedance, optional
        A fitted response model instead (:func:`planner_model`): it plans the gain sets of the
        paper's Table 1, the object the rig's hammer unless ``mass`` is given, eq 14's
        restitution the model's unless ``restitution`` is.
    mass, restitution : float, optional
        The object [kg] and the restitution; default the rig's hammer (:func:`object_defaults`).
    speed : float
        The object's speed [m/s].
    rig : path-like, optional
        Rig parameter file (default ``config/rig.yaml``).
    structure : str, optional
        A structure of the rig file's ``structures:`` (default the file's own).
    params : mapping, optional
        Dotted rig overrides, applied to every value the planner reads.
    post_contact : bool
        Split the paper's pooled gain classes into their gain sets
        (:func:`lambdas_per_gain_set`) and let the arm's servo, friction and gravity
        (:func:`arm_after_impact`) act over the contact's pulse and after it.
    """
    if (lambdas is None) == (model is None):
        raise InputError("the planner predicts with lambdas or with a response model: give exactly one")
    over = dict(params or {})
    if model is not None and over:
        raise InputError(f"rig overrides {sorted(over)} do not apply to a fitted response model (it is tied to its "
                         "rig file)")
    if structure is not None:
        over["flexible.structure"] = structure
    values = rig_values(rig=rig, params=over or None)
    robot = load_robot(str(values["robot"])) if robot is None else robot
    d = object_defaults(values)
    beam = Beam.from_values(values) if base == FLEXIBLE else None
    if model is not None:
        return ImpactPlanner(robot, model=model, mass=d["mass"] if mass is None else mass, speed=speed,
                             restitution=model.restitution_ if restitution is None else restitution,
                             contact_stiffness=d["contact_stiffness"], contact_exponent=d["contact_exponent"],
                             beam=beam, objective=objective, weights=weights, structure=structure,
                             pendulum=mass is None, contact_restitution=d["restitution"])
    arm = None
    if post_contact:
        lambdas = lambdas_per_gain_set(lambdas)
        arm = arm_after_impact(values, robot)
    return ImpactPlanner(robot, lambdas=lambdas, mass=d["mass"] if mass is None else mass, speed=speed,
                         restitution=d["restitution"] if restitution is None else restitution,
                         contact_stiffness=d["contact_stiffness"], contact_exponent=d["contact_exponent"],
                         beam=beam, objective=objective, weights=weights, arm=arm)
