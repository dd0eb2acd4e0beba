"""The planner's predictions from a fitted response model instead of a lambda.

With a model (:class:`campaign.joints.impedance_model.JointImpedance`, by default the shipped
``config/response_model.json``) every (pose, gain set, direction) candidate is the arm's
response to the contact law's pulse (:func:`campaign.joints.response.respond`): m* as eq 10
measures it, the joints' velocities and the contact's duration at the contact's end, and on
the flexible base the structure's tip twist then and its peak displacement over one
first-mode period, the arm ideally coupled to the structure (``coupling="loop"`` follows the
rig's VES-II emulation instead, at about four times the cost; :func:`rescore_loop` predicts
chosen candidates again through it, as the planner does for its best). The impulse is eq 14
with that m*; the peak force is the contact law's at the arm's apparent mass over the
compression (:mod:`campaign.plan.compression`, with the model's joint damping) on the fixed
base, at the reduced mass of m* on the flexible base.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.errors import InputError
from ..joints.terms import arm_terms
from ..model.exiit import impulse as eq14
from .compression import compression_mass
from .directions import unit_directions
from .prediction import Predictions, check_object

__all__ = ["predict_model", "rescore_loop"]


def predict_model(robot, Q, model, gains, directions, *, mass: float, speed: float, restitution: float, contact,
                  flexible: bool, structure: str | None = None, pendulum: bool = True,
                  coupling: str = "ideal") -> Predictions:
    """Every prediction over (pose, gain set, direction) from ``model``.

    Parameters
    ----------
    robot : Robot
    Q : array_like, shape (N, nv)
        DH poses [rad].
    model : JointImpedance
        A fitted response model (its setting: the rig's servo, contact law, structures).
    gains : sequence of str
        Gain sets of the paper's Table 1.
    directions : array_like, shape (D, 3)
        Impact directions n.
    mass, speed, restitution : float
        The object's mass [kg] and speed [m/s]; eq 14's restitution.
    contact : campaign.rig.contact.ContactLaw
    flexible : bool
        On the flexible base (the model's named ``structure``, default the rig file's).
    pendulum : bool
        The object is the rig's pendulum hammer (eq 10 counts its gravity's impulse).
    coupling : {"ideal", "loop"}
        The arm on the structure itself (default: what an impact on a real structure meets,
        and a quarter of the loop's cost), or through the rig's VES-II loop.
    """
    if not hasattr(model, "respond_terms"):
        raise InputError(f"a {model.kind!r} model has no contact response; the planner needs a joint_impedance model "
                         "(or plan with --lambda / --fit)")
    mass, speed, e = check_object(mass=mass, speed=speed, restitution=restitution)
    n = unit_directions(directions)
    gains = [str(g) for g in gains]
    Q = np.atleast_2d(np.asarray(Q, float))
    N, G, D = Q.shape[0], len(gains), n.shape[0]
    setting = model.setting_for(structure)
    terms = arm_terms(robot, Q, beam=setting.beam if flexible else None)
    cases = terms.take(np.repeat(np.arange(N), G))
    r = model.respond_terms(cases, gains * N, n, speed=speed, mass=mass, pendulum=pendulum, window=flexible,
                            structure=structure, restitution=e, coupling=coupling if flexible else None)
    shape = (N, G, D)
    out = _quantities(r, shape, setting, mass=mass, speed=speed, e=e, contact=contact, flexible=flexible)
    if not flexible:
        kp, kd = setting.servo(gains)
        damping = kd + np.asarray(model.damping_, float)[None]
        out["compression_mass"], out["peak_force"] = compression_mass(terms.H, terms.J, n, kp, damping,
                                                                      contact=contact, mass=mass, speed=speed)
    return Predictions(**out)


def _quantities(r, shape, setting, *, mass, speed, e, contact, flexible) -> dict:
    """The planner's quantities of a response reshaped to ``shape`` (the flexible base's peak
    force at the reduced mass of m*)."""
    m_eff = r.m_eff.reshape(shape)
    finite = np.isfinite(m_eff)
    mu = np.where(finite, m_eff * mass / np.where(finite, m_eff + mass, 1.0), mass)
    out = dict(m_eff=m_eff, impulse=eq14(m_eff, mass, 0.0, speed, e), dq=r.dq.reshape(shape + (-1,)),
               tip_velocity=r.tip_velocity.reshape(shape), peak_force=contact.peak_force(mu, speed),
               contact_duration=r.duration.reshape(shape), compression_mass=None)
    if flexible:
        twist = r.base_velocity.reshape(shape + (6,))
        out.update(base_velocity=twist,
                   base_momentum=np.linalg.norm(np.einsum("ik,...k->...i", setting.beam.mass_matrix[:3], twist), axis=-1),
                   structure_peak=r.base_peak.reshape(shape))
    return out


def rescore_loop(robot, Q, model, gains, directions, pred: Predictions, picks, *, mass: float, speed: float,
                 restitution: float, contact, structure: str | None = None, pendulum: bool = True) -> Predictions:
    """``pred`` (flexible base, ideally coupled) with the candidates ``picks`` predicted again
    through the rig's VES-II loop, every other candidate as it was.

    Parameters
    ----------
    robot, Q, model, gains, directions, mass, speed, restitution, contact, structure, pendulum
        As :func:`predict_model` was given them for ``pred``.
    pred : Predictions
        :func:`predict_model`'s flexible-base predictions over (pose, gain set, direction).
    picks : array_like of int, shape (K, 3)
        The (pose, gain set, direction) indices to predict through the loop.
    """
    picks = np.asarray(picks, int).reshape(-1, 3)
    if picks.shape[0] == 0:
        return pred
    mass, speed, e = check_object(mass=mass, speed=speed, restitution=restitution)
    n = unit_directions(directions)
    gains = [str(g) for g in gains]
    setting = model.setting_for(structure)
    if setting.loop is None:
        raise InputError("the rig file has no VES-II loop (ves.mode) to rescore the candidates through")
    Q = np.atleast_2d(np.asarray(Q, float))
    # one case per (pose, gain set), its picked directions the variants (padded with its last)
    cases, slot = np.unique(picks[:, :2], axis=0, return_inverse=True)
    slot = slot.ravel()
    col = np.zeros(picks.shape[0], int)
    for c in range(cases.shape[0]):
        col[slot == c] = np.arange(np.count_nonzero(slot == c))
    dirs = np.empty((cases.shape[0], int(col.max()) + 1, 3))
    dirs[:] = n[picks[:, 2]][[np.flatnonzero(slot == c)[-1] for c in range(cases.shape[0])]][:, None, :]
    dirs[slot, col] = n[picks[:, 2]]
    terms = arm_terms(robot, Q[cases[:, 0]], beam=setting.beam)
    r = model.respond_terms(terms, [gains[g] for g in cases[:, 1]], dirs, speed=speed, mass=mass, pendulum=pendulum,
                            window=True, structure=structure, restitution=e, coupling="loop")
    r = dataclasses.replace(r, **{f.name: getattr(r, f.name)[slot, col] for f in dataclasses.fields(r)
                                  if getattr(r, f.name) is not None})
    new = _quantities(r, (picks.shape[0],), setting, mass=mass, speed=speed, e=e, contact=contact, flexible=True)
    fields = {}
    at = tuple(picks.T)
    for name, value in new.items():
        old = getattr(pred, name)
        if value is None or old is None:
            continue
        arr = np.array(old, copy=True)
        arr[at] = value
        fields[name] = arr
    return dataclasses.replace(pred, **fields)
