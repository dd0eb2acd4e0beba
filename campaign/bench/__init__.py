"""Benchmarks of the simulated VES-II: work-precision, per-trial cost, stress.

Library code behind ``campaign bench``; nothing here is used by the campaign itself.

Work-precision (:func:`work_precision`)
    For representative scenes, every integration setting the rig supports
    (``substeps_contact`` x ``substeps_free`` of its event-located RK4, see
    :mod:`campaign.rig.integrate`), a uniform 0.1 ms step of the same integrator, and a
    straightforward fixed-step RK4 (:func:`naive_rk4`, no event location, no analytic
    swing, fixed horizon) are timed (median wall time per trial, settings interleaved
    round-robin so a load change on the shared machine hits all of them alike) and compared
    with a converged reference (the same scene at 32x the default substeps in and out of
    contact) in (a) the identified m* and e, (b) the true post-impact velocities, (c) the
    recorded channels (max error over the samples relative to the channel's peak-to-peak
    excursion, measured and truth groups separately).

Per-trial cost (:func:`trial_cost`)
    Median simulation time per trial at the default setting and, separately, the time to
    write its file (:func:`campaign.archive.write_trial`), beside the naive baseline in the
    same run.

Stress (:func:`stress_cases`, :func:`run_stress`)
    Corners of the input space. Every case either passes the invariants of
    :func:`check_invariants` or is refused before simulating (``InputError``) with a
    message naming the cause. A ``SimulationError`` after work started is a reported
    blow-up (no file written) and counts against the suite, as does anything else.

Closed-form stress (:func:`closed_form_stress`)
    Ex-IIT (eq 7, 11) towards the stretched singularity: finite or ``inf``, never NaN or
    garbage; the conditioning of eq 11; the lambda fit on ill-conditioned designs.
"""

from __future__ import annotations

from .closed_form import closed_form_stress, format_closed_form
from .common import machine_line, write_section
from .cost import format_cost, trial_cost, truth_m_impulse, write_probe
from .naive import naive_rk4, naive_trial
from .stress import (
    StressCase,
    StressResult,
    check_invariants,
    format_stress,
    run_case,
    run_stress,
    stress_cases,
    stress_summary,
)
from .work_precision import (
    Setting,
    WPScene,
    format_wp_references,
    format_wp_table,
    pareto_front,
    plot_work_precision,
    work_precision,
    wp_scenes,
    wp_settings,
    wp_verdict,
)

__all__ = [
    "naive_rk4", "naive_trial", "WPScene", "Setting", "wp_scenes", "wp_settings", "work_precision",
    "pareto_front", "format_wp_table", "plot_work_precision", "trial_cost", "format_cost",
    "StressCase", "StressResult", "stress_cases", "run_case", "run_stress", "check_invariants",
    "format_stress", "closed_form_stress", "format_closed_form", "write_section", "machine_line",
    "truth_m_impulse", "write_probe", "stress_summary", "format_wp_references", "wp_verdict",
]
