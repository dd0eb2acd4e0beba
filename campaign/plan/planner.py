"""The impact planner: where and how the arm should meet a moving object (paper, section 2).

The paper proposes the Ex-IIT for planning: choose the configuration that reduces the
impact force, and use the effective mass as an index of the supporting structure's
vibration. :class:`ImpactPlanner` finds every pose that reaches a contact point
(:func:`campaign.model.robot.ik.position_branches`), predicts every (pose, gain class,
impact direction) candidate (:func:`campaign.plan.prediction.predict`: m*, impulse, joint
velocities, peak force and, on the flexible base, the structure's peak displacement) and
ranks the candidates by an objective (:data:`OBJECTIVES`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError
from ..core.vocabulary import gain_sets
from ..model.exiit import lambda_matrix
from ..model.robot import Robot
from ..model.robot.ik import position_branches
from ..rig.contact import ContactLaw
from .directions import unit_directions
from .model_prediction import predict_model, rescore_loop
from .prediction import Predictions, check_object, pose_terms, predict

__all__ = ["ImpactPlanner", "OBJECTIVES", "RESCORE"]

#: quantities a plan can be ranked by (minimised)
OBJECTIVES = ("impulse", "force", "displacement", "weighted")
#: the ideally coupled ranking's best candidates a model predicts again through the VES-II loop
RESCORE = 64


class ImpactPlanner:
    """Every (pose, gain class, direction) candidate for catching an object at a point, ranked.

    scikit-learn's shape: the constructor stores settings, :meth:`fit` does the work on one
    contact point and a set of directions, fitted values end in ``_``.

    Parameters
    ----------
    robot : Robot
    lambdas : mapping of str to array_like
        Gain class name -> its Virtual Rotor Inertia [kg m^2] (diagonal or matrix).
    mass, speed : float
        The object's mass [kg] and speed along n [m/s].
    restitution : float
        ``e`` of eq 13-14, also the contact law's restitution [1].
    contact_stiffness, contact_exponent : float
        The rig's contact law ``F = k delta^p (1 + d ddelta/v0)`` [N/m^p], [1].
    beam : campaign.rig.beam.Beam, optional
        The flexible structure the arm stands on; None for a fixed base.
    objective : {"impulse", "force", "displacement", "weighted"}
        What the ranking minimises; ``weighted`` is ``sum w_k x_k / max(x_k)`` over impulse,
        peak force and (flexible base) structure displacement.
    weights : 3 floats
        ``w`` of the weighted objective (impulse, force, displacement), each >= 0.
    arm : campaign.plan.post_contact.ArmAfterImpact, optional
        Servo gains (per gain class), joint friction and gravity during and after the contact
        (:func:`campaign.plan.prediction.predict`): the peak force (fixed base) and the structure's peak (flexible base)
        then follow the arm's resistance to the contact's pulse.
    model : campaign.joints.impedance_model.JointImpedance, optional
        A fitted response model: the candidates are then its predictions
        (:func:`campaign.plan.model_prediction.predict_model`) for the gain sets ``gains``, and
        ``lambdas`` and ``arm`` are not used.
    gains : sequence of str, optional
        The gain sets a model plans with (default the paper's Table 1: zero, low, high).
    structure : str, optional
        The flexible base's named structure the model predicts on (default the rig file's).
    pendulum : bool
        The object is the rig's pendulum hammer (a model's eq 10 counts its gravity's impulse).
    contact_restitution : float, optional
        The restitution the contact law's damping is solved for, where it is not eq 14's
        ``restitution`` (a model's eq 14 takes its fitted trials' mean).
    rescore : int
        With a model on the flexible base whose rig emulates the structure through the VES-II
        loop: the best ``rescore`` candidates of the ideally coupled ranking are predicted again
        through the loop (:func:`campaign.plan.model_prediction.rescore_loop`) and every
        candidate is ranked on what it then carries (``coupling`` of each row); 0: none.

    Attributes
    ----------
    rescored_ : ndarray of bool, shape (N, G, D)
        The candidates predicted through the loop.
    """

    def __init__(self, robot: Robot, *, lambdas: Mapping[str, object] | None = None, mass: float, speed: float,
                 restitution: float, contact_stiffness: float, contact_exponent: float, beam=None,
                 objective: str = "impulse", weights=(1.0, 1.0, 1.0), arm=None, model=None, gains=None,
                 structure: str | None = None, pendulum: bool = True, contact_restitution: float | None = None,
                 rescore: int = RESCORE):
        self.robot = robot
        self.rescore = rescore
        self.contact_restitution = contact_restitution
        self.model = model
        self.gains = gains
        self.structure = structure
        self.pendulum = pendulum
        if model is not None:
            lambdas = {g: None for g in (gains if gains is not None else gain_sets())}
        self.lambdas = dict(lambdas or {})
        self.mass = mass
        self.speed = speed
        self.restitution = restitution
        self.contact_stiffness = contact_stiffness
        self.contact_exponent = contact_exponent
        self.beam = beam
        self.objective = objective
        self.weights = weights
        self.arm = arm

    def _check(self):
        check_object(mass=self.mass, speed=self.speed, restitution=self.restitution)
        if not self.lambdas:
            raise InputError("no gain class given: name at least one with its lambda")
        for name, lam in self.lambdas.items() if self.model is None else ():
            try:
                lambda_matrix(lam, self.robot.nv)
            except ValueError as exc:
                raise InputError(f"gain class {name!r}: {exc}") from None
        if self.arm is not None and self.model is None:
            self.arm.matrices(list(self.lambdas), self.robot.nv)     # refuses bad gains before any work
        if self.objective not in OBJECTIVES:
            raise InputError(f"objective {self.objective!r} is not one of {list(OBJECTIVES)}")
        if self.objective == "displacement" and self.beam is None:
            raise InputError("objective 'displacement' needs the flexible base (a fixed base has no structure)")
        w = np.asarray(self.weights, dtype=float)
        if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
            raise InputError(f"weights = {np.asarray(self.weights).tolist()} must be 3 values >= 0, not all zero")
        if self.objective == "weighted" and self.beam is None and not np.any(w[:2] > 0):
            raise InputError(f"weights = {w.tolist()} weigh only the displacement, which a fixed base has not "
                             "(give the impulse or the peak force a weight, or --base flexible)")
        if isinstance(self.rescore, bool) or not isinstance(self.rescore, (int, np.integer)) or self.rescore < 0:
            raise InputError(f"rescore = {self.rescore!r} must be an integer >= 0")
        e = self.restitution if self.contact_restitution is None else self.contact_restitution
        return ContactLaw(float(self.contact_stiffness), float(self.contact_exponent), float(e)), w

    def fit(self, point, directions) -> ImpactPlanner:
        """Find every pose reaching ``point`` [m] and predict each candidate; rank them.

        Raises InputError (before any prediction) for an unreachable point, a zero
        direction or a bad object, gain class or objective.
        """
        contact, w = self._check()
        n = unit_directions(directions)
        p = np.asarray(point, dtype=float)
        ik = position_branches(self.robot, p)
        if ik.n_branches == 0:
            where = ", ".join(f"{x + 0.0:.4g}" for x in np.ravel(p))     # + 0.0: never "-0"
            if ik.reached_outside_limits:
                raise InputError(f"point ({where}) m is reached only outside the joint limits")
            raise InputError(f"point ({where}) m is out of the arm's reach")
        rescored = None
        if self.model is not None:
            kw = dict(mass=self.mass, speed=self.speed, restitution=self.restitution, contact=contact,
                      structure=self.structure, pendulum=self.pendulum)
            pred = predict_model(self.robot, ik.q, self.model, list(self.lambdas), n, flexible=self.beam is not None,
                                 **kw)
            rescored = np.zeros(pred.m_eff.shape, bool)
            if self.beam is not None and self.rescore > 0 and self.model.setting_for(self.structure).loop is not None:
                # the ideal coupling ranks; the best candidates carry the loop the rig emulates
                order = np.argsort(self._score(pred, w), axis=None, kind="stable")[:int(self.rescore)]
                picks = np.array(np.unravel_index(order, pred.m_eff.shape)).T
                pred = rescore_loop(self.robot, ik.q, self.model, list(self.lambdas), n, pred, picks, **kw)
                rescored[tuple(picks.T)] = True
            frequency = None
            if self.beam is not None:
                frequency = pose_terms(self.robot, ik.q, beam=self.beam).frequency
        else:
            terms = pose_terms(self.robot, ik.q, beam=self.beam)
            pred = predict(terms, list(self.lambdas.values()), n, mass=self.mass, speed=self.speed,
                           restitution=self.restitution, contact=contact,
                           arm=self.arm, gain_names=list(self.lambdas))
            frequency = terms.frequency
        self.point_ = p
        self.q_ = ik.q
        self.ik_residual_ = ik.residual
        self.directions_ = n
        self.gain_classes_ = list(self.lambdas)
        self.predictions_ = pred
        self.rescored_ = rescored
        self.frequency_ = frequency
        self.score_ = self._score(pred, w)
        order = np.argsort(self.score_, axis=None, kind="stable")
        self.ranking_ = np.array(np.unravel_index(order, self.score_.shape)).T   # rows (pose, gain, dir)
        return self

    def _score(self, pred: Predictions, w: np.ndarray) -> np.ndarray:
        if self.objective == "impulse":
            return pred.impulse.copy()
        if self.objective == "force":
            return pred.peak_force.copy()
        if self.objective == "displacement":
            return pred.structure_peak.copy()
        parts = [pred.impulse, pred.peak_force] + ([pred.structure_peak] if pred.structure_peak is not None else [])
        score = np.zeros(pred.impulse.shape)
        for wk, x in zip(w[:len(parts)], parts, strict=True):     # a fixed base: no displacement term
            top = float(np.max(x))
            if top > 0:
                score += wk * x / top
        return score

    def rows(self) -> list[dict]:
        """The ranked candidates as JSON-safe dicts (best first)."""
        if not hasattr(self, "ranking_"):
            raise InputError("this ImpactPlanner is not fitted yet; call fit(point, directions) first")
        P = self.predictions_
        out = []
        for rank, (i, g, d) in enumerate(self.ranking_, start=1):
            m = float(P.m_eff[i, g, d])
            row = {
                "rank": rank, "branch": int(i) + 1, "q_dh_deg": np.degrees(self.q_[i]).tolist(),
                "gain_class": self.gain_classes_[g], "direction": self.directions_[d].tolist(),
                "m_eff": m if math.isfinite(m) else None, "m_eff_is_infinite": not math.isfinite(m),
                "impulse": float(P.impulse[i, g, d]), "peak_force": float(P.peak_force[i, g, d]),
                "tip_velocity": float(P.tip_velocity[i, g, d]), "dq": P.dq[i, g, d].tolist(),
                "score": float(self.score_[i, g, d]),
                "contact_duration": float(P.contact_duration[i, g, d]),
            }
            if P.structure_peak is not None and self.rescored_ is not None:
                row["coupling"] = "loop" if self.rescored_[i, g, d] else "ideal"
            if P.compression_mass is not None:
                row["compression_mass"] = float(P.compression_mass[i, g, d])
            if P.structure_peak is not None:
                row.update(base_velocity=P.base_velocity[i, g, d].tolist(),
                           base_momentum=float(P.base_momentum[i, g, d]),
                           structure_peak=float(P.structure_peak[i, g, d]))
                if P.structure_peak_release is not None:
                    row["structure_peak_release"] = float(P.structure_peak_release[i, g, d])
            out.append(row)
        return out
