"""Joint-resistance models behind one estimator interface: eq 11 with a given lambda, the
lambda fit (eq 11, 15), lambda plus a Coulomb impulse, the joints' impedance over the
contact (the response model); the trials they fit, their model files and the domain where they hold.

The names below are imported on first use (:func:`campaign.core.lazy.lazy_exports`). The
interface: :mod:`~campaign.joints.estimator`; the models and their measured accuracy: user
guide, *The lambda fit* and *The response model*.
"""

from __future__ import annotations

from ..core.lazy import lazy_exports

__all__ = [
    "ResponseModel", "Eq11Model", "LambdaModel", "CoulombModel", "LambdaFit", "IdentifiabilityWarning",
    "design_arrays", "load_fits", "CoulombLambdaFit", "JointImpedance", "Impacts", "Setting", "display_path",
    "ModelFileError", "load_model", "save_model", "shipped_model_path", "arm_terms", "respond", "Domain",
    "OutsideDomain", "m_eff_state", "ScatterModel", "fit_scatter", "tip_velocity_change",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "estimator": ("ResponseModel", "Eq11Model", "LambdaModel", "CoulombModel"),
    "lambda_fit": ("LambdaFit", "IdentifiabilityWarning", "design_arrays", "load_fits"),
    "coulomb": ("CoulombLambdaFit",),
    "impedance_model": ("JointImpedance",),
    "impacts": ("Impacts",),
    "setting": ("Setting", "display_path"),
    "modelfile": ("ModelFileError", "load_model", "save_model", "shipped_model_path"),
    "terms": ("arm_terms",),
    "response": ("respond",),
    "domain": ("Domain", "OutsideDomain", "m_eff_state"),
    "scatter": ("ScatterModel", "fit_scatter", "tip_velocity_change"),
})
