"""The simulated VES-II: the truth behind every "measurement" of the campaign.

``simulate(scene) -> xarray.DataTree`` with ``/measured`` (raw channels) and ``/truth``;
``simulate_arrays(scene)`` gives the same as plain arrays (``campaign.scene.schema.TrialArrays``).
Modules: :mod:`~campaign.rig.contact`, :mod:`~campaign.rig.pendulum`,
:mod:`~campaign.rig.controller`, :mod:`~campaign.rig.plant`, :mod:`~campaign.rig.integrate`,
:mod:`~campaign.rig.sensors`, :mod:`~campaign.rig.trial`; the flexible base adds
:mod:`~campaign.rig.beam`, :mod:`~campaign.rig.ves`, :mod:`~campaign.rig.ideal_base`,
:mod:`~campaign.rig.flexible`. The methods: user guide, *The rig* (``docs/rig.rst``).
"""

from .base_mass import flexible_base_body, mass_on_base
from .batch import simulate_batch
from .beam import Beam
from .contact import ContactLaw, pulse_shape
from .controller import PID, joint_gains
from .pendulum import Pendulum
from .trial import build, check_stroke, simulate, simulate_arrays, structure_modes

__all__ = ["simulate", "simulate_arrays", "build", "simulate_batch", "check_stroke", "structure_modes", "Beam",
           "ContactLaw", "pulse_shape", "PID", "joint_gains", "Pendulum", "flexible_base_body", "mass_on_base"]
