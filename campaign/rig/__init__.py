"""The simulated VES-II: the truth behind every "measurement" of the campaign.

``simulate(scene) -> xarray.DataTree`` with ``/measured`` (raw channels) and ``/truth``;
``simulate_arrays(scene)`` gives the same as plain arrays (``campaign.scene.schema.TrialArrays``).
Modules: :mod:`~campaign.rig.contact`, :mod:`~campaign.rig.pendulum`,
:mod:`~campaign.rig.controller`, :mod:`~campaign.rig.plant`, :mod:`~campaign.rig.integrate`,
:mod:`~campaign.rig.sensors`, :mod:`~campaign.rig.trial`; the flexible base adds
:mod:`~campaign.rig.beam`, :mod:`~campaign.rig.ves`, :mod:`~campaign.rig.ideal_base`,
:mod:`~campaign.rig.flexible`. The methods: user guide, *The rig* (``docs/rig.rst``).
"""

from .trial import build, simulate, simulate_arrays

__all__ = ["simulate", "simulate_arrays", "build"]
