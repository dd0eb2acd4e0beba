"""One trial of the simulated VES-II: scene in, raw channels (and truth) out.

:func:`simulate` builds only what the scene needs (a fixed-base scene has no base or
platform states), checks every input before integrating (pendulum reach, servo
stability, contact step), integrates (:mod:`.integrate`) and samples the sensors
(:mod:`.sensors`) into an ``xarray.DataTree`` following :mod:`campaign.schema`:
``/measured`` holds what a real rig records, ``/truth`` what only the simulator knows.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import xarray as xr

from .. import schema
from ..errors import InputError, SimulationError
from ..paper import impact_direction
from ..robot import load_robot
from ..scene import Scene
from .contact import Contact, contact_duration_estimate
from .controller import PID, check_stability
from .integrate import integrate_trial
from .pendulum import Pendulum
from .plant import FixedBasePlant
from .sensors import StateSampler, base_wrench, noise_streams, quantize, sample_grid

__all__ = ["simulate", "build", "Rig"]

#: RK4 steps per contact duration estimate: the step is set from the contact's own time scale
STEPS_PER_CONTACT = 32
#: a contact needing more RK4 substeps than this per servo tick is refused as too stiff
MAX_SUBSTEPS = 4096


@dataclasses.dataclass
class Rig:
    """The assembled plant of one scene, before integration."""

    scene: Scene
    plant: FixedBasePlant
    pid: PID
    servo_period: float
    substeps_contact: int
    substeps_free: int
    t_contact: float
    streams: dict


def build(scene: Scene) -> Rig:
    """Assemble the plant of ``scene`` and check it; raises InputError naming the cause."""
    if scene.base != "fixed":
        raise InputError(f"base {scene.base!r} needs the flexible-base rig (campaign.rig.flexible)")
    p = scene.p
    robot = load_robot(p("robot"))
    q0 = robot.check_q(np.radians(np.asarray(scene.q_paper_deg) + _offset()), what="configuration")
    gravity = float(p("gravity"))
    pend = Pendulum(float(p("pendulum.head_mass")), float(p("pendulum.rod_mass")), float(p("pendulum.radius")),
                    gravity, float(p("pendulum.max_release_deg")))
    pend.release_angle(scene.speed)  # refuses a speed the device cannot reach
    contact = Contact(float(p("contact.stiffness")), float(p("contact.exponent")), float(p("contact.restitution")))
    contact.damping  # refuses an unreachable restitution now
    plant = FixedBasePlant(robot, q0, impact_direction(), pend, contact,
                           coulomb_scale=float(p("arm.coulomb_scale")), viscous_scale=float(p("arm.viscous_scale")),
                           gravity=gravity)

    T = 1.0 / float(p("controller.servo_rate"))
    P, D, I = scene.gains_counts
    scale = float(p("controller.torque_per_unit"))
    H = robot.model.createData()
    import pinocchio as pin
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

    # contact step from the contact's own time scale (hammer against a wall bounds it)
    t_contact_scale = contact_duration_estimate(contact.stiffness, contact.exponent, pend.m_b, scene.speed)
    sub_c = max(1, math.ceil(T / (t_contact_scale / STEPS_PER_CONTACT)))
    sub_c = max(sub_c, int(p("integration.substeps_contact")))
    if sub_c > MAX_SUBSTEPS:
        raise InputError(
            f"contact too stiff for the integrator: a contact of ~{t_contact_scale * 1e3:.3g} ms needs "
            f"{sub_c} RK4 steps per {T * 1e3:g} ms servo tick (limit {MAX_SUBSTEPS}); lower contact.stiffness"
        )
    streams = noise_streams(scene.seed)
    t_contact = float(p("trial.pre_contact")) + float(p("trial.contact_jitter")) * streams["contact_time"].random()
    return Rig(scene, plant, pid, T, sub_c, int(p("integration.substeps_free")), t_contact, streams)


def _offset():
    from ..paper import load_paper
    return np.asarray(load_paper()["offset_deg"], dtype=float)


def _var(data, spec: schema.Var, dims=None):
    return xr.Variable(dims or spec.dims, data, {"units": spec.units, "long_name": spec.long_name})


def _time(dim: str, values):
    c = schema.CLOCKS[dim]
    return xr.Variable((dim,), np.asarray(values, dtype=float),
                       {"units": "s", "standard_name": "time", "long_name": c.long_name, "rate_key": c.rate_key})


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
    rig = build(scene)
    p = scene.p
    subs = dict(substeps_contact=rig.substeps_contact, substeps_free=rig.substeps_free)
    subs.update(integration or {})
    traj = integrate_trial(
        rig.plant, rig.pid, t_contact=rig.t_contact, speed=scene.speed, servo_period=rig.servo_period,
        min_post=float(p("trial.min_post_contact")), max_post=float(p("trial.max_post_contact")),
        settle_velocity=float(p("trial.settle_velocity")), stick_velocity=float(p("arm.stick_velocity")),
        catch_delay=float(p("pendulum.catch_delay")), **subs,
    )
    tree = record(rig, traj)
    tree.attrs["integration_steps"] = int(traj.n_steps)
    tree.attrs["integration_rhs_evaluations"] = int(traj.n_rhs)
    return tree


def record(rig: Rig, traj) -> xr.DataTree:
    """Sample every channel of the trial (measured and truth) into a DataTree."""
    scene, plant = rig.scene, rig.plant
    p = scene.p
    robot = plant.robot
    nv = plant.nv
    t_end = traj.t_end
    sampler = StateSampler(plant, traj)
    streams = rig.streams
    quant = bool(p("sensors.quantize"))
    spec = {v.name: v for v in schema.MEASURED + schema.TRUTH}
    joints = list(robot.joint_names)

    # joint encoders
    tj = sample_grid(float(p("sensors.joint_encoder_rate")), t_end)
    Xj, _ = sampler(tj)
    res = robot.encoder_resolution
    q_meas = Xj[:, :nv] + streams["joint_encoder"].normal(0.0, 1.0, (tj.size, nv)) * float(
        p("sensors.joint_encoder_noise_counts")) * res
    if quant:
        q_meas = np.round(q_meas / res) * res
    # pendulum encoder
    tp = sample_grid(float(p("sensors.pendulum_encoder_rate")), t_end)
    Xp, _ = sampler(tp)
    theta = quantize(Xp[:, plant.i_th], 2 * np.pi / float(p("sensors.pendulum_encoder_counts")) if quant else 0.0)
    # piezo
    tf = sample_grid(float(p("sensors.piezo_rate")), t_end)
    f_true = sampler.contact_force(tf)
    f_meas = f_true + streams["piezo"].normal(0.0, float(p("sensors.piezo_noise")), tf.size)
    f_meas = quantize(f_meas, float(p("sensors.piezo_resolution")) if quant else 0.0)
    fs = float(p("sensors.piezo_full_scale"))
    f_meas = np.clip(f_meas, -fs, fs)
    # base F/T at the arm's mounting
    tft = sample_grid(float(p("sensors.ft_rate")), t_end)
    Xft, XDft = sampler(tft)
    Fft = sampler.contact_force(tft)
    force = np.empty((tft.size, 3))
    torque = np.empty((tft.size, 3))
    # the wrench only changes while the arm moves: at rest before the touch and after the
    # integration stopped (arm static) one evaluation serves every sample
    pre = tft < traj.t_contact
    post = tft > traj.t[-1]
    for mask, xx in ((pre, traj.x0), (post, traj.x[-1])):
        if np.any(mask):
            fk, tk = base_wrench(plant, xx[:nv], np.zeros(nv), np.zeros(nv), 0.0)
            force[mask], torque[mask] = fk, tk
    for k in np.flatnonzero(~(pre | post)):
        force[k], torque[k] = base_wrench(plant, Xft[k, :nv], Xft[k, plant.i_v], XDft[k, plant.i_v], Fft[k])
    g = streams["ft"]
    force = force + g.normal(0.0, float(p("sensors.ft_noise_force")), force.shape)
    torque = torque + g.normal(0.0, float(p("sensors.ft_noise_torque")), torque.shape)
    # commanded torque on the servo clock (held values at each tick)
    ts = sample_grid(float(p("controller.servo_rate")), t_end)
    idx = np.clip(np.searchsorted(traj.servo_t, ts, side="right") - 1, 0, traj.servo_t.size - 1)
    tau = np.where((ts < traj.servo_t[0])[:, None], traj.tau_static[None, :], traj.servo_tau[idx])

    measured = xr.Dataset(
        {
            "q_enc": _var(q_meas, spec["q_enc"]),
            "theta_pend": _var(theta, spec["theta_pend"]),
            "f_piezo": _var(f_meas, spec["f_piezo"]),
            "ft_force": _var(force, spec["ft_force"]),
            "ft_torque": _var(torque, spec["ft_torque"]),
            "tau_cmd": _var(tau, spec["tau_cmd"]),
            "q_cmd": _var(plant.q0.copy(), spec["q_cmd"]),
            "hammer_mass_eff": _var(np.float64(plant.pend.m_b), spec["hammer_mass_eff"]),
            "pendulum_radius": _var(np.float64(plant.pend.radius), spec["pendulum_radius"]),
            "impact_direction": _var(plant.n.copy(), spec["impact_direction"]),
            "piezo_full_scale": _var(np.float64(fs), spec["piezo_full_scale"]),
        },
        coords={"t_joint": _time("t_joint", tj), "t_pend": _time("t_pend", tp), "t_force": _time("t_force", tf),
                "t_ft": _time("t_ft", tft), "t_servo": _time("t_servo", ts), "joint": ("joint", joints),
                "axis": ("axis", ["x", "y", "z"])},
    )

    # truth
    tt = sample_grid(float(p("sensors.truth_rate")), t_end)
    Xt, _ = sampler(tt)
    f_t = sampler.contact_force(tt)
    tip_v = np.empty(tt.size)
    energy = np.empty(tt.size)
    # tip velocity and energy are exact at the samples (Pinocchio per sample); before the
    # touch and after the integration stopped the arm is at rest
    pre = tt < traj.t_contact
    post = tt > traj.t[-1]
    tip_v[pre | post] = 0.0
    for k in np.flatnonzero(~(pre | post)):
        _, Jn = plant.tip(Xt[k, :nv])
        tip_v[k] = float(Jn @ Xt[k, plant.i_v])
        energy[k] = plant.energy(Xt[k])
    for mask, xx in ((pre, None), (post, traj.x[-1])):
        if np.any(mask):
            if xx is None:   # pendulum swinging in: energy of the first pre-contact sample state
                energy[mask] = [plant.energy(Xt[k]) for k in np.flatnonzero(mask)[[0]]] * int(mask.sum())
            else:
                energy[mask] = plant.energy(xx)
    c0, c1, _ = traj.contacts[0]
    peak = float(np.max(sampler.contact_force(np.linspace(c0, c1, 2001))))
    truth = xr.Dataset(
        {
            "q": _var(Xt[:, :nv], spec["q"]),
            "v": _var(Xt[:, plant.i_v], spec["v"]),
            "theta": _var(Xt[:, plant.i_th], spec["theta"]),
            "theta_dot": _var(Xt[:, plant.i_thd], spec["theta_dot"]),
            "f_contact": _var(f_t, spec["f_contact"]),
            "tip_velocity_n": _var(tip_v, spec["tip_velocity_n"]),
            "energy": _var(energy, spec["energy"]),
            "contact_start": _var(np.float64(c0), spec["contact_start"]),
            "contact_end": _var(np.float64(c1), spec["contact_end"]),
            "v_a_pre": _var(np.float64(traj.v_a_pre), spec["v_a_pre"]),
            "v_a_post": _var(np.float64(traj.v_a_post), spec["v_a_post"]),
            "v_b_pre": _var(np.float64(traj.v_b_pre), spec["v_b_pre"]),
            "v_b_post": _var(np.float64(traj.v_b_post), spec["v_b_post"]),
            "impulse": _var(np.float64(traj.impulse), spec["impulse"]),
            "peak_force": _var(np.float64(peak), spec["peak_force"]),
            "e_contact": _var(np.float64(rig.plant.contact.restitution), spec["e_contact"]),
        },
        coords={"t_truth": _time("t_truth", tt), "joint": ("joint", joints)},
        attrs={"n_contacts": len(traj.contacts), "settled": int(traj.settled),
               "t_static": float(traj.t_static) if traj.t_static is not None else -1.0},
    )
    for name, ds in (("measured", measured), ("truth", truth)):
        for var in ds.data_vars.values():
            if var.dtype.kind == "f" and not np.all(np.isfinite(var.values)):
                raise SimulationError(f"channel {name}/{var.name} has non-finite values; nothing is stored")
    root = xr.Dataset(attrs={
        "scene_json": scene.to_json(), "scene_sha256": scene.sha256, "seed": int(scene.seed), "base": scene.base,
        "config": int(scene.config), "gain": scene.gain, "speed": float(scene.speed), "repeat": int(scene.repeat),
        "robot": robot.name, "scene_name": scene.name,
    })
    return xr.DataTree.from_dict({"/": root, "/measured": measured, "/truth": truth})
