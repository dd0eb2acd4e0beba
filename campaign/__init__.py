"""campaign: a reproducible simulated re-run of Yoshida, Mavroidis & Dubowsky,
"Impact Dynamics of Space Long Reach Manipulators", on a simulated MIT VES-II.

One package per stage, each importing only from its own package and those listed before
it (:data:`LAYERS`, bottom up; ``tests/project/test_layout.py`` enforces the order):

``core``      errors, the vocabulary (bases, gain sets, trial paths), files, YAML, progress
``model``     the paper's conventions, the robot (URDF + drives -> Pinocchio), the Ex-IIT (eqs 5-14)
``scene``     one trial's validated description, its rig parameters and the channels it records
``rig``       the simulated VES-II: plant, integrator, servo, sensors, structures, VES loop
``archive``   trial files, campaign folders, manifest, verification
``identify``  m* (eq 10) and e (eq 12) per trial from the measured channels; identification tables
``recordings`` real robots' recorded hits: import, recording files, m* and e by momentum balance
``joints``    joint-resistance models: the lambda fits (eq 11, 15), Coulomb, joint impedance
``plan``      the impact planner, its factory, compression and post-contact terms, the stroke check
``design``    experiment design and the designed campaign
``studies``   experiments on the rig whose results the user guide and the report show (one module each)
``report``    Tables 2-4, the figures, HTML pages
``bench``     work-precision, per-trial cost and stress suites behind ``campaign bench``
``pipeline``  the workflow's jobs: paths, configuration checks, stage digests, job logs, calibration
``cli``       the ``campaign`` command: argument parsing, one module per subcommand
"""

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _version

__all__ = ["LAYERS", "__version__"]

#: the packages of the campaign package, bottom up: a module imports only from its own package and those before it
LAYERS = ("core", "model", "scene", "rig", "archive", "identify", "recordings", "joints", "plan", "design", "studies", "report",
          "bench", "pipeline", "cli")

try:
    __version__ = _version("campaign")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
