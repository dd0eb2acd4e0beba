"""Figure 5: joint 3 motion after impact (configuration 1, zero gains), as the paper recorded it.

(a) joint 3 displacement from its pre-impact angle and (b) joint 3 velocity, both from the
joint encoder samples (20 ms in the paper and in ``config/rig.yaml``); the velocity is the
finite difference of consecutive samples, plotted at their mid-times, as the paper's
numerical differentiation did. The simulator truth (group ``/truth``, sampled densely) is
the thin grey line. Time runs from the contact start found in the measured piezo force
(:func:`campaign.identify.detect_contact`); the contact interval is shaded. The paper's
"about 2.5 degrees" (``figure5_joint3_displacement_deg``) is drawn as a dotted line, with
the sign of the simulated displacement.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...archive import open_trial_arrays
from ...identify import detect_contact
from . import style

__all__ = ["JOINT", "series", "draw", "make"]

#: the joint the figure shows (0-based index of joint 3)
JOINT = 2


def series(trial: str | os.PathLike) -> dict:
    """The figure's data from one trial file (angles in deg, velocities in deg/s, time in s).

    Returns
    -------
    dict
        ``t_enc, disp_enc`` (encoder samples), ``t_vel, vel_enc`` (finite differences at
        mid-times), ``t_truth, disp_truth, vel_truth``, ``contact`` (start, end) from the
        piezo force, ``cell`` (the trial's cell), ``sample_interval`` [s].
    """
    # plain arrays: the job never imports xarray (~0.6 s)
    measured = open_trial_arrays(trial, group="measured")
    truth = open_trial_arrays(trial, group="truth")
    t_f = np.asarray(measured["t_force"].values, float)
    contact = detect_contact(t_f, np.asarray(measured["f_piezo"].values, float),
                             float(measured["piezo_full_scale"].values))
    if contact.n_contacts == 0:
        raise ValueError(f"{trial}: no contact found in the piezo force; Figure 5 needs an impact")
    t0 = contact.start
    t_enc = np.asarray(measured["t_joint"].values, float) - t0
    q = np.degrees(np.asarray(measured["q_enc"].values, float)[:, JOINT])
    before = t_enc < 0
    if not before.any():
        raise ValueError(f"{trial}: no joint encoder sample before the contact")
    q_ref = float(np.mean(q[before]))
    t_truth = np.asarray(truth["t_truth"].values, float) - t0
    q_truth = np.degrees(np.asarray(truth["q"].values, float)[:, JOINT])
    return {
        "t_enc": t_enc,
        "disp_enc": q - q_ref,
        "t_vel": 0.5 * (t_enc[1:] + t_enc[:-1]),
        "vel_enc": np.diff(q) / np.diff(t_enc),
        "t_truth": t_truth,
        "disp_truth": q_truth - float(np.mean(q_truth[t_truth < 0])),
        "vel_truth": np.degrees(np.asarray(truth["v"].values, float)[:, JOINT]),
        "contact": (0.0, contact.end - t0),
        "cell": f"{measured.attrs.get('base', '?')} base, configuration {measured.attrs.get('config', '?')}, "
                f"{measured.attrs.get('gain', '?')} gains, {float(measured.attrs.get('speed', np.nan)):g} m/s, "
                f"repeat {measured.attrs.get('repeat', '?')}",
        "sample_interval": float(np.median(np.diff(t_enc))),
    }


def draw(trial: str | os.PathLike, *, paper: Mapping[str, Any], t_min: float = -0.1):
    """Draw Figure 5 from one trial file (configuration 1, zero gains in the campaign).

    Parameters
    ----------
    trial : path-like
        A trial file (``campaign.archive``).
    t_min : float
        Start of the time axis relative to the contact [s].

    Returns
    -------
    matplotlib.figure.Figure
    """
    d = series(trial)
    paper_deg = float(paper["figure5_joint3_displacement_deg"])
    fig, (ax1, ax2) = style.new_figure(2, 1, width=5.2, height=4.6, sharex=True)
    t_max = float(d["t_enc"][-1])
    for ax in (ax1, ax2):
        ax.axvspan(*d["contact"], color="#f2c14e", alpha=0.35, lw=0, label="contact (piezo force)")
    ax1.plot(d["t_truth"], d["disp_truth"], color=style.TRUTH_COLOR, lw=0.7, label="simulator truth")
    ax1.plot(d["t_enc"], d["disp_enc"], "o-", color="#225588", ms=3.5, lw=1.0,
             label=f"encoder, {1e3 * d['sample_interval']:.0f} ms samples")
    final = d["disp_enc"][d["t_enc"] > d["contact"][1]]
    sign = float(np.sign(np.median(final))) if final.size and np.median(final) != 0 else 1.0
    ax1.axhline(sign * paper_deg, color=style.PAPER_COLOR, ls=":", lw=1.2,
                label=style.paper_label(f"about {paper_deg:g} deg"))
    ax1.set_ylabel("joint 3 displacement [deg]")
    ax1.set_title("(a) joint displacement", loc="left")
    ax1.legend(loc="best")
    ax2.plot(d["t_truth"], d["vel_truth"], color=style.TRUTH_COLOR, lw=0.7, label="simulator truth")
    ax2.step(d["t_vel"], d["vel_enc"], where="mid", color="#225588", lw=1.0, alpha=0.5)
    ax2.plot(d["t_vel"], d["vel_enc"], "o", color="#225588", ms=3.5,
             label="finite difference of encoder samples")
    ax2.set_ylabel("joint 3 velocity [deg/s]")
    ax2.set_xlabel("time after the contact start [s]")
    ax2.set_title("(b) joint velocity", loc="left")
    ax2.legend(loc="lower right")
    ax2.set_xlim(t_min, t_max)
    fig.suptitle(f"Figure 5: joint 3 motion after impact\n({d['cell']})", fontsize=9.5)
    return fig


def make(trial: str | os.PathLike, png: str | os.PathLike, pdf: str | os.PathLike | None = None, *,
         paper: Mapping[str, Any]):
    """Draw Figure 5 from ``trial`` and save it as PNG (and PDF). Returns the files written."""
    return style.save(draw(trial, paper=paper), png, pdf)
