"""Experiment design for lambda (D-, A- or E-optimal poses and directions), the designed
campaign that fits the response model, and what recorded hits' poses determine of lambda.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`). Method:
user guide, *Experiment design for lambda*.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "ExperimentDesign", "ErrorModel", "grid_candidates", "random_candidates", "paper_design", "feasible",
    "run_design", "write_design", "fit_model", "compare_shipped", "model_differences", "HitRows", "read_hit_rows",
    "log_sensitivity", "identifiability", "prediction_range", "subspace_fit", "transfer",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "designer": ("ExperimentDesign",),
    "error_model": ("ErrorModel",),
    "candidates": ("grid_candidates", "random_candidates", "paper_design", "feasible"),
    "run": ("run_design", "write_design"),
    "designed_model": ("fit_model", "compare_shipped", "model_differences"),
    "recorded": ("HitRows", "read_hit_rows", "log_sensitivity", "identifiability", "prediction_range", "subspace_fit", "transfer"),
})
