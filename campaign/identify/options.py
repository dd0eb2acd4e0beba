"""What identification reads and how: the required channels, the method names and :class:`IdentifyOptions`."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from ..core.errors import InputError, allowed_names

#: channels and constants identification reads from the ``measured`` group, with their dims
REQUIRED_CHANNELS = {
    "q_enc": ("t_joint", "joint"),
    "theta_pend": ("t_pend",),
    "f_piezo": ("t_force",),
    "q_cmd": ("joint",),
    "hammer_mass_eff": (),
    "pendulum_radius": (),
    "impact_direction": ("axis",),
    "piezo_full_scale": (),
}
#: extra constants a flexible-base trial needs (the base pose comes from the platform
#: channels, or the emulated base channels when the platform ones are absent)
FLEXIBLE_CONSTANTS = {"base_mass": (), "base_inertia": ("axis", "axis2")}
BASE_POSE_CHANNELS = (("platform_position", "platform_rotation"), ("base_position", "base_rotation"))

ARM_MODELS = ("joint", "lti", "poly", "onesided")
EDGE_MODELS = ("power", "line")
PENDULUM_MODELS = ("ode", "poly")
ARM_VELOCITIES = ("auto", "ft", "encoders", "combined")
FT_ROWS = ("all", "linear", "angular")
JOINT_COULOMB = ("global", "joint", "sign")
#: m* estimators (``IdentifyOptions.m_eff_estimator``; user guide, *Identification*, step 4)
M_EFF_ESTIMATORS = ("eq10", "impulse")
#: channels the F/T momentum method reads (``tau_cmd`` optional: the servo-step split)
FT_CHANNELS = {"ft_force": ("t_ft", "axis"), "ft_torque": ("t_ft", "axis")}

#: measured accuracy of the default identification against the simulator truth (user guide,
#: *Identification*, "Measured accuracy"; reproduce with ``snakemake study_identification_accuracy``)
ACCURACY_NOTE = """\
|relative error| of m* (eq 10) and e (eq 12) against eq 10/12 on the simulator's true edge
velocities, default options (arm_velocity="auto", arm_model="joint", power-law contact
edges, pendulum ODE fit), the campaign's rig, fixed base,
configurations 1-3 x 1.0/1.5/2.0/2.5 m/s x 2 repeats per gain (random contact phase, sensor
noise and quantisation), median / 90th percentile / worst (snakemake study_identification_accuracy):

  joint encoders at 50 Hz (the paper's 20 ms): F/T momentum method
    Zero  m* 0.34 / 0.98 / 1.5 %   e 0.05 / 0.12 / 0.27 %
    Low   m* 0.27 / 0.82 / 1.4 %   e 0.04 / 0.15 / 0.21 %
    High  m* 0.72 / 2.2 / 2.7 %    e 0.05 / 0.13 / 0.26 %   (signed mean -0.35 %)
    (encoders with the joint model at 50 Hz: Zero / Low / High worst 0.89 / 0.84 / 2.04 %;
    arm_velocity="combined": 0.78 / 0.57 / 1.88 %; the tip-space lti model: High 6.1 %)
  joint encoders at 1 kHz: encoder method, joint-dynamics model, 60 ms post window
    Zero  m* 0.07 / 0.18 / 0.31 %  Low m* 0.07 / 0.26 / 0.49 %  High m* 0.14 / 0.68 / 0.86 %
    e 0.01 % median, worst 0.09 %; every trial within the 1 % target
    (arm_model="lti": Zero 0.39, Low 0.65, High 1.53 % worst; the misses were
    config 2 High 1.0 m/s, +1.53 / -1.02 %, where the tip gains only 15 mm/s of a 57 mm/s
    impulse the servo and friction take back within the contact; noise-free encoders give
    the joint model v'_a - v_a within 0.41 % over the sweep, so the rest is the encoders'
    0.3-count noise)
  ideal scene (no gravity, friction, servo, noise; stiff 1 ms contact -> encoders):
  m* < 0.007 %, e < 0.003 %.
  contact edges (power law): start and end within 0.15 ms of the truth.

The F/T method's spread is the sensor noise (0.2 N, 0.02 N m at 1 kHz integrated over the
~70 ms contact, against 0.05-0.7 N s of arm momentum); noise-free trials give m* within
0.5 % for every gain."""


@dataclasses.dataclass(frozen=True)
class IdentifyOptions:
    """Thresholds and window lengths of the identification (SI units).

    Attributes
    ----------
    k_sigma : float
        Force threshold in noise standard deviations.
    force_floor : float
        Absolute lower bound of the force threshold [N].
    force_floor_rel : float
        Lower bound of the threshold as a fraction of the peak force.
    merge_gap : float
        Runs above the threshold closer than this are one contact [s].
    edge_fit_level : float
        Edge samples up to this multiple of the threshold fit the edge.
    edge_model : {"power", "line"}
        Edge refinement: power law (default) or the straight line (for comparison).
    edge_low_sigma : float
        The power-law edge fit takes samples down to this many noise levels.
    pendulum_window, pendulum_guard : float
        Length of the one-sided polynomial windows (``pendulum_model="poly"``) and the
        windows' distance from the edge [s].
    pendulum_degree : int
        Degree of the polynomial fitted to the pendulum angle (``pendulum_model="poly"``).
    pendulum_model : {"ode", "poly"}
        Hammer velocity from the pendulum's equation of motion (default) or a polynomial.
    pendulum_pre_window, pendulum_post_window : float
        Lengths of the one-sided windows of the ODE fit before / after the contact [s].
    pendulum_stop_time : float
        A pendulum count held this long (the brake) ends the window [s]; 0 disables.
    joint_pre_window : float
        Joint samples up to this long before the contact start enter the fit [s].
    joint_post_samples, joint_post_window_min : int, float
        Joint samples up to ``max(joint_post_window_min, joint_post_samples / rate)`` after
        the contact end enter the fit (:meth:`post_window`) [s].
    min_pre_samples, min_post_samples : int
        Fewer joint samples than this before the start / after the end -> excluded.
    resistance_order : int
        Order of the polynomial resistance deceleration (``poly``; the ``onesided`` fit
        after the contact has degree ``resistance_order + 1``).
    arm_model : {"joint", "lti", "poly", "onesided"}
        The encoder method's tip-velocity model (user guide, *Identification*, step 3): ``joint``
        (default) the joint-space dynamics driven by the measured servo torque; it falls
        back to ``lti`` on a flexible base or without a usable ``tau_cmd`` channel. The
        others for comparison.
    joint_model_post_min : float
        Post-contact window of ``arm_model="joint"``:
        ``max(joint_model_post_min, joint_post_samples / rate)`` (:meth:`joint_model_window`)
        [s]. 60 ms: measured over the 1 kHz sweep of :data:`ACCURACY_NOTE`, 40 ms left more
        of the encoder noise (High worst 0.84 %), 80 ms more Coulomb-sign switching (1.16 %).
    joint_contact_steps : int
        Equal integration steps of the joint model over the contact (200; 100 moved m* by
        up to 0.2 %, 400 by < 0.03 %).
    joint_post_step : float
        Largest integration step of the joint model after the contact [s]; the steps end
        on the servo ticks.
    joint_viscous_max : float
        Upper bound of the viscous-friction scale ``k_B`` (times the drive file's values).
    joint_coulomb_iterations : int
        Largest number of Coulomb-sign iterations of the joint model.
    joint_coulomb : {"sign", "global", "joint"}
        Coulomb friction of the joint model: a free constant per joint and direction of
        motion (default: no friction ratios taken from the drive file), one scale of the
        drive file's per-joint, per-direction values, or one scale per joint. ``global``
        is a little quieter on the rig (whose friction is the drive file's times one
        scale: 1 kHz High worst 0.72 % against 0.86 %) but assumes those ratios; on the
        synthetic trials of tests/identify/test_identify.py, whose joints decelerate each at its
        own rate, it is off by 2.2-4.3 % where they decelerate, ``sign`` within 1 % (median
        0.3 %).
    base_window : float
        One-sided base-pose window (flexible base) [s].
    min_tip_counts : float
        The tip must move along n by at least this many encoder steps (projected on the
        tip) after the contact, or the trial is excluded.
    arm_velocity : {"auto", "ft", "encoders", "combined"}
        Tip-velocity method (user guide, *Identification*, step 3): F/T momentum, joint encoders, both
        weighted by their variances, or
        ``auto`` (default): F/T when the joint samples are coarser than
        ``auto_joint_interval``, else the encoders. F/T falls back to the encoders with the
        reason in ``arm_velocity_note``.
    auto_joint_interval : float
        Joint sampling interval above which ``auto`` uses the F/T [s].
    ft_min_samples : int
        The contact must span at least this many F/T samples for the F/T method.
    ft_rows : {"all", "linear", "angular"}
        Momentum rows of ``A(q) v = h`` solved for v (noise-weighted).
    ft_rest_window, ft_guard : float
        The static F/T reference is the mean over up to ``ft_rest_window`` ending
        ``ft_guard`` before the contact start [s].
    m_eff_estimator : {"eq10", "impulse"}
        What ``m_eff`` estimates (user guide, *Identification*, step 4). ``"eq10"`` (default, the
        paper's): ``m_b (v_b - v'_b) / (v'_a - v_a)`` on the measured edge velocities.
        ``"impulse"``: the contact impulse over the tip's velocity change at the start
        pose, ``P / n.J(q_s)(qd' - qd)`` with ``P`` the hammer's momentum change less
        the pendulum's gravity impulse over the contact -- the impulsive-limit m* of eq 11
        that lambda is defined by (eq 10 sits ~0.5-1 % above it on a 40-70 ms contact).
        Needs ``pendulum_model="ode"`` (its ``w^2`` sizes the gravity impulse). ``e``
        (eq 12) and the edge velocities are the same under both. In the workflow:
        ``identify: {m_eff_estimator: impulse}`` in the config (like every option here).
    """

    k_sigma: float = 8.0
    force_floor: float = 0.5
    force_floor_rel: float = 0.02
    merge_gap: float = 2e-3
    edge_fit_level: float = 4.0
    edge_model: str = "power"
    edge_low_sigma: float = 3.0
    pendulum_window: float = 0.05
    pendulum_guard: float = 1e-3
    pendulum_degree: int = 3
    pendulum_model: str = "ode"
    pendulum_pre_window: float = 0.15
    pendulum_post_window: float = 0.09
    pendulum_stop_time: float = 5e-3
    joint_pre_window: float = 0.2
    joint_post_samples: int = 5
    joint_post_window_min: float = 0.04
    min_pre_samples: int = 3
    min_post_samples: int = 4
    resistance_order: int = 1
    arm_model: str = "joint"
    joint_model_post_min: float = 0.06
    joint_contact_steps: int = 200
    joint_post_step: float = 1e-3
    joint_viscous_max: float = 30.0
    joint_coulomb_iterations: int = 4
    joint_coulomb: str = "sign"
    min_tip_counts: float = 5.0
    base_window: float = 0.02
    arm_velocity: str = "auto"
    auto_joint_interval: float = 5e-3
    ft_min_samples: int = 20
    ft_rows: str = "all"
    ft_rest_window: float = 0.5
    ft_guard: float = 2e-3
    m_eff_estimator: str = "eq10"

    def post_window(self, rate: float) -> float:
        """Post-contact joint window [s] at a joint sampling ``rate`` [Hz]:
        ``max(joint_post_window_min, joint_post_samples / rate)``."""
        return max(self.joint_post_window_min, self.joint_post_samples / rate)

    def joint_model_window(self, rate: float) -> float:
        """Post-contact joint window of ``arm_model="joint"`` [s] at a joint sampling
        ``rate`` [Hz]: ``max(joint_model_post_min, joint_post_samples / rate)``."""
        return max(self.joint_model_post_min, self.joint_post_samples / rate)

    def __post_init__(self):
        for name in ("k_sigma", "merge_gap", "edge_fit_level", "pendulum_window", "joint_pre_window",
                     "pendulum_pre_window", "pendulum_post_window",
                     "joint_post_window_min", "base_window", "edge_low_sigma", "ft_rest_window",
                     "auto_joint_interval", "joint_model_post_min", "joint_post_step", "joint_viscous_max"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"identification option {name} must be > 0, got {v!r}")
        for name in ("force_floor", "force_floor_rel", "pendulum_guard", "min_tip_counts", "ft_guard",
                     "pendulum_stop_time"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InputError(f"identification option {name} must be >= 0, got {v!r}")
        for name in ("pendulum_degree", "min_pre_samples", "min_post_samples", "resistance_order",
                     "joint_post_samples", "ft_min_samples", "joint_contact_steps", "joint_coulomb_iterations"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 0:
                raise InputError(f"identification option {name} must be an integer >= 0, got {v!r}")
        if self.joint_contact_steps < 1:
            raise InputError(f"joint_contact_steps must be >= 1, got {self.joint_contact_steps}")
        if self.pendulum_degree < 1:
            raise InputError(f"pendulum_degree must be >= 1, got {self.pendulum_degree}")
        if self.arm_model not in ARM_MODELS:
            raise InputError(f"arm_model must be one of {ARM_MODELS}, got {self.arm_model!r}")
        for name, allowed in (("edge_model", EDGE_MODELS), ("arm_velocity", ARM_VELOCITIES), ("ft_rows", FT_ROWS),
                              ("pendulum_model", PENDULUM_MODELS), ("joint_coulomb", JOINT_COULOMB)):
            if getattr(self, name) not in allowed:
                raise InputError(f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if self.m_eff_estimator not in M_EFF_ESTIMATORS:
            raise InputError(f"identification option m_eff_estimator must be one of {M_EFF_ESTIMATORS}, "
                             f"got {self.m_eff_estimator!r}")
        if self.m_eff_estimator == "impulse" and self.pendulum_model != "ode":
            # the gravity impulse during the contact is m_b r w^2 int sin(theta) dt, and w^2
            # is a parameter of the ODE fit only (the polynomial has none)
            raise InputError(f"m_eff_estimator='impulse' needs pendulum_model='ode' (the pendulum's w^2 sizes "
                             f"the gravity impulse), got pendulum_model={self.pendulum_model!r}")


def check_identify_options(options: Mapping[str, Any] | None, *, key: str = "identify"):
    """:class:`campaign.identify.IdentifyOptions` from ``options``, every name and value checked."""
    names = [f.name for f in dataclasses.fields(IdentifyOptions)]
    for name in options or {}:
        if name not in names:
            raise InputError(f"{key}: unknown identification option {name!r}; {allowed_names(str(name), names)}")
    try:
        return IdentifyOptions(**dict(options or {}))
    except InputError as exc:
        raise InputError(f"{key}: {exc}") from None

