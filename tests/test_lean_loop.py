"""The plants' float kernels (campaign.rig.kernels) against the plants' own array methods,
bit for bit: the same functions in the same order on Python floats (elementwise IEEE
operations give the same bits on a float as on an array element; the few dot products are
summed in the order of the BLAS kernel NumPy calls), so no tolerance is needed.
"""

from __future__ import annotations

import numpy as np
import pytest

from campaign.model.paper import gain_counts
from campaign.rig.flexible import VesLoopPlant
from campaign.rig.kernels import ArrayKernel, FixedKernel, VesKernel, kernel_for
from campaign.rig.simulate import build
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
