"""campaign: a reproducible simulated re-run of Yoshida, Mavroidis & Dubowsky,
"Impact Dynamics of Space Long Reach Manipulators", on a simulated MIT VES-II.

Stages (one module each, data flowing down this list): ``robot`` (URDF + drives ->
Pinocchio), ``exiit`` (eqs 5-14), ``scene`` (one trial's description), ``rig`` (the
simulated VES-II -> raw channels), ``archive`` (HDF5/NetCDF trial files), ``identify``
(m*, e per trial), ``fit`` (Virtual Rotor Inertia), ``tables`` and ``figures``.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("campaign")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
