"""The lean trial loop (campaign.rig.trial_run on the float kernels of campaign.rig.kernels)
against the loop it replaced (tests/reference_loop.py: NumPy arrays through the plant's own
array methods): every step, every recorded channel and the truth, bit for bit.

The lean loop evaluates the same functions in the same order on Python floats (elementwise
IEEE operations give the same bits on a float as on an array element; the few dot products
are summed in the order of the BLAS kernel NumPy calls), so no tolerance is needed. Its only
intended difference is the count of right-hand-side evaluations: locating an event it
evaluates that event's function alone (a stop needs only the state, a contact event the
kinematics), where the reference evaluated the whole dynamics for every event function.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference_loop import integrate_reference

from campaign.core.errors import SimulationError
from campaign.model.paper import gain_counts
from campaign.rig.flexible import VesLoopPlant
from campaign.rig.integrate import integrate_trial
from campaign.rig.kernels import ArrayKernel, FixedKernel, VesKernel, kernel_for
from campaign.rig.simulate import build, integration_args, record_arrays
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

_FIELDS = ("t", "x", "xd", "servo_t", "servo_tau", "tau_static", "x0")
_VALUES = ("contacts", "v_a_post", "v_b_post", "impulse", "t_end", "t_static", "settled", "n_steps", "n_events")


def _same_array(a, b, label):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape, (label, a.dtype, b.dtype, a.shape, b.shape)
    assert a.tobytes() == b.tobytes(), f"{label}: largest difference {np.max(np.abs(a - b))}"


def _compare(scene, integration=None):
    ref_rig, lean_rig = build(scene, integration=integration), build(scene, integration=integration)
    ref = integrate_reference(ref_rig.plant, ref_rig.pid, **integration_args(ref_rig))
    lean = integrate_trial(lean_rig.plant, lean_rig.pid, **integration_args(lean_rig))
    for name in _FIELDS:
        _same_array(getattr(lean, name), getattr(ref, name), name)
    for name in _VALUES:
        assert getattr(lean, name) == getattr(ref, name), name
    assert lean.n_rhs <= ref.n_rhs
    a, b = record_arrays(ref_rig, ref), record_arrays(lean_rig, lean)
    assert a.attrs == b.attrs
    for group in ("measured", "truth"):
        assert a[group].attrs == b[group].attrs, group
        assert set(a[group].variables) == set(b[group].variables), group
        for name, var in a[group].variables.items():
            _same_array(b[group].variables[name].values, var.values, f"{group}/{name}")


@pytest.mark.parametrize("label", list(SCENES))
def test_the_lean_loop_records_every_channel_of_the_reference_loop_bit_for_bit(label):
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
def test_each_kernel_evaluates_the_plants_array_methods_bit_for_bit(label, kernel):
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
    for x, tau, fs, v0, caught in _random_states(plant, rng, 120):
        xl, taul = x.tolist(), tuple(tau.tolist())
        assert k.stage(xl, t, taul, fs, v0, caught) == plant.rhs(x, tau, fs, v0, caught, t).tolist()
        xd, lam, gap = plant.evaluate(x, tau, fs, v0, caught, t)
        got = k.full(xl, t, taul, fs, v0, caught)
        assert got[0] == xd.tolist() and got[1] == np.asarray(lam).tolist()
        assert (got[2] is None) == (gap is None) and (gap is None or tuple(got[2]) == tuple(map(float, gap[:2])))
        assert k.holding(xl, t, taul, fs, v0) == np.asarray(plant.holding(x, tau, fs, v0, t)[0]).tolist()
        plant._t = t
        assert tuple(k.gap(xl, t)) == tuple(map(float, plant.gap(x)[:2]))
