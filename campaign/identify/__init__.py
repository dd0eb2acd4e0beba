"""Per-trial identification: effective mass m* (eq 10, or eq 11's impulsive limit) and restitution e (eq 12).

Identification reads only a trial's ``measured`` group (never ``truth``), exactly as a
real VES-II allows (paper section 3, design brief section 5):

1. **Contact interval** from the piezo force ``f_piezo``. The baseline and noise level
   come from the record itself (median and MAD, refined on the samples within 5 sigma);
   the threshold is ``max(k_sigma * sigma, force_floor, force_floor_rel * peak)``
   (default 8 sigma, 0.5 N, 2 % of the peak). Runs above the threshold closer than
   ``merge_gap`` (2 ms) are one contact. Each edge is refined by a power law
   ``c |t - t0|^p`` fitted to the edge samples from ``edge_low_sigma`` (3) noise levels up
   to ``edge_fit_level`` (4x) the threshold (``edge_model="power"``; the contact law is
   ``F ~ delta^p`` with p < 1, so a straight line on those samples, ``edge_model="line"``,
   lands 0.5-0.65 ms after the true end -- 3-7 % of v'_a at High gains, where the tip
   decelerates through the contact end; the power law: both edges within 0.15 ms). The
   impulse is the trapezoid integral of the baseline-corrected force over the refined
   interval (edge triangles included).
2. **Hammer velocities** ``v_b``, ``v'_b`` from the pendulum encoder, by the free
   pendulum's equation of motion ``theta'' = -w^2 sin(theta)`` (``pendulum_model="ode"``):
   written as ``theta(t) = a + b (t - t_edge) - w^2 S2(t)``, ``S2`` the double time integral
   of ``sin`` of the measured angle, it is linear in ``a, b, w^2`` (``w`` is not needed from
   the rig) and exact over the whole free swing, so the one-sided windows can be long:
   ``pendulum_pre_window`` (150 ms) ending and ``pendulum_post_window`` (90 ms, the brake
   catches the hammer 100 ms after the contact; a count held for ``pendulum_stop_time``,
   5 ms, ends the window anyway) starting ``pendulum_guard`` (1 ms) from the edge;
   ``v = r theta' cos(theta)`` (the schema's hammer velocity along n). The previous cubic on
   50 ms (``pendulum_model="poly"``) left the 16-bit encoder's quantisation in the
   velocities: worst 3.5 / 5.9 mm/s on v_b / v'_b over the 1 kHz sweep, e worst 1.17 %;
   the ODE fit: 0.18 / 0.23 mm/s, e worst 0.1 %.
3. **Arm tip velocities** ``v_a``, ``v'_a``, by one of two methods (``arm_velocity``):

   **F/T momentum** (``"ft"``). The base F/T sensor (``ft_force``, ``ft_torque``, 1 kHz,
   about the base origin) reads ``W = C + G - dh/dt``: the contact wrench ``C`` (piezo force
   along n at the impact point), the arm's gravity wrench ``G`` and the rate of the arm's
   spatial momentum ``h = A(q) v`` about the base origin (link inertias; the armature is a
   joint-space term the mounting does not see). So ``h(t)`` is integrated on the F/T clock
   from the pre-contact state (encoder line over the pre window: ``q_s``, ``qdot_s``):
   ``dh = n dI + (p x n) dI + (c(q) - c(q_s)) x m g dt - (W - W_rest) dt``, ``dI`` the piezo
   impulse increment, ``W_rest`` the mean reading before the contact (``ft_rest_window``
   up to ``ft_guard`` before it; its force is ``m g``, so gravity's size comes from the
   sensor), ``c`` the arm's centre of mass. The servo torques (``tau_cmd``) are held between
   ticks and step the reading by ``-A H^-1 dtau`` at each tick: that part is integrated
   exactly, the rest by trapezoids (a plain trapezoid is off by 1-3 % of h at High gains).
   At every F/T sample ``v`` is the weighted least-squares solution of ``A(q) v = h``
   (``ft_rows``: all six rows by default, each weighted by its measured noise; ``q`` is
   advanced with ``v``, Adams-Bashforth 2, since the gravity moment is 10-20 % of the
   angular momentum at the contact end), the tip velocity ``n . J v``, interpolated at
   the contact end. The force rows alone are noise-limited (0.2 N over 70 samples is
   1.7e-3 N s against 0.05-0.7 N s of arm momentum): m* worst 4-10 %; the moment rows are
   10x quieter but carry the gravity model; all six rows: see :data:`ACCURACY_NOTE`.
   ``m*`` then depends only on the F/T, the piezo and the model (the encoders give the
   configuration and ``v_a``). Falls back to the encoders, recording why in
   ``arm_velocity_note``, when the trial has no F/T channels, the F/T force does not
   respond to the contact (e.g. a channel of zeros), the contact spans fewer than
   ``ft_min_samples`` (20) F/T samples (the ideal scene's 1 ms contact), the record does not
   cover the contact, or the base is flexible: there the sensor rides on the accelerating
   platform, and its reading holds the platform's inertial wrench on the arm, which the
   platform pose channels would have to give by double differentiation; that is not
   built, flexible trials keep the encoder method below (not measured with F/T).
   **Combined** (``"combined"``, not the default): ``v'_a - v_a`` from the encoders and
   from the F/T weighted by their variances (the encoder fit's residual scatter; the F/T
   rest-window noise integrated over the contact). At 1 kHz with the 40 ms post window it
   about equals the encoders (High worst 1.40 % against 1.44 %: the F/T variance is the larger);
   with 20 ms it cut High's 90th percentile 0.81 -> 0.67 %, worst 3.06 -> 2.78 %.
   ``"auto"`` (default) uses the F/T when the joint samples are coarser than
   ``auto_joint_interval`` (5 ms) and the encoders otherwise: chosen when the encoder
   method was the tip-space ``lti`` model (50 Hz High worst 6.1 % against the F/T's 2.7 %;
   the encoders win at 1 kHz, every gain). With the joint-dynamics model the encoders
   (2.0 %) and ``"combined"`` (1.9 %) beat the F/T at 50 Hz too (:data:`ACCURACY_NOTE`);
   ``auto`` is unchanged so far.

   **Joint encoders** (``"encoders"``), default model ``arm_model="joint"`` when the joint
   samples are at most ``auto_joint_interval`` (5 ms) apart, else ``"lti"`` (the comment in
   :func:`identify_trial` says why, and what that choice rests on): the joint
   samples of a pre-contact window (``joint_pre_window``, 0.2 s), the contact and a
   post-contact window ``max(joint_model_post_min, joint_post_samples / rate)`` (60 ms at
   1 kHz, 0.1 s = 5 samples at 50 Hz) are fitted, each joint weighted by its encoder
   resolution, with the arm's linearised joint-space dynamics
   ``M x'' = dtau_cmd - G x - k_B B x' + f(t) w - c(sign x')`` driven by the *measured*
   servo torque ``tau_cmd`` (a measured channel: the controller output the drives apply)
   and the measured force shape; unknown: one generalised impulse per joint ``w`` (the
   impact response's direction in joint space is measured, not the model's), a scale of
   the drive file's viscous friction (``k_B``), a Coulomb torque per joint and direction
   of motion, the pre-contact pose and velocities (details: :func:`_joint_dynamics_fit`). ``v'_a = n . J(q_e) qd(t_e)``.
   Why: at High gains the servo and the friction take back most of the impulse within the
   contact (configuration 2 at 1.0 m/s: the impulse alone would give the tip 57 mm/s, the
   servo -17.5, viscous -15, Coulomb -8, net 15.6), so the net v'_a - v_a is a small
   difference, and the tip-space model below, which has to guess the servo (a spring-
   damper on the tip) and reads one tip series mixing three joints' quantisation noise,
   missed 1 % at the smallest tip motions (1.53 %). With the servo's torque measured, the
   remaining unknowns are few and smooth; the model explains the servo's reversal of the
   tip after the contact, so the post window can be longer (60 ms: 40 ms left more noise,
   80 ms more Coulomb-sign switching). Noise-free encoders: v'_a - v_a within 0.41 % over
   the 1 kHz sweep. It falls back to ``lti`` without a usable ``tau_cmd`` or on a flexible
   base (the platform's acceleration would enter the joint dynamics; not built).

   ``arm_model="lti"`` (the default before; kept for comparison and as the fallback): the
   impact point's position along n, ``s(t) = n . p(q(t))`` (forward kinematics of each
   sample), is fitted over the pre-contact window and a post-contact window
   ``max(joint_post_window_min, joint_post_samples / rate)`` (0.1 s = 5 samples at 50 Hz;
   40 ms at 1 kHz: measured over the sweep, 20 ms left the 0.3-count encoder noise at
   High gains' smallest tip motions, 3.1 % worst m*, 60-80 ms let the servo's reversal
   bias the model, 2.7-4.7 %) with the model::

       s(t) = s_s + v_a u + w y_f(t) + c y_1(t),      u = t - t_s,

   where ``y_f`` is the response of the joint-resistance law ``y'' + a1 y' + a0 y = input``
   to the measured contact force normalised to unit impulse, and ``y_1`` its response to
   a unit step from the contact start (Coulomb friction); ``a1, a0 >= 0`` (viscous /
   servo damping and stiffness) by bounded nonlinear least squares, ``s_s, v_a, w, c`` by
   linear least squares inside it (variable projection). Then
   ``v'_a = v_a + w y_f'(t_e) + c y_1'(t_e)``. This is eq 1 for the tip: the contact force
   drives the arm (the velocity follows the accumulated impulse, with the measured pulse
   shape), while the joint resistance -- friction, servo, gravity compensation, the source
   of lambda -- acts from the contact start on, continuously across the contact end
   (it depends on the joint state, not on the contact). Anchoring the post-contact samples
   to the well-determined pre-contact position through the measured force shape is what
   makes 20 ms samples usable (the contact holds 0-3 of them); a central difference
   across the impact is simply wrong (tests show it off by > 15 %).
   Alternatives kept for comparison (``arm_model``): ``poly`` (the force-shaped term plus
   a polynomial deceleration of order ``resistance_order`` from the contact start) and
   ``onesided`` (independent polynomial fits before the start and after the end,
   extrapolated to the edges). With the power-law contact edges the ``lti`` model follows
   the rig closely at 1 kHz but for the High-gain trials of smallest tip motion (worst
   1.53 %); at 50 Hz its High-gain worst case is 6.1 % (the servo reverses the tip 10-20 ms
   after the contact, between two samples), hence the F/T method there.
   On a flexible base the tip's inertial velocity is the base point's plus the arm's:
   the platform pose channels (1 kHz; the emulated base channels when the platform ones
   are absent) give ``n . (p_b + R r0)`` (``r0`` the tip at ``q_cmd`` in the base frame,
   mount included, :func:`base_geometry`), fitted one-sided (``base_window``, 20 ms,
   quadratic), and the arm part ``n . R (p(q) - p(q_cmd))`` uses the model above.
4. ``e = (v'_a - v'_b) / (v_b - v_a)`` (eq 12) on the edge velocities, the piezo impulse
   beside the hammer's (``impulse_momentum``) as a cross-check, and ``m*`` by one of two
   estimators (``m_eff_estimator``):

   **eq 10** (``"eq10"``, default: what the paper computed, its Table 2):
   ``m* = m_b (v_b - v'_b) / (v'_a - v_a)``. In the impulsive limit this is eq 11's m*,
   the quantity lambda is defined by (eqs 11, 15). On a finite contact with a hanging
   pendulum it is not, for two reasons, both making it larger: (a) the hammer's momentum
   change holds the pendulum's gravity impulse over the contact (the head swings up
   through the bottom): +0.35..+0.55 % of the contact impulse on the synthetic 40 ms
   contacts of tests/test_fit.py, +0.8..+1.05 % on three rig trials (~70 ms); (b) the arm moves
   during the contact, so ``v'_a - v_a = n.(J(q_e) qd' - J(q_s) qd)`` is not the
   ``n.J(q_s) (qd' - qd)`` of eq 11 (up to +0.75 % on those 40 ms contacts, growing with
   speed). Together eq 10's m* sits +0.4..+1.1 % above eq 11 there (+1.2..+2.8 % on the
   three rig trials). Lambda fitted to it is biased by as much (lambda_3 +1.75 % from
   the true eq-10 m* of those trials): within the 50 Hz confidence intervals, outside the
   1 kHz ones.

   **impulse** (``"impulse"``): ``m* = P / n.J(q_s) (qd' - qd)``, eq 11's impulsive-limit
   m* on a finite contact. ``P`` is the contact impulse from the pendulum: its equation of
   motion with the force ``F`` at the head, ``m_b r theta'' = -m_b r w^2 sin(theta) -
   F cos(theta)``, integrated over the contact, with ``w^2`` from the ODE fits and the
   measured angle (:func:`_contact_impulse`; so it needs ``pendulum_model="ode"``). The
   size of ``P`` comes from the pendulum as in eq 10 (no force calibration); the piezo
   gives only the force's shape (the ``cos(theta)`` weighting) and stays the cross-check.
   The tip's velocity change goes through the Jacobian at the contact start: the joint
   model and the F/T method map their joint velocities at the contact end with ``J(q_s)``;
   the tip-space models (``lti``, ``poly``, ``onesided``) are fitted a second time, to the
   joint samples mapped linearly through ``J(q_s)`` (:func:`_start_jacobian_series`).
   ``v_a``, ``v'_a`` and ``e`` stay the edge values. On a flexible base the base point's
   velocity change is taken as measured: what the platform's suspension and rotation do
   during the contact is not impulsive and is not corrected (synthetic flexible trials
   with a 5 Hz base: +0.65..+3.0 % above eq 8's m*, against +1.1..+4.0 % for eq 10), so
   there it is a partial correction, applied rather than refused because its two parts
   are exact in themselves. Measured on the lambda-recovery trials at 1 kHz: ``P`` within
   0.015 % of the true impulse; each trial's m* within 0.75 % of its own truth (the true
   impulse over the true ``n.J(q_s) (qd' - qd)``), the same spread as eq 10 against its
   truth; lambda_3 +0.3 % with every CI covering the truth (eq 10: +2.0 %, the CIs of
   lambda_1 and lambda_3 miss). Use ``"impulse"`` to estimate lambda or to compare with
   eq 11 / eq 8 predictions; ``"eq10"`` to reproduce the paper's numbers. Each result
   records its estimator (``TrialIdentification.m_eff_estimator``).

A trial that cannot give a trustworthy m* -- no contact in the force channel, more than
one contact (a rebound), a saturated piezo, a contact not fully inside the record, too
few samples before or after the contact, a tip that does not move measurably along n --
is returned with ``excluded=True`` and the reason; the fits never average it in. A file
that is not a trial, or a trial without a required channel, raises
:class:`~campaign.errors.TrialFileError` (files) or :class:`~campaign.errors.InputError`
(datasets) naming it.

Measured accuracy against the simulator truth: :data:`ACCURACY_NOTE`.
"""

from __future__ import annotations

from .options import (
    ACCURACY_NOTE, REQUIRED_CHANNELS, IdentifyOptions, FLEXIBLE_CONSTANTS, BASE_POSE_CHANNELS, ARM_MODELS,
    EDGE_MODELS, PENDULUM_MODELS, ARM_VELOCITIES, FT_ROWS, JOINT_COULOMB, M_EFF_ESTIMATORS, FT_CHANNELS,
)
from .results import TrialIdentification
from .contact import Contact, detect_contact
from .hammer import hammer_velocity
from .channels import base_geometry
from .ft_momentum import _ft_tip_velocity, _cross
from .joint_dynamics import _joint_dynamics_fit
from .trial import identify_trial
from .loading import find_trials, identify_file, identify_files, load_trial

__all__ = [
    "ACCURACY_NOTE",
    "REQUIRED_CHANNELS",
    "Contact",
    "IdentifyOptions",
    "TrialIdentification",
    "base_geometry",
    "detect_contact",
    "find_trials",
    "hammer_velocity",
    "identify_file",
    "identify_files",
    "identify_trial",
    "load_trial",
]
