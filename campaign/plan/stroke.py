"""The VES platform's stroke checked before a flexible-base trial is simulated.

The planner's eq 8 prediction of the platform's peak excursion (an impulsive contact into
the structure's first bending pair, the larger of a free and a locked arm) bounds the
simulated peak from above, so a trial it puts far beyond ``ves.stroke`` is refused before
any integration. The rig's own check on the simulated platform
(:func:`campaign.rig.trial.check_stroke`) stays the definitive one.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import FLEXIBLE
from ..model.robot import load_robot
from ..rig.beam import Beam
from ..rig.contact import ContactLaw
from ..rig.pendulum import Pendulum
from ..scene.description import Scene
from .prediction import pose_terms, predict

__all__ = ["LOCKED_LAMBDA", "STROKE_MARGIN", "predicted_platform_peak", "check_stroke_before", "check_scene_stroke"]

#: lambda [kg m^2] standing for a locked arm in the stroke prediction (far above any servo's)
LOCKED_LAMBDA = 1e6
#: a trial is refused before simulating when eq 8's predicted platform excursion exceeds the
#: stroke this many times. The prediction (impulsive contact, the larger of a free and a
#: locked arm) bounds the simulated peak from above: 0.64-0.98 of it over configurations
#: 1-3, Zero/Low/High gains, 1.0 and 2.5 m/s on both structures (the stiff mast lowest, its
#: contact is not impulsive). Twice the stroke refuses only trials the simulation would refuse
#: too; those in between are simulated and refused by the definitive check after it.
STROKE_MARGIN = 2.0


def predicted_platform_peak(robot, q0, n, beam, *, mass: float, speed: float, restitution: float, contact) -> float:
    """The platform's peak excursion [m] eq 8 predicts before simulating: the base velocity
    change of an impulsive contact (eq 8, 13-14) fed into the structure's first bending pair
    (:func:`campaign.plan.prediction.predict`), the larger of a free arm (lambda = 0) and a
    locked one."""
    terms = pose_terms(robot, np.asarray(q0, float)[None], beam=beam)
    lam = [np.zeros(robot.nv), np.full(robot.nv, LOCKED_LAMBDA)]
    pred = predict(terms, lam, np.asarray(n, float)[None], mass=mass, speed=speed, restitution=restitution,
                   contact=contact)
    return float(np.max(pred.structure_peak))


def check_stroke_before(peak: float, *, stroke: float, structure: str = "") -> None:
    """Refuse a trial whose predicted platform excursion ``peak`` (:func:`predicted_platform_peak`)
    exceeds the stroke by more than the prediction's error (:data:`STROKE_MARGIN`)."""
    if peak > STROKE_MARGIN * stroke:
        raise InputError(
            f"the emulated base would move about {peak:.4g} m from rest (eq 8's impulsive base velocity on the "
            f"structure's first mode), beyond the VES platform's stroke ves.stroke = {stroke:g} m"
            + (f" (structure {structure})" if structure else "")
            + ": a slower hammer or a stiffer or heavier structure keeps the platform in range")


def check_scene_stroke(scene: Scene) -> None:
    """:func:`check_stroke_before` for one scene: a flexible-base scene whose rig states a
    stroke (``ves.stroke``); nothing to check otherwise."""
    params = scene.param_dict
    if scene.base != FLEXIBLE or "ves.stroke" not in params:
        return
    robot = load_robot(scene.p("robot"))
    try:
        q0 = robot.q_from_angles(scene.q_paper_deg, what=f"pose {list(scene.q_paper_deg)} deg ({robot.name} angles)")
    except ValueError as exc:
        raise InputError(str(exc)) from None
    contact = ContactLaw.from_scene(scene)
    peak = predicted_platform_peak(robot, q0, scene.impact_direction, Beam.from_scene(scene),
                                   mass=Pendulum.from_scene(scene).m_b, speed=scene.speed,
                                   restitution=contact.restitution, contact=contact)
    check_stroke_before(peak, stroke=float(scene.p("ves.stroke")), structure=str(params.get("flexible.structure", "")))
