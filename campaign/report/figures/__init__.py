"""Figures 4-9 of the paper, re-drawn from the campaign's model, trials and identification.

One module per figure, each with ``draw(...) -> matplotlib.figure.Figure`` (testable without
files) and ``make(..., png, pdf)`` (what the workflow's thin scripts call). Every figure is
drawn with the non-interactive Agg backend, saved as PNG and PDF, has axis labels with
units, and shows the paper's value wherever the paper publishes one (from
``config/paper.yaml``, never typed again). Shared look: :mod:`campaign.report.figures.style`.

=======  ==================================================================  ====================
module   shows                                                               drawn from
=======  ==================================================================  ====================
fig4     arm configurations 1-3 and the impact direction, side view (x-z)    the Pinocchio model
fig5     joint 3 displacement and velocity after impact, config 1, zero      one trial (encoders)
fig6     observed effective mass per configuration and gain (Z/L/H)          identification
fig7     observed restitution coefficient per configuration and gain         identification
fig8     the flexible-base set-up: beam, platform, arm                       model + rig file
fig9     base displacement after impact, configs 1 and 2, High vs Low        flexible trials
=======  ==================================================================  ====================

Beside them: :mod:`~campaign.report.figures.plan_maps` (the planner's workspace and direction
maps) and :mod:`~campaign.report.figures.validity` (eq 8's validity map).
"""

__all__ = ["fig4", "fig5", "fig6", "fig7", "fig8", "fig9", "plan_maps", "validity", "style"]
