"""The lean trial loop (campaign.rig.trial_run on the float kernels of campaign.rig.kernels)
against the loop it replaced (tests/reference_loop.py: NumPy arrays through the plant's own
array methods): every step, every recorded channel and the truth, within the tolerance
policy's cross-path tolerance (campaign.core.tolerance.CROSS_PATH_RTOL) of each quantity's
scale, and tight enough that a change of one part in 10^9 of a rig parameter fails it.

The lean loop evaluates the same functions in the same order on Python floats, but a
product formed on Python floats and the dot products NumPy hands to its BLAS kernel round
differently on some kernels (AVX-512, Prescott), so the two paths agree to roundoff, not
always bit for bit. Its only intended difference is the count of right-hand-side
evaluations: locating an event it evaluates that event's function alone (a stop needs only
the state, a contact event the kinematics), where the reference evaluated the whole
dynamics for every event function.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference_loop import integrate_reference

from campaign.core.errors import SimulationError
from campaign.core.tolerance import CROSS_PATH_RTOL, compare, differences, worst
from campaign.model.paper import gain_counts
from campaign.rig.flexible import VesLoopPlant
from campaign.rig.integrate import integrate_trial
from campaign.rig.kernels import ArrayKernel, FixedKernel, VesKernel, kernel_for
from campaign.rig.trial import build, integration_args, record_arrays
from campaign.scene.description import make_scene

_STIFF = {"flexible.structure": "stiff_mast"}
_IDEAL_COUPLING = {"ves.mode": "ideal", "flexible.structure": "stiff_mast", "flexible.trial_periods": 0.3}


def _scene(base, config, gain, speed, params=None):
    return make_scene(base=base, config=config, gain=gain, speed=speed, gains_counts=gain_counts(gain),
                      campaign_seed=1996, params=params or {})


#: fixed and flexible bases, every gain set, configurations 1-3, the ideal scene, the ideal
#: coupling, the VES loop on both structures with the frozen arm's linear phases on and off
SCENES = {
    **{f"fixed/config{c}/{g}/v{v}": _scene("fixed", c, g, v) for c in (1, 2, 3) for g in ("zero", "low", "high")
       for v in ((1.5, 2.5) if c == 1 else (2.5,))},
    **{f"flexible/config{c}/{g}": _scene("flexible", c, g, 2.5) for c, g in ((1, "high"), (2, "low"), (2, "zero"))},
    "flexible/config3/high/v1.5": _scene("flexible", 3, "high", 1.5),
    "flexible/config2/low, linear phases off": _scene("flexible", 2, "low", 2.5, {"flexible.linear_phases": False}),
    "flexible/config1/high/v1.5, linear phases off": _scene("flexible", 1, "high", 1.5,
                                                           {"flexible.linear_phases": False}),
    "flexible stiff mast/config1/high": _scene("flexible", 1, "high", 2.5, _STIFF),
    "flexible stiff mast/config2/zero/v1.5": _scene("flexible", 2, "zero", 1.5, _STIFF),
    **{f"ideal scene/config{c}": make_scene(scene="ideal", config=c, speed=v)
       for c, v in ((1, 1.0), (2, 2.5), (3, 1.0))},
    "ideal coupling/config1/high": _scene("flexible", 1, "high", 2.5, _IDEAL_COUPLING),
    "ideal coupling/config2/low/v1.5": _scene("flexible", 2, "low", 1.5, _IDEAL_COUPLING),
    "ideal coupling, free base": make_scene(base="flexible", scene="ideal", config=2, speed=1.5,
                                            params={"ves.mode": "ideal", "flexible.trial_periods": 0.02}),
}

#: the trajectory's arrays; those whose columns are separate quantities (state components, joints)
_FIELDS = ("t", "x", "xd", "servo_t", "servo_tau", "tau_static", "x0")
_COLUMNS = ("x", "xd", "servo_tau", "tau_static", "x0", "contacts")
_VALUES = ("contacts", "v_a_pre", "v_b_pre", "v_a_post", "v_b_post", "impulse", "t_end", "t_static", "settled",
           "n_steps", "n_events")


def _value(x):
    """A trajectory value as numbers (an open contact's end and an absent time as NaN)."""
    if x is None:
        return np.nan
    if isinstance(x, list):
        return np.array([[np.nan if v is None else v for v in item] for item in x], dtype=float)
    return x


def _group_attrs(attrs):
    return {k: (np.asarray(v).astype(str) if isinstance(v, str) else v) for k, v in attrs.items()}


def _differences(scene, integration=None, *, lean_scene=None):
    """Every difference of the lean loop (on ``lean_scene``, default ``scene``) from the
    reference loop: trajectory, event values and counts, each recorded channel and the truth,
    under the cross-path tolerance."""
    ref_rig, lean_rig = build(scene, integration=integration), build(lean_scene or scene, integration=integration)
    ref = integrate_reference(ref_rig.plant, ref_rig.pid, **integration_args(ref_rig))
    lean = integrate_trial(lean_rig.plant, lean_rig.pid, **integration_args(lean_rig))
    names = _FIELDS + _VALUES
    found = differences({n: _value(getattr(ref, n)) for n in names}, {n: _value(getattr(lean, n)) for n in names},
                        rtol=CROSS_PATH_RTOL, prefix="trajectory ", per_column=_COLUMNS)
    assert lean.n_rhs <= ref.n_rhs
    a, b = record_arrays(ref_rig, ref), record_arrays(lean_rig, lean)
    for group in ("measured", "truth"):
        found += differences(_group_attrs(a[group].attrs), _group_attrs(b[group].attrs), rtol=CROSS_PATH_RTOL,
                             prefix=f"{group} attribute ")
        found += differences({k: v.values for k, v in a[group].variables.items()},
                             {k: v.values for k, v in b[group].variables.items()},
                             rtol=CROSS_PATH_RTOL, prefix=f"{group}/")
    return found, (a.attrs, b.attrs)


def _compare(scene, integration=None):
    found, (ref_attrs, lean_attrs) = _differences(scene, integration)
    assert ref_attrs == lean_attrs
    beyond = [str(d) for d in found if not d.ok]
    assert beyond == [], beyond
    return worst(found)


@pytest.mark.parametrize("label", list(SCENES))
def test_the_lean_loop_records_every_channel_of_the_reference_loop_to_roundoff(label):
    _compare(SCENES[label])


def test_the_stress_corners_integrate_as_the_reference_loop_does():
    from campaign import bench

    compared = 0
    for case in bench.stress_cases(reduced=True):
        scene = case.make()
        try:
            build(scene, integration=case.integration)
        except ValueError:      # refused up front: no loop runs
            continue
        _compare(scene, case.integration)
        compared += 1
    assert compared >= 5


def test_a_change_of_one_part_in_a_billion_of_the_hammer_mass_fails_the_oracle():
    # the lean loop on a hammer 1e-9 heavier: the oracle must see it, far beyond its tolerance
    scene = SCENES["fixed/config2/low/v2.5"]
    planted = _scene("fixed", 2, "low", 2.5, {"pendulum.head_mass": scene.p("pendulum.head_mass") * (1 + 1e-9)})
    found, _ = _differences(scene, lean_scene=planted)
    moved = worst(found)
    assert not moved.ok, str(moved)
    assert moved.largest > 100 * moved.allowed, str(moved)
    # and many quantities see it, not one channel by accident
    assert sum(not d.ok for d in found) >= 10, [str(d) for d in found if not d.ok]


def test_a_blow_up_and_an_event_cascade_fail_as_in_the_reference_loop():
    # negative joint damping (energy fed in at every step): far beyond what RK4 at the servo
    # substep can follow the joints' stop events cascade; moderately the state overflows
    for scale, message in ((-1e6, "events within one servo tick"), (-1e2, "blew up")):
        errors = []
        for integrate in (integrate_reference, integrate_trial):
            rig = build(_scene("fixed", 3, "high", 2.5) if scale < -1e3 else _scene("fixed", 2, "high", 1.5))
            rig.plant.viscous = scale * np.abs(rig.plant.viscous)
            with pytest.raises(SimulationError, match=message) as err:
                integrate(rig.plant, rig.pid, **integration_args(rig))
            errors.append(str(err.value))
        assert errors[0] == errors[1]


def _random_states(plant, rng, n):
    """States near the plant's pose with random rates, torques and friction modes."""
    nv = plant.nv
    for k in range(n):
        x = np.zeros(plant.size)
        x[:nv] = plant.q0 + rng.normal(0.0, 0.01, nv)
        x[nv] = rng.normal(0.0, 0.05)
        x[plant.i_v] = rng.normal(0.0, 0.3, nv)
        if k % 3 == 0:
            x[plant.i_v.start] = 0.0
        x[plant.i_thd] = rng.normal(0.0, 3.0)
        x[plant.i_P] = rng.normal()
        tau = rng.normal(0.0, 20.0, nv) * np.asarray(plant.sticky | ~plant.sticky.any(), float)
        modes = np.where(plant.sticky, rng.choice([-1, 0, 1], nv), 1)
        yield x, tau, plant.friction_state(modes, x[:nv]), (None if k % 2 else 0.7), k % 5 == 0


@pytest.mark.parametrize("label, kernel", [("fixed/config1/high/v1.5", FixedKernel),
                                           ("fixed/config3/low/v2.5", FixedKernel),
                                           ("flexible/config2/low", VesKernel),
                                           ("ideal coupling/config1/high", ArrayKernel)])
def test_each_kernel_evaluates_the_plants_array_methods_to_roundoff(label, kernel):
    plant = build(SCENES[label]).plant
    k = kernel_for(plant)
    assert type(k) is kernel
    rng = np.random.default_rng(7)
    if isinstance(plant, VesLoopPlant):
        # the platform in motion: the emulator stepped under a swinging wrench
        for i in range(40):
            plant.loop.advance(plant.w_static + np.array([30.0 * np.sin(0.3 * i), 5.0, 0.0, 0.0, 2.0, -1.0]))
        plant._cache = {}
    t = plant.t_last + 0.37e-3 if isinstance(plant, VesLoopPlant) else 0.2
    kernel_out, plant_out = {}, {}

    def both(key, k_value, p_value):
        kernel_out.setdefault(key, []).append(k_value)
        plant_out.setdefault(key, []).append(p_value)

    for x, tau, fs, v0, caught in _random_states(plant, rng, 120):
        xl, taul = x.tolist(), tuple(tau.tolist())
        both("stage", k.stage(xl, t, taul, fs, v0, caught), plant.rhs(x, tau, fs, v0, caught, t).tolist())
        xd, lam, gap = plant.evaluate(x, tau, fs, v0, caught, t)
        got = k.full(xl, t, taul, fs, v0, caught)
        both("full xd", got[0], xd.tolist())
        both("full holding torques", list(got[1]), np.asarray(lam).tolist())
        assert (got[2] is None) == (gap is None)
        if gap is not None:
            both("full gap", tuple(got[2]), tuple(map(float, gap[:2])))
        both("holding", list(k.holding(xl, t, taul, fs, v0)), np.asarray(plant.holding(x, tau, fs, v0, t)[0]).tolist())
        plant._t = t
        both("gap", tuple(k.gap(xl, t)), tuple(map(float, plant.gap(x)[:2])))
    # each output over the 120 states as one channel: state components and the gap's terms
    # column by column, the holding torques of the stuck joints (as many as stick) as one
    found = []
    for key in kernel_out:
        ragged = "torques" in key or key == "holding"
        k_value = np.concatenate([np.ravel(v) for v in kernel_out[key]]) if ragged else np.array(kernel_out[key])
        p_value = np.concatenate([np.ravel(v) for v in plant_out[key]]) if ragged else np.array(plant_out[key])
        found.append(compare(k_value, p_value, name=key, rtol=CROSS_PATH_RTOL, per_column=not ragged))
    beyond = [str(d) for d in found if not d.ok]
    assert beyond == [], beyond
