"""The impact planner: every pose, gain class and direction to meet an object at a point,
ranked; its factory from the rig's values, its maps, the predictions behind it and the VES
stroke check.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`). Method
and accuracy: user guide, *The impact planner*.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "ImpactPlanner", "build_planner", "planner_model", "planner_lambdas", "check_model_domain", "horizontal_directions",
    "cone_directions", "pose_terms", "predict", "check_object", "predict_model", "workspace_map", "direction_map",
    "grid_points", "check_scene_stroke", "RESCORE", "rescore_loop",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "planner": ("ImpactPlanner", "RESCORE"),
    "factory": ("build_planner", "planner_model", "planner_lambdas", "check_model_domain"),
    "directions": ("horizontal_directions", "cone_directions"),
    "prediction": ("pose_terms", "predict", "check_object"),
    "model_prediction": ("predict_model", "rescore_loop"),
    "maps": ("workspace_map", "direction_map"),
    "grid": ("grid_points",),
    "stroke": ("check_scene_stroke",),
})
