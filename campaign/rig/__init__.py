"""The simulated VES-II: the truth behind every "measurement" of the campaign.

``simulate(scene) -> xarray.DataTree`` with ``/measured`` (raw channels) and ``/truth``;
``simulate_arrays(scene)`` gives the same as plain arrays (``campaign.schema.TrialArrays``).
Modules: :mod:`.contact`, :mod:`.pendulum`, :mod:`.controller`, :mod:`.plant`,
:mod:`.integrate`, :mod:`.sensors`, :mod:`.simulate`; the flexible base adds
:mod:`.beam`, :mod:`.ves`.
"""

from .simulate import build, simulate, simulate_arrays

__all__ = ["simulate", "simulate_arrays", "build"]
