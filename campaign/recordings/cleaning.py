"""What a logged recording needs before identification: stale rows, stamp glitches, a second clock.

* A logger that writes a row on its own tick repeats the previous pose when no new message
  arrived: such rows carry no sample and are dropped (:func:`drop_stale`).
* A stamp off by a fraction of a period between two regular neighbours is a glitch of the
  stamp, not of the sample: it is put back half-way between its neighbours; an irregular
  stamp that cannot be explained so is counted and the row dropped (:func:`repair_stamps`).
* The object's clock (motion capture) and the robot's differ by an offset: the object's
  onset of motion is matched to the end effector's deceleration along the impact direction
  (:func:`clock_offset`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .contact import Body, fit_contact, fit_onset, noise_level

__all__ = ["StampReport", "drop_stale", "repair_stamps", "clock_offset", "impact_direction_of", "MAX_CLOCK_OFFSET"]

#: the largest clock offset searched [s]
MAX_CLOCK_OFFSET = 0.025


@dataclasses.dataclass(frozen=True)
class StampReport:
    """What :func:`repair_stamps` did: stamps repaired (put half-way between their neighbours)
    and rows dropped (stamps out of order or irregular beyond repair)."""

    repaired: int
    dropped: int


def drop_stale(values: np.ndarray) -> np.ndarray:
    """Mask of the rows to keep: a row equal to the previous row in every column is stale."""
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    keep = np.ones(len(values), dtype=bool)
    keep[1:] = np.any(values[1:] != values[:-1], axis=1)
    return keep


def repair_stamps(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, StampReport]:
    """Repair the stamps of a nominally periodic log.

    A stamp whose interval to its predecessor is off the period by more than 40 % while the
    two intervals around it add up to two periods (within 25 %) is a glitch: it is set
    half-way between its neighbours. Stamps that then still go backwards, or repeat, are
    dropped.

    Returns
    -------
    t : ndarray
        The repaired stamps.
    keep : ndarray of bool
        Rows to keep.
    report : StampReport
    """
    t = np.array(t, dtype=float)
    if len(t) < 3:
        return t, np.ones(len(t), dtype=bool), StampReport(0, 0)
    period = float(np.median(np.diff(t)))
    repaired = 0
    for k in range(1, len(t) - 1):
        d1, d2 = t[k] - t[k - 1], t[k + 1] - t[k]
        if abs(d1 - period) > 0.4 * period and abs(d1 + d2 - 2 * period) < 0.25 * period:
            t[k] = 0.5 * (t[k - 1] + t[k + 1])
            repaired += 1
    keep = np.ones(len(t), dtype=bool)
    last = t[0]
    for k in range(1, len(t)):
        if t[k] <= last + 0.1 * period:
            keep[k] = False
        else:
            last = t[k]
    return t, keep, StampReport(repaired, int((~keep).sum()))


def _velocity(t: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference velocities at the midpoints of the samples."""
    dt = np.diff(t)
    return 0.5 * (t[1:] + t[:-1]), np.diff(p, axis=0) / dt[:, None]


def impact_direction_of(t: np.ndarray, p: np.ndarray, *, span: float = 0.08) -> tuple[np.ndarray, float]:
    """The direction of the largest velocity change of a body and when it happens.

    The velocity change over ``span`` seconds (means of the finite-difference velocities
    in 15 ms either side) is largest across the contact; its direction is the impact
    direction n for the struck body. Returns (unit n, time of the change's centre).
    """
    tm, v = _velocity(np.asarray(t, float), np.asarray(p, float))
    best, centre, n = -1.0, float(tm[len(tm) // 2]), np.array([1.0, 0.0, 0.0])
    for tc in tm:
        before = (tm > tc - span / 2 - 0.015) & (tm <= tc - span / 2)
        after = (tm >= tc + span / 2) & (tm < tc + span / 2 + 0.015)
        if not before.any() or not after.any():
            continue
        dv = v[after].mean(axis=0) - v[before].mean(axis=0)
        size = float(np.linalg.norm(dv))
        if size > best:
            best, centre, n = size, float(tc), dv / size if size > 0 else n
    return n, centre


def clock_offset(t_robot: np.ndarray, ee: np.ndarray, t_object: np.ndarray, obj: np.ndarray, *,
                 max_offset: float = MAX_CLOCK_OFFSET) -> float:
    """The offset to add to the object's stamps to put them on the robot's clock [s].

    Along the object's impact direction n the object's velocity change (its onset of motion)
    and the end effector's (its deceleration) come from the same contact force. The
    object's contact window and the profile of its velocity change are fitted on its own
    clock (:func:`campaign.recordings.contact.fit_contact`), then the start of the same
    profile, scaled, in the end effector's positions on the robot's clock, within
    ``max_offset`` (:func:`campaign.recordings.contact.fit_onset`); the offset is the
    difference. The end effector of an arm follows the impulse as a point mass does over a
    short, stiff contact (found to within a millisecond on the rig); over a long, soft one
    its velocity lags the object's and the offset comes out some milliseconds short.
    """
    n, centre = impact_direction_of(t_object, obj)
    t_o, s_o = np.asarray(t_object, float), np.asarray(obj, float) @ n
    body = Body(t_o, s_o, noise_level(t_o, s_o), 0.05, 0.06)
    coarse = fit_contact([body], guess=centre, deg=2, search="refine")
    found = fit_contact([body], guess=coarse.t_s, deg=2, reach=0.02, min_T=max(0.004, coarse.T - 0.03),
                        max_T=coarse.T + 0.03)
    onset = fit_onset(np.asarray(t_robot, float), np.asarray(ee, float) @ n, T=found.T, shape=found.shape,
                      guess=found.t_s,
                      reach=max_offset, deg=2, pre=0.05, post=0.04)
    return onset - found.t_s
