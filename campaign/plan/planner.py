"""The impact planner: where and how the arm should meet a moving object (paper, section 2).

The paper proposes the Ex-IIT for planning: choose the configuration that reduces the
impact force, and use the effective mass as an index of the supporting structure's
vibration. For every pose that reaches a contact point (:func:`campaign.model.robot.ik.position_branches`),
every gain class (its Virtual Rotor Inertia lambda) and every allowed impact direction
``n`` (the direction of the force on the arm; the object moves along ``n`` at speed
``v_b``, the arm is at rest), this module predicts:

* ``m*`` along ``n``: eq 7 on a fixed base, eq 8 on the flexible base (eq 11);
* the contact impulse ``I`` (eq 14 with ``v_a = 0``);
* the arm's post-impact joint velocities ``dq = (H + lambda)^-1 J^T n I`` (eq 5 and 13; on
  the flexible base with the generalised ``J*`` and ``H*`` of eq 8);
* the contact's duration and the peak contact force of the rig's contact law between two
  free bodies of reduced mass ``m* m_b / (m* + m_b)``
  (:meth:`campaign.rig.contact.Contact.peak_force`); given the arm's servo and friction
  (``arm``), on the fixed base the peak force takes the arm's apparent mass over the
  compression instead of m* (:mod:`campaign.plan.compression`: the force peaks before the
  servo has built up the resistance lambda averages over the whole contact);
* on the flexible base, the base's velocity change (the free base of eq 8 under the
  impulse), the momentum of the structure's tip body, and the predicted peak base
  displacement: the structure's first bending pair released with eq 8's base velocity
  change, or (given ``arm``) the linearised arm on the structure driven by the contact's
  force pulse and followed until the structure's peak (:mod:`campaign.plan.post_contact`).

Everything per pose is one Pinocchio pass (:func:`pose_terms`); the rest is NumPy over the
(pose, gain, direction) axes (:func:`predict`). :class:`ImpactPlanner` wraps the search and
ranks the candidates by an objective.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np
import pinocchio as pin

from ..core.errors import InputError, SimulationError
from ..model.exiit import RANGE_RTOL, impulse, lambda_matrix
from ..model.robot import Robot
from ..model.robot.floating import attach_to_floating_base
from ..model.robot.ik import position_branches, position_branches_many
from ..rig.contact import Contact, pulse_shape
from .compression import compression_mass
from .post_contact import peak_displacement, pulse_peak_displacement, unit_responses

__all__ = ["PoseTerms", "Predictions", "pose_terms", "predict", "ImpactPlanner", "OBJECTIVES",
           "horizontal_directions", "cone_directions", "peak_amplitude_factor", "check_object",
           "workspace_map", "direction_map"]

#: quantities a plan can be ranked by (minimised)
OBJECTIVES = ("impulse", "force", "displacement", "weighted")


@dataclasses.dataclass(frozen=True)
class PoseTerms:
    """What the predictions need of each pose, from one Pinocchio pass (shapes lead with N poses).

    Attributes
    ----------
    q : (N, nv) DH angles [rad].
    H : (N, nv, nv) joint-space inertia with the reflected rotor inertia (fixed base), or
        ``H*`` of eq 8 (flexible base) [kg m^2].
    J : (N, 3, nv) linear rows of the impact-point Jacobian, or ``J*`` of eq 8.
    G_base : (N, 3, 3) or None; the base term ``[R_gh M^-1 R_gh^T]_33`` of eq 8 [1/kg].
    base_from_impulse : (N, 6, 3) or None; ``M_b^-1 J_b^T``: base twist change per unit
        impulse vector with the arm's joints held [m/s/(N s)].
    base_from_dq : (N, 6, nv) or None; ``M_b^-1 H_bm``: base twist change per arm joint
        velocity (subtracted).
    modal_velocity : (N, 2, 6) or None; ``phi_i^T M_b``: velocity of the first bending pair's
        modal coordinates per base twist [sqrt(kg)].
    modal_disp : (N, 2, 3) or None; ``phi_i[:3] * g(zeta) / omega_i``: peak translation of
        the base per unit modal velocity [m / (sqrt(kg) m/s)].
    frequency : (N, 2) or None; the pair's frequencies with the arm (locked) on top [Hz].
    structure_mass : (6, 6) or None; the structure's tip body alone (beam share + platform).
    M_full : (N, 6 + nv, 6 + nv) or None; the arm on its free base (CRBA): ``[[M_b, H_bm], [H_bm^T, H_m]]``.
    gravity_stiffness : (N, 6 + nv, 6 + nv) or None; ``dG/dq`` of the gravity forces on the arm
        and its free base per unit gravity [per m/s^2] (the post-contact term,
        :mod:`campaign.plan.post_contact`).
    structure_stiffness, structure_damping : (6, 6) or None; the structure's ``K_s`` and ``B_s``.
    """

    q: np.ndarray
    H: np.ndarray
    J: np.ndarray
    G_base: np.ndarray | None = None
    base_from_impulse: np.ndarray | None = None
    base_from_dq: np.ndarray | None = None
    modal_velocity: np.ndarray | None = None
    modal_disp: np.ndarray | None = None
    frequency: np.ndarray | None = None
    structure_mass: np.ndarray | None = None
    M_full: np.ndarray | None = None
    gravity_stiffness: np.ndarray | None = None
    structure_stiffness: np.ndarray | None = None
    structure_damping: np.ndarray | None = None

    @property
    def flexible(self) -> bool:
        return self.G_base is not None


def peak_amplitude_factor(zeta: float) -> float:
    """First peak of ``x = (1/omega_d) e^(-zeta omega t) sin(omega_d t)`` times ``omega`` [1].

    A damped mode released with unit velocity peaks when ``tan(omega_d t) = sqrt(1-zeta^2)/zeta``,
    at ``(1/omega) exp(-zeta/sqrt(1-zeta^2) * atan(sqrt(1-zeta^2)/zeta))``; 1 without damping.
    """
    if zeta <= 0.0:
        return 1.0
    s = math.sqrt(1.0 - zeta * zeta)
    return math.exp(-zeta / s * math.atan2(s, zeta))


def _skew_batch(r: np.ndarray) -> np.ndarray:
    S = np.zeros(r.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -r[..., 2], r[..., 1]
    S[..., 1, 0], S[..., 1, 2] = r[..., 2], -r[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -r[..., 1], r[..., 0]
    return S


def pose_terms(robot: Robot, Q, *, beam=None) -> PoseTerms:
    """One Pinocchio pass over the poses ``Q`` (N, nv) [rad]: inertia, Jacobian, eq 8's parts.

    Parameters
    ----------
    robot : Robot
    Q : array_like, shape (N, nv)
    beam : campaign.rig.beam.Beam, optional
        The flexible structure; None for a fixed base. The arm stands on its emulated base
        body (:meth:`~campaign.rig.beam.Beam.base_body`) as a free-flyer model (eq 8: in
        the impulsive phase the spring and damper transmit nothing).
    """
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    nv = robot.nv
    if Q.ndim != 2 or Q.shape[1] != nv:
        raise InputError(f"poses must have shape (N, {nv}), got {Q.shape}")
    N = Q.shape[0]
    if beam is None:
        model, data, fid = robot.model, robot.model.createData(), robot.impact_frame_id
        H = np.empty((N, nv, nv))
        J = np.empty((N, 3, nv))
        for i in range(N):
            H[i] = pin.crba(model, data, Q[i])
            J[i] = pin.computeFrameJacobian(model, data, Q[i], fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        H = np.triu(H) + np.swapaxes(np.triu(H, 1), 1, 2)
        return PoseTerms(q=Q, H=H, J=J)


    frobot = attach_to_floating_base(robot, beam.base_body())
    model, data, fid = frobot.model, frobot.model.createData(), frobot.impact_frame_id
    nb = 6
    Mfull = np.empty((N, nb + nv, nb + nv))
    Jfull = np.empty((N, 3, nb + nv))
    r_gh = np.empty((N, 3))
    w = np.empty(N)
    Hg = np.empty((N, 3, 3))
    zero_v = np.zeros(model.nv)
    for i in range(N):
        q = frobot.q_full(Q[i])
        Mfull[i] = pin.crba(model, data, q)
        Jfull[i] = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        pin.ccrba(model, data, q, zero_v)          # centroid, total mass, centroidal inertia
        w[i] = data.Ig.mass
        Hg[i] = data.Ig.inertia
        r_gh[i] = data.oMf[fid].translation - data.com[0]
    Mfull = np.triu(Mfull) + np.swapaxes(np.triu(Mfull, 1), 1, 2)
    Mb, Hbm, Hm = Mfull[:, :nb, :nb], Mfull[:, :nb, nb:], Mfull[:, nb:, nb:]
    Jb, Jm = Jfull[:, :, :nb], Jfull[:, :, nb:]
    Mb_inv_Hbm = np.linalg.solve(Mb, Hbm)
    H_star = Hm - np.swapaxes(Hbm, 1, 2) @ Mb_inv_Hbm          # eq 8: H* = H_m - H_bm^T M_b^-1 H_bm
    J_star = Jm - Jb @ Mb_inv_Hbm                               # eq 8: J* = J_m - J_b M_b^-1 H_bm
    # eq 8's base term, linear block: [R_gh M^-1 R_gh^T]_33 = E / w + [r]x H_g^-1 [r]x^T
    S = _skew_batch(r_gh)
    G_base = np.eye(3) / w[:, None, None] + S @ np.linalg.solve(Hg, np.swapaxes(S, 1, 2))
    base_from_impulse = np.linalg.solve(Mb, np.swapaxes(Jb, 1, 2))

    # structure with the arm locked on top: K phi = omega^2 M_b phi, M_b = structure + arm
    # (the free-flyer's base block is exactly that composite inertia in the tip frame)
    K = np.asarray(beam.stiffness)
    L = np.linalg.cholesky(Mb)
    Linv = np.linalg.inv(L)
    A = Linv @ K @ np.swapaxes(Linv, 1, 2)
    w2, V = np.linalg.eigh(0.5 * (A + np.swapaxes(A, 1, 2)))
    phi = np.swapaxes(Linv, 1, 2) @ V[:, :, :2]                 # mass-normalised, first pair
    omega = np.sqrt(w2[:, :2])
    modal_velocity = np.swapaxes(phi, 1, 2) @ Mb                # eta_dot = phi^T M_b dx_b
    g = peak_amplitude_factor(float(beam.damping_ratio))
    modal_disp = np.swapaxes(phi[:, :3, :], 1, 2) * (g / omega)[:, :, None]
    # the gradient of the gravity forces per unit gravity, base and joints (world z up): as the
    # arm moves, its weight's moment on the structure's tip changes, and as the tip tilts, so do
    # the gravity torques on the joints
    gmodel = pin.Model(model)
    gmodel.gravity.linear = np.array([0.0, 0.0, -1.0])
    gdata = gmodel.createData()
    dG = np.empty((N, nb + nv, nb + nv))
    for i in range(N):
        dG[i] = pin.computeGeneralizedGravityDerivatives(gmodel, gdata, frobot.q_full(Q[i]))
    return PoseTerms(q=Q, H=H_star, J=J_star, G_base=G_base, base_from_impulse=base_from_impulse,
                     base_from_dq=Mb_inv_Hbm, modal_velocity=modal_velocity, modal_disp=modal_disp,
                     frequency=omega / (2.0 * math.pi), structure_mass=np.asarray(beam.mass_matrix),
                     M_full=Mfull, gravity_stiffness=dG, structure_stiffness=K,
                     structure_damping=np.asarray(beam.damping))


@dataclasses.dataclass(frozen=True)
class Predictions:
    """Predictions over (pose, gain class, direction); arrays of shape (N, G, D[, ...]).

    Attributes
    ----------
    m_eff : effective mass along n [kg] (eq 11), ``inf`` where n leaves the range of G*_33.
    impulse : contact impulse on the arm along n [N s] (eq 14).
    dq : (N, G, D, nv) post-impact joint velocities [rad/s] (eq 13).
    tip_velocity : post-impact tip velocity along n [m/s] (eq 13).
    peak_force : peak contact force [N] (the rig's contact law).
    base_velocity : (N, G, D, 6) base twist change [m/s, rad/s] (flexible base), else None.
    base_momentum : linear momentum given to the structure's tip body [N s], else None.
    structure_peak : predicted peak base displacement [m], else None: with the arm's
        post-contact motion (:mod:`campaign.plan.post_contact`) when ``predict`` was given ``arm``,
        else ``structure_peak_release``.
    structure_peak_release : the first bending pair released with eq 8's base velocity
        change (arm locked after the impact), each mode at its first peak [m], else None.
    contact_duration : duration of the contact law's pulse at the reduced mass [s]
        (:meth:`campaign.rig.contact.Contact.duration`).
    compression_mass : the arm's apparent mass over the compression [kg] (fixed base, with
        ``arm`` and its finite contact), which then sets ``peak_force``
        (:mod:`campaign.plan.compression`), else None.
    """

    m_eff: np.ndarray
    impulse: np.ndarray
    dq: np.ndarray
    tip_velocity: np.ndarray
    peak_force: np.ndarray
    base_velocity: np.ndarray | None = None
    base_momentum: np.ndarray | None = None
    structure_peak: np.ndarray | None = None
    structure_peak_release: np.ndarray | None = None
    contact_duration: np.ndarray | None = None
    compression_mass: np.ndarray | None = None


def check_object(*, mass, speed, restitution) -> tuple[float, float, float]:
    """The object's mass [kg], speed [m/s] and the restitution, checked (InputError naming the value)."""
    out = []
    for name, value, units in (("object mass", mass, "kg"), ("object speed", speed, "m/s")):
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{name} must be a number > 0 {units}, got {value!r}") from None
        if not (math.isfinite(v) and v > 0.0):
            raise InputError(f"{name} = {value!r} {units} must be > 0")
        out.append(v)
    try:
        e = float(restitution)
    except (TypeError, ValueError):
        raise InputError(f"restitution must be a number in (0, 1], got {restitution!r}") from None
    if not (math.isfinite(e) and 0.0 < e <= 1.0):
        raise InputError(f"restitution = {restitution!r} must be in (0, 1]")
    return out[0], out[1], e


def _unit_rows(directions) -> np.ndarray:
    n = np.atleast_2d(np.asarray(directions, dtype=float))
    if n.ndim != 2 or n.shape[1] != 3 or not np.all(np.isfinite(n)):
        raise InputError(f"directions must be finite 3-vectors, got shape {np.shape(directions)}")
    norm = np.linalg.norm(n, axis=1)
    if np.any(norm == 0.0):
        i = int(np.flatnonzero(norm == 0.0)[0])
        raise InputError(f"direction {n[i].tolist()} is the zero vector")
    return n / norm[:, None]


def predict(terms: PoseTerms, lambdas, directions, *, mass: float, speed: float, restitution: float,
            contact, arm=None, gain_names=None) -> Predictions:
    """Every prediction of the planner over (pose, gain class, direction).

    Parameters
    ----------
    terms : PoseTerms
        From :func:`pose_terms` (fixed or flexible base).
    lambdas : sequence of array_like
        Virtual Rotor Inertia of each gain class (diagonal vectors or matrices) [kg m^2].
    directions : array_like, shape (D, 3)
        Impact directions n (normalised here), base frame.
    mass, speed : float
        The object's mass ``m_b`` [kg] and its speed along n ``v_b`` [m/s]; the arm is at rest.
    restitution : float
        ``e`` of eq 13-14 [1].
    contact : campaign.rig.contact.Contact
        The contact law for the peak force (its restitution should be ``restitution``).
    arm : campaign.plan.post_contact.ArmAfterImpact, optional
        The servo gains, joint friction and gravity acting on the arm during and after the
        contact. With ``arm.pulse`` the contact is the contact law's pulse: on the fixed base
        the peak force follows the arm's apparent mass over the compression
        (:mod:`campaign.plan.compression`), on the flexible base the structure's peak follows the
        arm and structure driven by the pulse (:func:`campaign.plan.post_contact.pulse_peak_displacement`);
        without it, the impulse arrives at once (lambda's m* for the force, eq 8's release with
        the arm's post-contact motion for the structure). None: lambda's m* and eq 8's
        release alone.
    gain_names : sequence of str, optional
        Names of the gain classes in ``lambdas`` (keys of ``arm.gains``); default their indices.
    """
    mass, speed, e = check_object(mass=mass, speed=speed, restitution=restitution)
    n = _unit_rows(directions)
    nv = terms.H.shape[-1]
    lam = np.stack([lambda_matrix(x, nv) for x in lambdas])            # (G, nv, nv)
    Hl = terms.H[:, None] + lam[None]                                   # (N, G, nv, nv)
    JT = np.swapaxes(terms.J, 1, 2)[:, None]                             # (N, 1, nv, 3)
    X = np.linalg.solve(Hl, np.broadcast_to(JT, Hl.shape[:2] + JT.shape[2:]))   # (H+lam)^-1 J^T
    G33 = terms.J[:, None] @ X                                           # (N, G, 3, 3)
    if terms.flexible:
        G33 = G33 + terms.G_base[:, None]
    s = np.einsum("di,ngij,dj->ngd", n, G33, n)                          # n^T G33 n
    tr = np.trace(G33, axis1=2, axis2=3)[:, :, None]
    finite = (s > RANGE_RTOL * tr) & (tr > 0.0)
    m_eff = np.full(s.shape, np.inf)
    m_eff[finite] = 1.0 / s[finite]
    imp = impulse(m_eff, mass, 0.0, speed, e)                            # eq 14, v_a = 0
    Xn = np.einsum("ngij,dj->ngdi", X, n)                                # (H+lam)^-1 J^T n
    dq = Xn * imp[..., None]                                             # eq 5/13: joint velocities
    tip_velocity = np.where(finite, s * imp, 0.0)                        # n^T J dq = I / m*
    mu = np.where(finite, mass / (1.0 + mass * s), mass)                 # m* m_b / (m* + m_b)
    peak = contact.peak_force(mu, speed)
    duration = contact.duration(mu, speed)
    kp = damping = names = None
    if arm is not None:
        names = [str(g) for g in range(lam.shape[0])] if gain_names is None else list(gain_names)
        if len(names) != lam.shape[0]:
            raise InputError(f"{len(names)} gain class names for {lam.shape[0]} lambdas")
        kp, damping, _ = arm.matrices(names, nv)
    if not terms.flexible:
        m_c = None
        if arm is not None and arm.pulse:
            # the force peaks a quarter into the contact, before the servo has built up the
            # resistance lambda averages over the whole contact (campaign.plan.compression)

            m_c, peak = compression_mass(terms.H, terms.J, n, kp, damping, contact=contact, mass=mass, speed=speed)
        return Predictions(m_eff=m_eff, impulse=imp, dq=dq, tip_velocity=tip_velocity, peak_force=peak,
                           contact_duration=duration, compression_mass=m_c)
    # the free base of eq 8 under the impulse: dv_b = M_b^-1 (J_b^T n I - H_bm dq)
    dvb = (np.einsum("nkj,dj->ndk", terms.base_from_impulse, n)[:, None] * imp[..., None]
           - np.einsum("nki,ngdi->ngdk", terms.base_from_dq, dq))
    # momentum of the structure's tip body (beam share + platform) and its first bending pair
    eta_dot = np.einsum("nmk,ngdk->ngdm", terms.modal_velocity, dvb)      # (N, G, D, 2)
    disp = np.einsum("nmi,ngdm->ngdi", terms.modal_disp, eta_dot)         # both modes at their peak
    momentum = np.linalg.norm(np.einsum("ik,ngdk->ngdi", terms.structure_mass[:3], dvb), axis=-1)
    release = np.linalg.norm(disp, axis=-1)
    peak_x = release
    if arm is not None:

        p_vec = n[None, None] * imp[..., None]
        if arm.pulse:

            # eq 14's impulse spread over the contact law's pulse, entering as a force on the
            # free arm (H*^-1 J*^T, no lambda): the servo and friction resist it explicitly
            _, shape = pulse_shape(contact.damping, float(contact.exponent))
            X_free = np.linalg.solve(terms.H, np.swapaxes(terms.J, 1, 2))[:, None]
            X_free = np.broadcast_to(X_free, X.shape)
            peak_x = pulse_peak_displacement(terms, X_free, kp, damping, p_vec, duration, shape=shape,
                                             gravity=float(arm.gravity), samples=int(arm.samples))
        else:
            R, _ = unit_responses(terms, X, kp, damping, gravity=float(arm.gravity), samples=int(arm.samples))
            peak_x = peak_displacement(R, p_vec)
        if not np.all(np.isfinite(peak_x)):
            i, g, d = (int(k[0]) for k in np.nonzero(~np.isfinite(peak_x)))
            raise SimulationError(f"post-contact response is not finite at pose {np.degrees(terms.q[i]).tolist()} "
                                  f"deg, gain class {names[g]!r}, direction {n[d].tolist()}")
    return Predictions(m_eff=m_eff, impulse=imp, dq=dq, tip_velocity=tip_velocity, peak_force=peak,
                       base_velocity=dvb, base_momentum=momentum, structure_peak=peak_x,
                       structure_peak_release=release, contact_duration=duration)


def horizontal_directions(count: int, *, start_deg: float = 180.0) -> np.ndarray:
    """``count`` horizontal unit directions evenly spaced from ``start_deg`` (from +x towards +y)."""
    if not (isinstance(count, (int, np.integer)) and count >= 1):
        raise InputError(f"number of directions must be an integer >= 1, got {count!r}")
    a = np.radians(start_deg) + 2.0 * np.pi * np.arange(count) / count
    return np.stack([np.cos(a), np.sin(a), np.zeros(count)], axis=1)


def cone_directions(axis, half_angle_deg: float, count: int) -> np.ndarray:
    """The axis and ``count - 1`` directions on the cone of ``half_angle_deg`` around it."""
    axis = _unit_rows(axis)[0]
    a = float(half_angle_deg)
    if not (math.isfinite(a) and 0.0 <= a <= 180.0):
        raise InputError(f"cone half-angle = {half_angle_deg!r} deg must be in [0, 180]")
    if not (isinstance(count, (int, np.integer)) and count >= 1):
        raise InputError(f"number of directions must be an integer >= 1, got {count!r}")
    if count == 1 or a == 0.0:
        return axis[None]
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    t = 2.0 * np.pi * np.arange(count - 1) / (count - 1)
    ring = (np.cos(np.radians(a)) * axis[None]
            + np.sin(np.radians(a)) * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v))
    return np.vstack([axis[None], ring])


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
        (:func:`predict`): the peak force (fixed base) and the structure's peak (flexible base)
        then follow the arm's resistance to the contact's pulse.
    """

    def __init__(self, robot: Robot, *, lambdas: Mapping[str, object], mass: float, speed: float,
                 restitution: float, contact_stiffness: float, contact_exponent: float, beam=None,
                 objective: str = "impulse", weights=(1.0, 1.0, 1.0), arm=None):
        self.robot = robot
        self.lambdas = dict(lambdas)
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
        for name, lam in self.lambdas.items():
            try:
                lambda_matrix(lam, self.robot.nv)
            except ValueError as exc:
                raise InputError(f"gain class {name!r}: {exc}") from None
        if self.arm is not None:
            self.arm.matrices(list(self.lambdas), self.robot.nv)     # refuses bad gains before any work
        if self.objective not in OBJECTIVES:
            raise InputError(f"objective {self.objective!r} is not one of {list(OBJECTIVES)}")
        if self.objective == "displacement" and self.beam is None:
            raise InputError("objective 'displacement' needs the flexible base (a fixed base has no structure)")
        w = np.asarray(self.weights, dtype=float)
        if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
            raise InputError(f"weights = {np.asarray(self.weights).tolist()} must be 3 values >= 0, not all zero")
        return Contact(float(self.contact_stiffness), float(self.contact_exponent), float(self.restitution)), w

    def fit(self, point, directions) -> "ImpactPlanner":
        """Find every pose reaching ``point`` [m] and predict each candidate; rank them.

        Raises InputError (before any prediction) for an unreachable point, a zero
        direction or a bad object, gain class or objective.
        """

        contact, w = self._check()
        n = _unit_rows(directions)
        p = np.asarray(point, dtype=float)
        ik = position_branches(self.robot, p)
        if ik.n_branches == 0:
            where = ", ".join(f"{x:.4g}" for x in np.ravel(p))
            if ik.reached_outside_limits:
                raise InputError(f"point ({where}) m is reached only outside the joint limits")
            raise InputError(f"point ({where}) m is out of the arm's reach")
        terms = pose_terms(self.robot, ik.q, beam=self.beam)
        pred = predict(terms, list(self.lambdas.values()), n, mass=self.mass, speed=self.speed,
                       restitution=self.restitution, contact=contact,
                       arm=self.arm, gain_names=list(self.lambdas))
        self.point_ = p
        self.q_ = ik.q
        self.ik_residual_ = ik.residual
        self.directions_ = n
        self.gain_classes_ = list(self.lambdas)
        self.predictions_ = pred
        self.frequency_ = terms.frequency
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
        for wk, x in zip(w, parts):
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
            if P.compression_mass is not None:
                row["compression_mass"] = float(P.compression_mass[i, g, d])
            if P.structure_peak is not None:
                row.update(base_velocity=P.base_velocity[i, g, d].tolist(),
                           base_momentum=float(P.base_momentum[i, g, d]),
                           structure_peak=float(P.structure_peak[i, g, d]),
                           structure_peak_release=float(P.structure_peak_release[i, g, d]))
            out.append(row)
        return out


def workspace_map(robot: Robot, *, lambdas: Mapping[str, object], contact, mass: float, speed: float,
                  restitution: float, direction, y: float, x_range=(-1.0, 1.0), z_range=(-1.0, 1.0),
                  resolution: float = 0.05, beam=None, arm=None) -> dict:
    """m* (eq 7) and, on a flexible base, the structure's peak displacement over a vertical plane.

    The plane ``y = const`` of the arm's base frame is sampled every ``resolution`` metres;
    at each point every IK branch is evaluated, and the best (smallest) and worst branch of
    each quantity are kept per gain class. Unreachable points hold NaN (they are masked in
    the figures, never stored as numbers). ``arm``: the post-contact term of the structure's
    peak (:func:`predict`).

    Returns
    -------
    dict
        ``x``, ``z`` [m] (grid axes), ``n_branches`` (nz, nx), ``gain_classes``; per quantity
        ``m_eff`` (fixed base, eq 7) and, with ``beam``, ``m_eff_flexible`` (eq 8) and
        ``structure_peak`` [m]: ``<q>_best`` and ``<q>_worst`` of shape (G, nz, nx).
    """

    res = float(resolution)
    if not (math.isfinite(res) and res > 0):
        raise InputError(f"map resolution = {resolution!r} m must be > 0")
    x = np.arange(x_range[0], x_range[1] + 0.5 * res, res)
    z = np.arange(z_range[0], z_range[1] + 0.5 * res, res)
    if x.size < 2 or z.size < 2:
        raise InputError(f"map range x {list(x_range)}, z {list(z_range)} m holds fewer than 2 points per axis")
    n = _unit_rows(direction)
    names = list(lambdas)
    lams = [lambdas[k] for k in names]
    G = len(names)
    nb = np.zeros((z.size, x.size), dtype=int)
    owner, Q = [], []
    ZZ, XX = np.meshgrid(z, x, indexing="ij")
    points = np.stack([XX.ravel(), np.full(XX.size, float(y)), ZZ.ravel()], axis=1)
    for k, ik in enumerate(position_branches_many(robot, points)):
        iz, ix = divmod(k, x.size)
        nb[iz, ix] = ik.n_branches
        for q in ik.q:
            owner.append((iz, ix))
            Q.append(q)
    out = {"x": x, "z": z, "y": float(y), "n_branches": nb, "gain_classes": names, "direction": n[0]}
    if not Q:
        raise InputError(f"no point of the plane y = {y:g} m within x {list(x_range)}, z {list(z_range)} m "
                         "is reachable")
    Q = np.array(Q)
    owner = np.array(owner)
    quantities = {"m_eff": predict(pose_terms(robot, Q), lams, n, mass=mass, speed=speed,
                                   restitution=restitution, contact=contact).m_eff[:, :, 0]}
    if beam is not None:
        P = predict(pose_terms(robot, Q, beam=beam), lams, n, mass=mass, speed=speed, restitution=restitution,
                    contact=contact, arm=arm, gain_names=names)
        quantities["m_eff_flexible"] = P.m_eff[:, :, 0]
        quantities["structure_peak"] = P.structure_peak[:, :, 0]
    for name, vals in quantities.items():
        best = np.full((G, z.size, x.size), np.inf)
        worst = np.full((G, z.size, x.size), -np.inf)
        for g in range(G):
            np.minimum.at(best[g], (owner[:, 0], owner[:, 1]), vals[:, g])
            np.maximum.at(worst[g], (owner[:, 0], owner[:, 1]), vals[:, g])
        best[:, nb == 0] = np.nan
        worst[:, nb == 0] = np.nan
        out[f"{name}_best"], out[f"{name}_worst"] = best, worst
    return out


def direction_map(robot: Robot, q, *, lambdas: Mapping[str, object], contact, mass: float, speed: float,
                  restitution: float, count: int = 72, beam=None, arm=None) -> dict:
    """m* and the structure's peak displacement against the horizontal impact direction at a pose
    (``arm``: the post-contact term of the structure's peak, :func:`predict`).

    Returns
    -------
    dict
        ``azimuth`` [rad] (from +x towards +y, ``count`` values), ``gain_classes``,
        ``m_eff`` (G, count) on the fixed base (eq 7); with ``beam`` also ``m_eff_flexible``
        (eq 8) and ``structure_peak`` [m].
    """
    q = np.asarray(q, dtype=float)
    n = horizontal_directions(count, start_deg=0.0)
    names = list(lambdas)
    lams = [lambdas[k] for k in names]
    kw = dict(mass=mass, speed=speed, restitution=restitution, contact=contact)
    out = {"azimuth": np.arctan2(n[:, 1], n[:, 0]) % (2 * np.pi), "gain_classes": names, "q": q,
           "m_eff": predict(pose_terms(robot, q[None]), lams, n, **kw).m_eff[0]}
    if beam is not None:
        P = predict(pose_terms(robot, q[None], beam=beam), lams, n, **kw, arm=arm, gain_names=names)
        out["m_eff_flexible"] = P.m_eff[0]
        out["structure_peak"] = P.structure_peak[0]
    return out
