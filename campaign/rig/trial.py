"""One trial of the simulated VES-II: scene in, raw channels (and truth) out.

:func:`simulate` builds only what the scene needs (a fixed-base scene has no base or
platform states), checks every input before integrating (pendulum reach, servo
stability, contact step), integrates (:mod:`.integrate`) and samples the sensors
(:mod:`.sensors`) into an ``xarray.DataTree`` following :mod:`campaign.scene.schema`:
``/measured`` holds what a real rig records, ``/truth`` what only the simulator knows.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from ..core.errors import InputError, SimulationError
from ..core.lazy import LazyModule
from ..core.vocabulary import FIXED, FLEXIBLE
from ..model.exiit import effective_mass
from ..model.robot import load_robot
from ..scene import schema
from ..scene.description import Scene
from ..scene.schema import ChannelArray, GroupArrays, TrialArrays
from .beam import Beam
from .contact import ContactLaw, contact_duration_estimate
from .controller import PID, check_stability
from .flexible import IdealCouplingPlant, VesLoopPlant
from .integrate import integrate_trial
from .pendulum import Pendulum
from .placement import place_pendulum, placement_params
from .plant import FixedBasePlant
from .sensors import (
    StateSampler,
    mount_wrenches,
    noise_streams,
    quantize,
    sample_grid,
    truth_terms,
)
from .tree import to_tree

__all__ = ["simulate", "simulate_arrays", "to_tree", "build", "check_stroke", "structure_modes", "Rig"]

# imported on first use: ``import campaign.rig`` (e.g. for the beam model of Figure 8) and
# the campaign's simulation jobs (simulate_arrays) need not pay ~0.7 s for xarray; only a
# DataTree (:func:`.tree.to_tree`) imports it
xr = LazyModule("xarray")

#: RK4 steps per contact duration estimate: the step is set from the contact's own time scale
STEPS_PER_CONTACT = 32
#: longest VES latency accepted [s]; real emulators run at a few ms
MAX_VES_LATENCY = 0.1
#: longest recording after the touch a flexible-base trial may need [s]
MAX_FLEXIBLE_RECORD = 20.0
#: the ideal coupling refuses a structure needing more RK4 steps than this per servo tick
MAX_SUBSTEPS_IDEAL = 16
#: an integration override must keep at least this many RK4 steps over the shortest contact
MIN_STEPS_PER_CONTACT = 8
#: a contact needing more RK4 substeps than this per servo tick is refused as too stiff
MAX_SUBSTEPS = 4096


@dataclasses.dataclass
class Rig:
    """The assembled plant of one scene, before integration."""

    scene: Scene
    plant: FixedBasePlant
    pid: PID
    min_post: float
    max_post: float
    servo_period: float
    substeps_contact: int
    substeps_free: int
    t_contact: float
    streams: dict


def build(scene: Scene, *, integration: dict | None = None) -> Rig:
    """Assemble the plant of ``scene`` and check it; raises InputError naming the cause.

    ``integration`` overrides the integrator's substeps (``substeps_contact``,
    ``substeps_free``), checked here too: an override must still resolve the contact."""
    p = scene.p
    robot = load_robot(p("robot"))
    try:
        q0 = robot.q_from_angles(scene.q_paper_deg, what=f"pose {list(scene.q_paper_deg)} deg ({robot.name} angles; "
                                 f"model = these + {robot.angle_offset_deg.tolist()} deg)")
    except ValueError as exc:
        raise InputError(str(exc)) from None
    gravity = float(p("gravity"))
    pend = Pendulum.from_scene(scene)
    theta0 = pend.release_angle(scene.speed)  # refuses a speed the device cannot reach
    n = np.asarray(scene.impact_direction, dtype=float)
    # the pendulum is placed to strike the impact point along n at the bottom of its swing;
    # a pose it cannot reach, or whose impact point is not exposed from n, is refused here
    place = placement_params(scene.param_dict)
    if place is not None:
        place_pendulum(robot, q0, n, radius=pend.radius, release_angle=theta0,
                       what=f"pose {list(scene.q_paper_deg)} deg", **place)
    contact = ContactLaw.from_scene(scene)
    _ = contact.damping  # solving for the damping refuses an unreachable restitution now
    friction = dict(coulomb_scale=float(p("arm.coulomb_scale")), viscous_scale=float(p("arm.viscous_scale")),
                    gravity=gravity)
    min_post, max_post = float(p("trial.min_post_contact")), float(p("trial.max_post_contact"))
    # the hammer must rebound: one at least as heavy as the arm's free effective mass (eq 11,
    # lambda = 0, the smallest m* the arm can show) keeps pushing it and never leaves cleanly
    m1 = effective_mass(robot, q0, n)
    if pend.m_b >= m1:
        raise InputError(
            f"hammer effective mass m_b = {pend.m_b:.4g} kg (pendulum.head_mass, pendulum.rod_mass) is not below "
            f"the arm's free effective mass m* = {m1:.4g} kg (eq 11, lambda = 0) at this pose: it would keep "
            "pushing the arm instead of rebounding")
    streams = noise_streams(scene.seed)
    t_contact = float(p("trial.pre_contact")) + float(p("trial.contact_jitter")) * streams["contact_time"].random()
    if scene.base == FIXED:
        plant, freqs = FixedBasePlant(robot, q0, n, pend, contact, **friction), None
    else:
        plant, freqs, min_post, max_post = _flexible_plant(scene, robot, q0, n, pend, contact, friction,
                                                           t_contact=t_contact, min_post=min_post)
    pid, T = _servo(scene, robot, plant, q0)
    sub_c, sub_f = _substeps(scene, contact, pend, m1, freqs, servo_period=T, max_post=max_post,
                             integration=integration)
    return Rig(scene, plant, pid, min_post, max_post, T, sub_c, sub_f, t_contact, streams)


def _flexible_plant(scene: Scene, robot, q0, n, pend, contact, friction: dict, *, t_contact: float, min_post: float):
    """The plant of a flexible-base scene (ideal coupling or VES loop, ``ves.mode``), the
    structure's natural frequencies with the arm on top [Hz] and the recording's length
    after the touch ``(min_post, max_post)``: ``flexible.trial_periods`` periods of the
    structure's first mode (for Figure 9), refused beyond ``MAX_FLEXIBLE_RECORD``; the VES
    loop is refused at a latency beyond ``MAX_VES_LATENCY`` or unstable with the arm."""
    p = scene.p
    beam = Beam.from_scene(scene)
    freqs, arm = _modes_with_arm(robot, q0, beam)
    f1 = float(freqs[0])
    min_post = max_post = max(min_post, float(p("flexible.trial_periods")) / f1)
    if max_post > MAX_FLEXIBLE_RECORD:
        raise InputError(
            f"the structure's first mode ({f1:.3g} Hz with the arm on top; flexible.beam_EI = "
            f"{p('flexible.beam_EI'):g} N m^2, beam_length = {p('flexible.beam_length'):g} m) needs a "
            f"{max_post:.3g} s recording for flexible.trial_periods = {p('flexible.trial_periods'):g} periods, "
            f"beyond the {MAX_FLEXIBLE_RECORD:g} s a trial may last: stiffen the structure or record fewer periods")
    if p("ves.mode") == "ideal":
        return IdealCouplingPlant(robot, q0, n, pend, contact, beam, **friction), freqs, min_post, max_post
    if float(p("ves.latency")) > MAX_VES_LATENCY:
        raise InputError(
            f"VES latency {p('ves.latency'):g} s (ves.latency) is beyond {MAX_VES_LATENCY:g} s: a force loop "
            f"delayed that long cannot emulate a {f1:.3g} Hz structure (it destabilises it), and its "
            "stability check would have to analyse the whole delay line")
    plant = VesLoopPlant(robot, q0, n, pend, contact, beam, **friction,
                         rate=float(p("ves.rate")), latency=float(p("ves.latency")),
                         bandwidth=float(p("ves.bandwidth")), duration=t_contact + max_post)
    linear = scene.param_dict.get("flexible.linear_phases", False)
    if not isinstance(linear, bool):
        raise InputError(f"flexible.linear_phases must be true or false, got {linear!r}")
    plant.linear_phases = linear
    T_e = plant.emulator_period
    plant.reset_loop(math.floor(t_contact / T_e + 1e-9) * T_e)
    # the emulation loop closed through the (locked) arm must be stable
    fz, zeta = plant.loop.closed_loop_poles(np.asarray(arm.matrix()))
    if np.any(zeta < 0):
        k = int(np.argmin(zeta))
        raise InputError(
            f"the VES emulation loop is unstable at ves.rate = {p('ves.rate'):g} Hz, ves.latency = "
            f"{p('ves.latency'):g} s, ves.bandwidth = {p('ves.bandwidth'):g} Hz: its {fz[k]:.4g} Hz mode has "
            f"damping ratio {zeta[k]:.3g} < 0 with the arm on the platform; lower the bandwidth or the latency")
    return plant, freqs, min_post, max_post


def _servo(scene: Scene, robot, plant: FixedBasePlant, q0) -> tuple[PID, float]:
    """The arm's servo (the counts PID at ``controller.servo_rate``, holding the static
    output at ``q0``) and its period [s]; refused if unstable on the arm or if holding
    ``q0`` needs more than the peak torques."""
    p = scene.p
    T = 1.0 / float(p("controller.servo_rate"))
    P, D, I = scene.gains_counts
    scale = float(p("controller.torque_per_unit"))
    H = robot.model.createData()
    Hd = np.diag(pin.crba(plant.model, H, q0))
    check_stability(Hd, plant.viscous, P=P, D=D, I=I, scale=scale, resolution=robot.encoder_resolution,
                    period=T, joint_names=robot.joint_names)
    g0 = plant.gravity_torque(q0)
    use_gc = scene.gain in (p("controller.gravity_compensation") or [])
    if np.any(np.abs(g0) > robot.tau_max):
        raise InputError(f"holding configuration {list(scene.q_paper_deg)} deg needs gravity torques "
                         f"{np.round(g0, 2).tolist()} N m beyond the peak torques {robot.tau_max.tolist()}")
    pid = PID(P, D, I, scale, robot.encoder_resolution, robot.tau_max, g0 if use_gc else np.zeros_like(g0), q0,
              T, quantize=bool(p("sensors.quantize")))
    pid.hold_static(g0)
    return pid, T


def _substeps(scene: Scene, contact, pend, m1: float, freqs, *, servo_period: float, max_post: float,
              integration: dict | None) -> tuple[int, int]:
    """The integrator's RK4 substeps per servo tick ``(in contact, out of contact)``: from
    the contact's own time scale (``STEPS_PER_CONTACT``) and the scene's settings, enough
    for the ideal coupling's highest structure mode, then ``integration``'s overrides.
    Refused: a contact outlasting the recording or needing more than ``MAX_SUBSTEPS``, a
    structure the ideal coupling cannot resolve, and an override that leaves the contact
    (or the ideal coupling's structure) unresolved."""
    p, T = scene.p, servo_period
    ideal = scene.base == FLEXIBLE and p("ves.mode") == "ideal"
    # contact step from the contact's own time scale (hammer against a wall bounds it)
    t_contact_scale = contact_duration_estimate(contact.stiffness, contact.exponent, pend.m_b, scene.speed)
    if t_contact_scale > max_post:
        raise InputError(
            f"a contact of ~{t_contact_scale:.3g} s (contact.stiffness = {contact.stiffness:g}, hammer m_b = "
            f"{pend.m_b:.3g} kg at {scene.speed:g} m/s) outlasts the recording after the touch "
            f"({max_post:g} s, trial.max_post_contact): stiffen the contact or lengthen the recording")
    sub_c = max(1, math.ceil(T / (t_contact_scale / STEPS_PER_CONTACT)))
    sub_c = max(sub_c, int(p("integration.substeps_contact")))
    if sub_c > MAX_SUBSTEPS:
        raise InputError(
            f"contact too stiff for the integrator: a contact of ~{t_contact_scale * 1e3:.3g} ms needs "
            f"{sub_c} RK4 steps per {T * 1e3:g} ms servo tick (limit {MAX_SUBSTEPS}); lower contact.stiffness"
        )
    sub_f = int(p("integration.substeps_free"))
    if ideal:
        # the structure is integrated with the arm: RK4 must resolve its highest mode
        # (omega h <= 1) out of contact too
        sub_free_min = math.ceil(2.0 * math.pi * float(freqs[-1]) / float(p("controller.servo_rate")))
        if sub_free_min > MAX_SUBSTEPS_IDEAL:
            raise InputError(
                f"ideal coupling cannot resolve the structure's highest mode ({freqs[-1]:.4g} Hz: "
                f"{sub_free_min} RK4 steps per servo tick, limit {MAX_SUBSTEPS_IDEAL}); use ves.mode = loop, "
                "whose emulator steps the structure exactly, or a softer beam (flexible.beam_EI, beam_EA_ratio)")
        sub_f = max(sub_f, sub_free_min)
        # in contact the structure is integrated with the same RK4 step: it must resolve that
        # mode as well (with 1 step per tick the ideal coupling's m* is 18 % off, benchmarks/)
        sub_c = max(sub_c, sub_free_min)
    for key, value in (integration or {}).items():
        if key not in ("substeps_contact", "substeps_free") or not (isinstance(value, int) and value >= 1):
            raise InputError(f"integration override {key}={value!r}: expected substeps_contact or substeps_free, "
                             "an integer >= 1")
    sub_c = int((integration or {}).get("substeps_contact", sub_c))
    sub_f = int((integration or {}).get("substeps_free", sub_f))
    if ideal and min(sub_c, sub_f) < sub_free_min:
        raise InputError(
            f"integration override substeps_contact={sub_c}, substeps_free={sub_f}: the ideal coupling needs at "
            f"least {sub_free_min} RK4 steps per servo tick to resolve the structure's highest mode "
            f"({freqs[-1]:.4g} Hz)")
    # the contact must stay resolved: the shortest it can be is against the arm's free
    # effective mass (reduced mass of the hammer and m1)
    m_red = pend.m_b * m1 / (pend.m_b + m1)
    t_short = contact_duration_estimate(contact.stiffness, contact.exponent, m_red, scene.speed)
    steps = sub_c * t_short / T
    if steps < MIN_STEPS_PER_CONTACT:
        raise InputError(
            f"substeps_contact={sub_c} gives only {steps:.2g} RK4 steps over a contact of ~{t_short * 1e3:.3g} ms "
            f"(at least {MIN_STEPS_PER_CONTACT} needed)")
    return sub_c, sub_f


def _modes_with_arm(robot, q0, beam):
    """Natural frequencies [Hz] of the structure with the arm locked on top (ascending) and
    the arm's composite inertia at the beam tip."""

    data = robot.model.createData()
    pin.ccrba(robot.model, data, q0, np.zeros(robot.nv))
    arm = beam.base_body().mount.act(data.oYcrb[0])
    return np.asarray(beam.modes(tip=arm)[0], float), arm


def structure_modes(scene: Scene) -> np.ndarray:
    """Natural frequencies [Hz] of a flexible scene's structure with its arm locked on top in
    the scene's configuration, ascending: the first bending pair (its period T_1 sets the
    recording and Figure 9's time axis), then the second pair, torsion, axial."""

    robot = load_robot(scene.p("robot"))
    q0 = robot.q_from_angles(scene.q_paper_deg, what="configuration")
    return _modes_with_arm(robot, q0, Beam.from_scene(scene))[0]


def check_stroke(platform, *, stroke: float, stroke_rotation: float, structure: str = "") -> None:
    """Refuse a trial whose platform leaves the VES-II's stroke (``ves.stroke`` [m] per
    translation axis, ``ves.stroke_rotation`` [rad] per rotation axis): the real rig could not
    have emulated it. ``platform`` is the platform pose per sample (n, 6)."""
    platform = np.asarray(platform, float)
    for cols, limit, key, units in ((slice(0, 3), stroke, "ves.stroke", "m"),
                                    (slice(3, 6), stroke_rotation, "ves.stroke_rotation", "rad")):
        peak = float(np.max(np.abs(platform[:, cols]))) if platform.size else 0.0
        if peak > limit:
            raise InputError(
                f"the emulated base moves {peak:.4g} {units} from rest, beyond the VES platform's stroke {key} = "
                f"{limit:g} {units}" + (f" (structure {structure})" if structure else "")
                + ": a slower hammer or a stiffer or heavier structure keeps the platform in range")


def _check_finite(groups) -> None:
    """Refuse a trial with a non-finite value in any channel (``groups``: (name, {key: data})),
    naming the first such channel; one pass over all float values when every one is finite."""
    arrays = [np.ravel(x) for _, group in groups for x in group.values()]
    values = np.concatenate([x for x in arrays if x.dtype.kind == "f"])
    if np.isfinite(values).all():
        return
    for name, group in groups:
        for key, x in group.items():
            x = np.asarray(x)
            if x.dtype.kind == "f" and not np.all(np.isfinite(x)):
                raise SimulationError(f"channel {name}/{key} has non-finite values; nothing is stored")


def simulate(scene: Scene, *, integration: dict | None = None) -> xr.DataTree:
    """Simulate one trial and return its channels as a DataTree (``/measured``, ``/truth``).

    Parameters
    ----------
    scene : Scene
    integration : dict, optional
        Overrides for the integrator (``substeps_contact``, ``substeps_free``), for
        convergence studies; the defaults come from the scene.

    Raises
    ------
    InputError
        Bad scene (unreachable speed, unstable servo, contact too stiff, ...), before any work.
    SimulationError
        The integration failed (blow-up); nothing is returned.
    """
    return to_tree(simulate_arrays(scene, integration=integration))


def simulate_arrays(scene: Scene, *, integration: dict | None = None) -> TrialArrays:
    """:func:`simulate` returning the trial as plain arrays (``campaign.scene.schema.TrialArrays``),
    which :func:`campaign.archive.write_trial` stores as the same file: the campaign's
    simulation jobs use it and never import xarray (~0.7 s per job, more than a fixed-base
    trial takes to simulate). :func:`to_tree` gives the DataTree :func:`simulate` returns."""
    rig = build(scene, integration=integration)
    traj = integrate_trial(rig.plant, rig.pid, **integration_args(rig))
    trial = record_arrays(rig, traj)
    trial.attrs["integration_steps"] = int(traj.n_steps)
    trial.attrs["integration_rhs_evaluations"] = int(traj.n_rhs)
    return trial


def integration_args(rig: Rig) -> dict:
    """The integrator's keyword arguments for ``rig`` (:func:`.integrate.integrate_trial`)."""
    p = rig.scene.p
    return dict(t_contact=rig.t_contact, speed=rig.scene.speed, servo_period=rig.servo_period,
                min_post=rig.min_post, max_post=rig.max_post, substeps_contact=rig.substeps_contact,
                substeps_free=rig.substeps_free, settle_velocity=float(p("trial.settle_velocity")),
                stick_velocity=float(p("arm.stick_velocity")), catch_delay=float(p("pendulum.catch_delay")))


def record(rig: Rig, traj) -> xr.DataTree:
    """Sample every channel of the trial (measured and truth) into a DataTree."""
    return to_tree(record_arrays(rig, traj))


def _clock(dim: str, values) -> ChannelArray:
    """A clock's time coordinate [s] with its CF attributes."""
    c = schema.CLOCKS[dim]
    return ChannelArray((dim,), np.asarray(values, dtype=float),
                        {"units": "s", "long_name": c.long_name, "rate_key": c.rate_key})


def _names(dim: str, labels) -> ChannelArray:
    return ChannelArray((dim,), np.asarray(list(labels)), {})


def _channels(data: dict, specs: dict) -> dict:
    return {k: ChannelArray(specs[k].dims, x, {"units": specs[k].units, "long_name": specs[k].long_name})
            for k, x in data.items()}


class _Clocks:
    """(times, states, derivatives) on a channel's clock (its rate key); channels at one
    rate share them."""

    def __init__(self, p, sampler: StateSampler, t_end: float):
        self.p, self.sampler, self.t_end = p, sampler, t_end
        self.grids = {}

    def __call__(self, rate_key: str):
        rate = float(self.p(rate_key))
        if rate not in self.grids:
            t = sample_grid(rate, self.t_end)
            self.grids[rate] = (t, *self.sampler(t))
        return self.grids[rate]


def record_arrays(rig: Rig, traj) -> TrialArrays:
    """Sample every channel of the trial (measured and truth) into plain arrays
    (:func:`record` without building xarray objects; :func:`to_tree` makes the tree)."""
    scene, plant = rig.scene, rig.plant
    p = scene.p
    flexible = scene.base == FLEXIBLE
    loop = flexible and hasattr(plant, "loop")
    clocks = _Clocks(p, StateSampler(plant, traj), traj.t_end)
    measured, coords, history = _measured(rig, traj, clocks, loop=loop)
    truth, truth_coords, base_truth = _truth(rig, traj, clocks, history)
    if flexible:
        tb, base_measured, base_true = _base_channels(rig, clocks, history, base_truth)
        measured.update(base_measured)
        coords["t_base"] = _clock("t_base", tb)
        coords["axis2"] = _names("axis2", "xyz")
        truth.update(base_true)
        truth_coords["axis"] = _names("axis", "xyz")
    _check_finite((("measured", measured), ("truth", truth)))
    # the groups share some names: each has its own specs
    measured = GroupArrays(_channels(measured, {v.name: v for v in schema.MEASURED}), coords)
    truth = GroupArrays(_channels(truth, {v.name: v for v in schema.TRUTH}), truth_coords,
                        {"n_contacts": len(traj.contacts), "settled": int(traj.settled),
                         "t_static": float(traj.t_static) if traj.t_static is not None else -1.0,
                         "ves_mode": str(p("ves.mode")) if flexible else "none"})
    return TrialArrays({
        "scene_json": scene.to_json(), "scene_sha256": scene.sha256, "seed": int(scene.seed), "base": scene.base,
        "config": int(scene.config), "gain": scene.gain, "speed": float(scene.speed), "repeat": int(scene.repeat),
        "robot": plant.robot.name, "scene_name": scene.name,
    }, {"measured": measured, "truth": truth})


def _measured(rig: Rig, traj, clocks: _Clocks, *, loop: bool) -> tuple[dict, dict, tuple | None]:
    """The channels a real rig records (``/measured``: encoders, piezo, base F/T, commanded
    torque, constants of the set-up), their coordinates, and for the VES loop the
    emulator's record ``(times, states)`` (:func:`_ft_wrench`)."""
    plant, p, streams = rig.plant, rig.scene.p, rig.streams
    robot = plant.robot
    aq, t_end = plant.arm_q, traj.t_end
    quant = bool(p("sensors.quantize"))
    # joint encoders
    tj, Xj, _ = clocks("sensors.joint_encoder_rate")
    res = robot.encoder_resolution
    q_meas = Xj[:, aq] + streams["joint_encoder"].normal(0.0, 1.0, (tj.size, robot.nv)) * float(
        p("sensors.joint_encoder_noise_counts")) * res
    if quant:
        q_meas = np.round(q_meas / res) * res
    # pendulum encoder
    tp, Xp, _ = clocks("sensors.pendulum_encoder_rate")
    theta = quantize(Xp[:, plant.i_th].copy(), 2 * np.pi / float(p("sensors.pendulum_encoder_counts")) if quant else 0.0)
    # piezo
    tf = sample_grid(float(p("sensors.piezo_rate")), t_end)
    f_true = clocks.sampler.contact_force(tf)
    f_meas = f_true + streams["piezo"].normal(0.0, float(p("sensors.piezo_noise")), tf.size)
    f_meas = quantize(f_meas, float(p("sensors.piezo_resolution")) if quant else 0.0)
    fs = float(p("sensors.piezo_full_scale"))
    f_meas = np.clip(f_meas, -fs, fs)
    # base F/T
    tft, wrench, history = _ft_wrench(rig, traj, clocks, loop=loop)
    g = streams["ft"]
    force = wrench[:, :3] + g.normal(0.0, float(p("sensors.ft_noise_force")), (tft.size, 3))
    torque = wrench[:, 3:] + g.normal(0.0, float(p("sensors.ft_noise_torque")), (tft.size, 3))
    # commanded torque on the servo clock (held values at each tick)
    ts = sample_grid(float(p("controller.servo_rate")), t_end)
    idx = np.clip(np.searchsorted(traj.servo_t, ts, side="right") - 1, 0, traj.servo_t.size - 1)
    tau = np.where((ts < traj.servo_t[0])[:, None], traj.tau_static[None, aq], traj.servo_tau[idx][:, aq])

    coords = {"t_joint": _clock("t_joint", tj), "t_pend": _clock("t_pend", tp), "t_force": _clock("t_force", tf),
              "t_ft": _clock("t_ft", tft), "t_servo": _clock("t_servo", ts),
              "joint": _names("joint", list(robot.joint_names)), "axis": _names("axis", "xyz")}
    measured = {
        "q_enc": q_meas,
        "theta_pend": theta,
        "f_piezo": f_meas,
        "ft_force": force,
        "ft_torque": torque,
        "tau_cmd": tau,
        "q_cmd": plant.q0[aq].copy(),
        "hammer_mass_eff": np.float64(plant.pend.m_b),
        "pendulum_radius": np.float64(plant.pend.radius),
        "impact_direction": plant.n.copy(),
        "piezo_full_scale": np.float64(fs),
    }
    return measured, coords, history


def _ft_wrench(rig: Rig, traj, clocks: _Clocks, *, loop: bool):
    """The true wrench at the arm's mounting on the F/T sensor's clock, ``(times, wrench)``,
    and for the VES loop the emulator's record ``(times, states)`` (None otherwise).

    The wrench only changes while the arm moves; at rest before the touch and after the
    integration stopped one evaluation serves every sample. The emulator sampled the sensor
    at its ticks; between ticks the reading is interpolated."""
    plant = rig.plant
    tft, Xft, XDft = clocks("sensors.ft_rate")
    wrench = np.empty((tft.size, 6))
    pre = tft < traj.t_contact
    post = tft > traj.t[-1]
    rest = np.concatenate(plant.rest_wrench())
    wrench[pre] = rest
    if not loop:
        if np.any(post):
            last = traj.x[-1]
            wrench[post] = mount_wrenches(plant, last[None], np.zeros((1, last.size)), np.zeros(1))[0]
        mid = ~(pre | post)
        wrench[mid] = mount_wrenches(plant, Xft[mid], XDft[mid], clocks.sampler.contact_force(tft[mid]))
        return tft, wrench, None
    tk, wk, rec = plant.ticks()    # (times, wrenches, records): built from its history once here
    # the states each tick reached, one emulator period later (at rest before the first),
    # interpolated linearly between ticks (the plant's platform_history, on these arrays)
    t_rec = np.concatenate([[plant.t_first], tk + plant.emulator_period])
    rec = np.vstack([np.zeros(24), rec])
    tk = np.concatenate([[traj.t_contact], tk])
    wk = np.vstack([rest, wk])
    tn = tft[~pre]
    wrench[~pre] = np.column_stack([np.interp(tn, tk, wk[:, i]) for i in range(6)])
    return tft, wrench, (t_rec, rec)


def _truth(rig: Rig, traj, clocks: _Clocks, history):
    """What only the simulator knows (``/truth``), its coordinates, and the base's true
    state on the truth clock (flexible base: (n, 12) position, rotation, velocity, angular
    velocity; None on a fixed base)."""
    plant = rig.plant
    aq = plant.arm_q
    tt, Xt, _ = clocks("sensors.truth_rate")
    f_t = clocks.sampler.contact_force(tt)
    pre = tt < traj.t_contact
    post = tt > traj.t[-1]
    # tip velocity and energy are exact at the samples (Pinocchio per sample); before the
    # touch and after the integration stopped the arm is at rest (one evaluation each)
    base_truth = None
    if history is not None:
        t_rec, rec = history
        P_hist = np.column_stack([np.interp(tt, t_rec, rec[:, i]) for i in range(6, 12)])
        V_hist = np.column_stack([np.interp(tt, t_rec, rec[:, i]) for i in range(18, 24)])
        energy, tip_v = truth_terms(plant, Xt, pre, post, P_hist, V_hist)
        base_truth = np.column_stack([P_hist, V_hist])
    else:
        energy, tip_v = truth_terms(plant, Xt, pre, post)
        if rig.scene.base == FLEXIBLE:
            base_truth = plant.base_state(Xt)
    c0, c1, _ = traj.contacts[0]
    peak = float(np.max(clocks.sampler.contact_force(np.linspace(c0, c1, 2001))))
    truth = {
        "q": Xt[:, aq],
        "v": Xt[:, plant.arm_v],
        "theta": Xt[:, plant.i_th],
        "theta_dot": Xt[:, plant.i_thd],
        "f_contact": f_t,
        "tip_velocity_n": tip_v,
        "energy": energy,
        "contact_start": np.float64(c0),
        "contact_end": np.float64(c1),
        "v_a_pre": np.float64(traj.v_a_pre),
        "v_a_post": np.float64(traj.v_a_post),
        "v_b_pre": np.float64(traj.v_b_pre),
        "v_b_post": np.float64(traj.v_b_post),
        "impulse": np.float64(traj.impulse),
        "peak_force": np.float64(peak),
        "e_contact": np.float64(plant.contact.restitution),
    }
    truth_coords = {"t_truth": _clock("t_truth", tt), "joint": _names("joint", list(plant.robot.joint_names))}
    return truth, truth_coords, base_truth


def _base_channels(rig: Rig, clocks: _Clocks, history, base_truth):
    """A flexible base's channels on the emulator's clock: ``(times, measured, truth)``
    (structure, commanded and actual platform pose; the base's true state from
    ``base_truth``). Refuses a trial whose platform leaves the VES stroke
    (:func:`check_stroke`)."""
    scene, plant = rig.scene, rig.plant
    tb = sample_grid(float(scene.p("ves.rate")), clocks.t_end)
    body = plant.beam.base_body()
    if history is not None:
        t_rec, rec = history
        chan = np.column_stack([np.interp(tb, t_rec, rec[:, i]) for i in range(18)])
        structure, platform, command = chan[:, 0:6], chan[:, 6:12], chan[:, 12:18]
    else:
        Xb, _ = clocks.sampler(tb)
        structure = plant.base_state(Xb)[:, :6]
        platform = command = structure     # ideal coupling: the platform is the structure
    # a scene stored before the rig stated the platform's stroke has none: no limit then
    check_stroke(platform, stroke=float(scene.param_dict.get("ves.stroke", math.inf)),
                 stroke_rotation=float(scene.param_dict.get("ves.stroke_rotation", math.inf)),
                 structure=str(scene.param_dict.get("flexible.structure", "")))
    measured = {
        "base_position": structure[:, :3],
        "base_rotation": structure[:, 3:],
        "platform_cmd_position": command[:, :3],
        "platform_cmd_rotation": command[:, 3:],
        "platform_position": platform[:, :3],
        "platform_rotation": platform[:, 3:],
        "base_mass": np.float64(body.mass),
        "base_inertia": np.asarray(body.inertia, float),
        "base_com": np.asarray(body.com, float),
        "base_mount": np.asarray(body.mount.translation, float),
    }
    truth = {
        "base_position": base_truth[:, 0:3],
        "base_rotation": base_truth[:, 3:6],
        "base_velocity": base_truth[:, 6:9],
        "base_omega": base_truth[:, 9:12],
    }
    return tb, measured, truth
