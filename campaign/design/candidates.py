"""Candidate poses for the experiment design, and which of them the rig can strike.

Candidates (:func:`grid_candidates`, :func:`random_candidates`, :func:`read_candidates`)
are paper-degree poses with horizontal impact directions; :func:`paper_design` is the
paper's three configurations. :func:`feasible` keeps those the rig can strike (joint
limits, the pendulum's placement, :mod:`campaign.rig.placement`, and a hammer lighter than
the arm's free effective mass); :func:`rig_refusal` checks a chosen pose again by
assembling its rig (:func:`campaign.rig.trial.build`) for every gain and speed, which
also refuses a pose whose servo would be unstable.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.files import check_regular_file, open_regular
from ..core.vocabulary import FIXED
from ..model.exiit import effective_mass
from ..model.paper import impact_direction, load_paper, paper_offset_deg, paper_q
from ..rig.pendulum import Pendulum
from ..rig.placement import place_pendulum, placement_params
from ..rig.trial import build
from ..scene.description import (
    check_direction,
    direction_from_azimuth,
    load_rig,
    make_scene,
)

__all__ = ["grid_candidates", "random_candidates", "read_candidates", "paper_design", "feasible", "rig_refusal"]


def _directions_from(azimuths) -> np.ndarray:
    return np.array([direction_from_azimuth(a) for a in azimuths], float)


def grid_candidates(*, q1=(-45.0, 0.0, 45.0), q2=tuple(range(90, 226, 15)), q3=tuple(range(-30, 136, 15)),
                    azimuths=tuple(range(-150, 181, 30))) -> tuple[np.ndarray, np.ndarray]:
    """Every combination of paper-degree joint angles and direction azimuths (from -x about +z).

    Returns
    -------
    Q : ndarray, shape (N, 3)
        Poses, paper degrees.
    D : ndarray, shape (N, 3)
        Horizontal unit directions.
    """
    grid = np.array(np.meshgrid(q1, q2, q3, azimuths, indexing="ij"), float).reshape(4, -1).T
    return grid[:, :3].copy(), _directions_from(grid[:, 3])


def random_candidates(n: int, *, robot, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` poses uniform within the joint limits (paper degrees) with uniform azimuths, seeded."""
    if not (isinstance(n, (int, np.integer)) and n > 0):
        raise InputError(f"number of random candidates must be an integer > 0, got {n!r}")
    rng = np.random.default_rng(seed)
    off = paper_offset_deg()
    lo, hi = np.degrees(robot.q_lower) - off, np.degrees(robot.q_upper) - off
    Q = rng.uniform(lo, hi, size=(n, robot.nv))
    return Q, _directions_from(rng.uniform(-180.0, 180.0, size=n))


def read_candidates(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Candidates from a CSV with columns ``q1,q2,q3`` (paper degrees) and either ``azimuth``
    (deg from -x about +z) or ``nx,ny,nz``; each direction is checked (horizontal, unit)."""
    path = check_regular_file(path, what="candidate file")
    Q, D = [], []
    with open_regular(path, "rb", what="candidate file") as fh:
        raw = fh.read()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"candidate file {path}: not a CSV table (not UTF-8 text: {exc.reason} at byte "
                         f"{exc.start})") from None
    reader = csv.DictReader(io.StringIO(text, newline=""))
    cols = set(reader.fieldnames or ())
    if not {"q1", "q2", "q3"} <= cols or not ({"azimuth"} <= cols or {"nx", "ny", "nz"} <= cols):
        raise InputError(f"{path}: needs columns q1,q2,q3 and azimuth or nx,ny,nz; has {sorted(cols)}")
    for line, row in enumerate(reader, 2):
        try:
            Q.append([float(row[k]) for k in ("q1", "q2", "q3")])
            if "azimuth" in cols and row.get("azimuth", "") != "":
                D.append(_directions_from([float(row["azimuth"])])[0])
            else:
                D.append(check_direction([float(row[k]) for k in ("nx", "ny", "nz")]))
        except (ValueError, InputError) as exc:
            raise InputError(f"{path}, line {line}: {exc}") from None
    if not Q:
        raise InputError(f"{path} lists no candidate")
    return np.array(Q, float), np.array(D, float)


def paper_design() -> tuple[np.ndarray, np.ndarray]:
    """The paper's three configurations (paper degrees) and its impact direction."""
    table = load_paper()["configurations"]
    Q = np.array([table[k] for k in sorted(table)], float)
    return Q, np.repeat(impact_direction()[None, :], len(Q), axis=0)


def feasible(robot, Q_paper, D, *, speed: float, rig=None) -> tuple[np.ndarray, list[str]]:
    """Which candidates the rig can strike at ``speed`` (the largest of the campaign).

    Returns
    -------
    ok : ndarray of bool, shape (N,)
    reasons : list of str
        Why each refused candidate is refused ("" where ok).
    """
    p, _ = load_rig(rig)
    pend = Pendulum.from_values(p)
    theta0 = pend.release_angle(speed)
    place = placement_params(p)
    data = robot.model.createData()
    ok = np.zeros(len(Q_paper), bool)
    reasons = []
    Q = paper_q(Q_paper) if len(Q_paper) else []
    for i, (q, n) in enumerate(zip(Q, D, strict=True)):
        try:
            if place is not None:
                place_pendulum(robot, q, n, radius=pend.radius, release_angle=theta0, data=data, **place)
            else:
                robot.check_q(q)
            if pend.m_b >= effective_mass(robot, q, n, data=data):
                raise InputError("hammer not lighter than the arm's free effective mass")
        except (InputError, ValueError) as exc:
            reasons.append(str(exc))
            continue
        ok[i] = True
        reasons.append("")
    return ok, reasons


def rig_refusal(q_paper, n, *, gains: Sequence[str], speeds: Sequence[float], rig=None) -> str:
    """Why the rig refuses to assemble a pose for some gain set and speed ("" if it never does)."""
    for gain in gains:
        for v in speeds:
            try:
                build(make_scene(base=FIXED, config=0, q_paper_deg=[float(x) for x in q_paper],
                                 direction=[float(x) for x in n], gain=gain, speed=float(v), rig=rig))
            except (InputError, ValueError) as exc:
                return f"{gain} gains, {v:g} m/s: {exc}"
    return ""
