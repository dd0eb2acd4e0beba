"""The paper's conventions, the robot (URDF + drives -> Pinocchio) and the Ex-IIT (eqs 5-14).

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`): the
workflow's start-up reads :mod:`campaign.model.conventions` without Pinocchio. The modules:
:mod:`~campaign.model.paper` (``config/paper.yaml``), :mod:`~campaign.model.conventions`,
:mod:`~campaign.model.robot` (with :mod:`~campaign.model.robot.floating` and
:mod:`~campaign.model.robot.ik`), :mod:`~campaign.model.exiit`, :mod:`~campaign.model.table2`.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "load_paper", "paper_robot", "paper_q", "paper_offset_deg", "configuration_q", "impact_direction",
    "gain_counts", "configurations", "angle_count", "Robot", "load_robot", "ROBOTS_DIR", "BaseBody",
    "attach_to_floating_base", "impact_point", "position_branches", "effective_mass", "effective_mass_batch",
    "exiit_fixed", "exiit_floating", "impact_jacobian", "table2_rows",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "paper": ("load_paper", "paper_robot", "paper_q", "paper_offset_deg", "configuration_q", "impact_direction",
              "gain_counts"),
    "conventions": ("configurations", "angle_count"),
    "robot": ("Robot", "load_robot", "ROBOTS_DIR"),
    "robot.floating": ("BaseBody", "attach_to_floating_base"),
    "robot.ik": ("impact_point", "position_branches"),
    "exiit": ("effective_mass", "effective_mass_batch", "exiit_fixed", "exiit_floating", "impact_jacobian"),
    "table2": ("table2_rows",),
})
