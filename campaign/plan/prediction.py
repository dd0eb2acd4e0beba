"""The impact planner's predictions over (pose, gain class, impact direction) (paper, section 2).

For every pose that reaches a contact point (:func:`campaign.model.robot.ik.position_branches`),
every gain class (its Virtual Rotor Inertia lambda) and every allowed impact direction
``n`` (the direction of the force on the arm; the object moves along ``n`` at speed
``v_b``, the arm is at rest), this module predicts:

* ``m*`` along ``n``: eq 7 on a fixed base, eq 8 on the flexible base (eq 11);
* the contact impulse ``I`` (eq 14 with ``v_a = 0``);
* the arm's post-impact joint velocities ``dq = (H + lambda)^-1 J^T n I`` (eq 5 and 13; on
  the flexible base with the generalised ``J*`` and ``H*`` of eq 8);
* the contact's duration and the peak contact force of the rig's contact law between two
  free bodies of reduced mass ``m* m_b / (m* + m_b)``
  (:meth:`campaign.rig.contact.ContactLaw.peak_force`); given the arm's servo and friction
  (``arm``), on the fixed base the peak force takes the arm's apparent mass over the
  compression instead of m* (:mod:`campaign.plan.compression`: the force peaks before the
  servo has built up the resistance lambda averages over the whole contact);
* on the flexible base, the base's velocity change (the free base of eq 8 under the
  impulse), the momentum of the structure's tip body, and the predicted peak base
  displacement: the structure's first bending pair released with eq 8's base velocity
  change, or (given ``arm``) the linearised arm on the structure driven by the contact's
  force pulse and followed until the structure's peak (:mod:`campaign.plan.post_contact`).

Everything per pose is one Pinocchio pass (:func:`pose_terms`); the rest is NumPy over the
(pose, gain, direction) axes (:func:`predict`). :class:`campaign.plan.planner.ImpactPlanner`
ranks the candidates by an objective.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from ..core.errors import InputError, SimulationError
from ..model.exiit import RANGE_RTOL, impulse, lambda_matrix
from ..model.robot import Robot
from ..model.robot.floating import attach_to_floating_base
from ..rig.contact import pulse_shape
from .compression import compression_mass
from .directions import unit_directions
from .post_contact import peak_displacement, pulse_peak_displacement, unit_responses

__all__ = ["PoseTerms", "Predictions", "pose_terms", "predict", "peak_amplitude_factor", "check_object"]


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
        (:meth:`campaign.rig.contact.ContactLaw.duration`).
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
    contact : campaign.rig.contact.ContactLaw
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
    n = unit_directions(directions)
    nv = terms.H.shape[-1]
    lam = np.stack([lambda_matrix(x, nv) for x in lambdas])            # (G, nv, nv)
    X, s, finite, m_eff = _effective_mass(terms, lam, n)
    imp = impulse(m_eff, mass, 0.0, speed, e)                            # eq 14, v_a = 0
    Xn = np.einsum("ngij,dj->ngdi", X, n)                                # (H+lam)^-1 J^T n
    dq = Xn * imp[..., None]                                             # eq 5/13: joint velocities
    tip_velocity = np.where(finite, s * imp, 0.0)                        # n^T J dq = I / m*
    mu = np.where(finite, mass / (1.0 + mass * s), mass)                 # m* m_b / (m* + m_b)
    peak = contact.peak_force(mu, speed)
    duration = contact.duration(mu, speed)
    kp = damping = names = None
    if arm is not None:
        kp, damping, names = _servo(arm, gain_names, lam.shape[0], nv)
    if not terms.flexible:
        m_c = None
        if arm is not None and arm.pulse:
            # the force peaks a quarter into the contact, before the servo has built up the
            # resistance lambda averages over the whole contact (campaign.plan.compression)
            m_c, peak = compression_mass(terms.H, terms.J, n, kp, damping, contact=contact, mass=mass, speed=speed)
        return Predictions(m_eff=m_eff, impulse=imp, dq=dq, tip_velocity=tip_velocity, peak_force=peak,
                           contact_duration=duration, compression_mass=m_c)
    dvb, momentum, release = _base_release(terms, n, imp, dq)
    peak_x = release
    if arm is not None:
        peak_x = _structure_peak(terms, X, kp, damping, n, imp, duration, contact=contact, arm=arm, names=names)
    return Predictions(m_eff=m_eff, impulse=imp, dq=dq, tip_velocity=tip_velocity, peak_force=peak,
                       base_velocity=dvb, base_momentum=momentum, structure_peak=peak_x,
                       structure_peak_release=release, contact_duration=duration)


def _effective_mass(terms: PoseTerms, lam: np.ndarray, n: np.ndarray):
    """Eq 7 (fixed base) or eq 8 (flexible base) along each direction, with eq 11's lambda.

    Returns ``X = (H + lambda)^-1 J^T`` (N, G, nv, 3), ``s = n^T G33 n`` (N, G, D) [1/kg],
    where n is in the range of ``G33`` (``finite``, (N, G, D) bool) and ``m* = 1/s`` there,
    ``inf`` elsewhere [kg].
    """
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
    return X, s, finite, m_eff


def _servo(arm, gain_names, n_gains: int, nv: int):
    """``arm``'s proportional gains ``K_p`` and damping ``K_d + B_v`` per gain class, (G, nv)
    each (:meth:`campaign.plan.post_contact.ArmAfterImpact.matrices`), and the gain classes'
    names (default their indices)."""
    names = [str(g) for g in range(n_gains)] if gain_names is None else list(gain_names)
    if len(names) != n_gains:
        raise InputError(f"{len(names)} gain class names for {n_gains} lambdas")
    kp, damping, _ = arm.matrices(names, nv)
    return kp, damping, names


def _base_release(terms: PoseTerms, n: np.ndarray, imp: np.ndarray, dq: np.ndarray):
    """The free base of eq 8 under the impulse: its twist change ``dv_b`` (N, G, D, 6), the
    momentum given to the structure's tip body [N s] and the structure's first bending pair
    released with ``dv_b``, each mode at its first peak [m]."""
    # dv_b = M_b^-1 (J_b^T n I - H_bm dq)
    dvb = (np.einsum("nkj,dj->ndk", terms.base_from_impulse, n)[:, None] * imp[..., None]
           - np.einsum("nki,ngdi->ngdk", terms.base_from_dq, dq))
    # momentum of the structure's tip body (beam share + platform) and its first bending pair
    eta_dot = np.einsum("nmk,ngdk->ngdm", terms.modal_velocity, dvb)      # (N, G, D, 2)
    disp = np.einsum("nmi,ngdm->ngdi", terms.modal_disp, eta_dot)         # both modes at their peak
    momentum = np.linalg.norm(np.einsum("ik,ngdk->ngdi", terms.structure_mass[:3], dvb), axis=-1)
    release = np.linalg.norm(disp, axis=-1)
    return dvb, momentum, release


def _structure_peak(terms: PoseTerms, X, kp, damping, n, imp, duration, *, contact, arm, names) -> np.ndarray:
    """The structure's peak displacement [m] with the arm's servo, friction and gravity
    (:mod:`campaign.plan.post_contact`): under the contact law's pulse with ``arm.pulse``,
    else released with eq 8's velocities; SimulationError where it is not finite."""
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
    return peak_x
