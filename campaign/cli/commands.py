"""The ``campaign`` subcommands: each one's module under :mod:`campaign.cli` and its help line.

Standard library only: ``campaign --help`` lists the subcommands from here without importing
any stage, and ``campaign COMMAND ...`` imports only the module of COMMAND.
"""

from __future__ import annotations

__all__ = ["COMMANDS", "HELP"]

#: subcommand -> the module of campaign.cli that registers it, in the order --help lists them
COMMANDS = {
    "meff": "meff", "plan": "plan", "map": "map", "trial": "trial", "sweep": "sweep", "design": "design",
    "archive": "archive", "identify": "identify", "fit-lambda": "identify", "recorded-lambda": "recorded",
    "tables": "identify",
    "calibrate": "calibrate", "bench": "bench", "import": "recordings", "identify-recordings": "recordings",
}

#: subcommand -> its one-line help
HELP = {
    "meff": "effective mass of the tip along an impact direction (eq 11), or the paper's Table 2",
    "plan": "rank the arm's poses, gain classes and impact directions for catching an object at a point",
    "map": "maps of m* and structure excitation over the workspace or the impact direction",
    "trial": "simulate one impact trial and write its NetCDF4/HDF5 file",
    "sweep": "simulate a sweep of trials and write one file per trial",
    "design": "choose K arm poses and impact directions that identify lambda best (D-, A- or E-optimal)",
    "archive": "verify, finalize and list a campaign folder of trial files",
    "identify": "identify m* (eq 10) and e (eq 12) of trial files from their measured channels",
    "fit-lambda": "fit the Virtual Rotor Inertia lambda per gain class over an archive's fixed-base trials",
    "recorded-lambda": "what recorded hits' poses determine of lambda, and one session's fit predicting another",
    "tables": "write Tables 2-4 (CSV and Markdown) from an archive, beside the paper's values",
    "calibrate": "fit unpublished rig parameters to the paper's fixed-base observations",
    "bench": "work-precision / per-trial cost benchmark and the numerical stress suite",
    "import": "import a real robot's recorded hits (air-hockey layout or mapped CSV) into a recording folder",
    "identify-recordings": "identify m* and e by momentum balance per recorded hit, with intervals",
}
