"""The paper's Table 2 recomputed from the model: m1, m2 and m3 of configurations 1-3 (eq 7, 11).

``m1`` uses lambda = 0, ``m2`` and ``m3`` the paper's Table 3 lambda of the Zero/Low and High
gain classes; the fixed base and the paper's impact direction, all from ``config/paper.yaml``.
``campaign meff --table`` prints it beside the published values.
"""

from __future__ import annotations

from ..core.vocabulary import table2_columns
from .exiit import effective_mass
from .paper import configuration_q, impact_direction, load_paper
from .robot import load_robot

__all__ = ["table2_column_classes", "table2_rows"]


def table2_column_classes() -> tuple[tuple[str, str | None], ...]:
    """Table 2's columns: (column, the Table 3 gain class whose lambda it uses, None for
    lambda = 0); m2 and m3 as ``config/paper.yaml`` maps them."""
    return (("m1", None), *table2_columns().items())


def table2_rows(robot=None) -> list[dict]:
    """Table 2 of the paper recomputed: one row per (configuration, column).

    Parameters
    ----------
    robot : campaign.model.robot.Robot, optional
        The arm; default the paper's robot.

    Returns
    -------
    list of dict
        Keys ``config``, ``column``, ``gain_class`` (None for m1), ``lambda`` [kg m^2],
        ``model`` [kg], ``paper`` [kg], ``rel_diff`` = (model - paper) / paper.
    """
    paper = load_paper()
    robot = load_robot(paper["robot"]) if robot is None else robot
    n = impact_direction()
    rows = []
    for column, gain_class in table2_column_classes():
        lam = [0.0] * robot.nv if gain_class is None else [float(v) for v in paper["table3"][gain_class]]
        for config in sorted(paper["configurations"]):
            model = effective_mass(robot, configuration_q(config), n, lam)
            published = float(paper["table2"][column][config])
            rows.append({
                "config": int(config), "column": column, "gain_class": gain_class, "lambda": lam,
                "model": model, "paper": published, "rel_diff": (model - published) / published,
            })
    return rows
