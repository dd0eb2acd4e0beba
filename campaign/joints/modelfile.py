"""A fitted joint-resistance model as a JSON file, with its provenance; loading checks all of it.

The file (schema :data:`SCHEMA`, version :data:`SCHEMA_VERSION`) holds:

* ``kind``: the model (:data:`KINDS`), its ``options`` and fitted ``parameters`` with their
  intervals;
* ``robot``: its name and the sha256 of its drive file and URDF; ``rig`` and ``paper``: the
  rig file and the paper's tables (Table 1 gains) by path and sha256, which the model takes
  as known (:class:`campaign.joints.setting.Setting`);
* ``fit``: the archive the trials came from, the number of trials and the sha256 of their
  sorted list, the residual of each (``ln m*_model - ln m*_identified``, keyed by trial),
  their rms and scatter (the intervals' part), per flexible-base structure where the model
  was checked there the residuals and their scatter, and (``scatter_model``, where fitted)
  the scatter model the intervals carry (:mod:`campaign.joints.scatter`);
* ``domain``: where the model holds, the speeds, gain sets, object masses, impact directions,
  m* and structures of the trials it was fitted and checked on
  (:class:`campaign.joints.domain.Domain`);
* ``package_version``;
* ``digest``: the sha256 of the content and of each entry, written by the fit
  (:func:`campaign.joints.modelcheck.content_digest`).

No pickles: numbers are JSON numbers written with Python's shortest round-trip repr, so a
loaded model predicts bit for bit what the saved one did. :func:`load_model` refuses, with
one line naming the problem (:class:`ModelFileError`, an InputError: exit status 2 in the
CLI), a file that is not JSON, of another schema or version, of an unknown kind, missing a
key or with a value of the wrong type or outside its valid range
(:func:`campaign.joints.modelcheck.check_values`), fitted for another robot, rig file or
paper table, or edited after its fit (its content no longer matches its digest).
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..core.errors import InputError
from ..core.files import open_regular, write_atomic
from ..core.vocabulary import bases, gain_sets
from ..core.yamlfile import config_file
from .coulomb import CoulombLambdaFit
from .domain import Domain
from .estimator import CoulombModel, Eq11Model, LambdaModel, ResponseModel, json_numbers
from .impedance_model import JointImpedance
from .modelcheck import check_digest, check_values, content_digest
from .scatter import ScatterModel
from .setting import Setting, display_path

__all__ = ["SCHEMA", "SCHEMA_VERSION", "KINDS", "SHIPPED_MODEL", "ModelFileError", "model_document", "save_model",
           "load_model", "shipped_model_path", "trial_list_digest"]

SCHEMA = "campaign.response_model"
#: the shipped model's file name in the configuration folder (fitted by the designed campaign)
SHIPPED_MODEL = "response_model.json"
SCHEMA_VERSION = 2
#: the model kinds a file may hold
KINDS = {"eq11": Eq11Model, "lambda": LambdaModel, "lambda_coulomb": CoulombModel, "joint_impedance": JointImpedance}
#: the top-level keys and their JSON types
_KEYS = {"schema": str, "schema_version": int, "kind": str, "options": dict, "parameters": dict, "robot": dict,
         "rig": dict, "paper": dict, "fit": dict, "domain": dict, "package_version": str, "digest": dict}
_FIT_KEYS = {"archive": (str, type(None)), "n_trials": int, "trial_list_sha256": str, "residuals": dict,
             "rms_log_residual": (float, int, type(None)), "residual_scatter": (float, int, type(None)),
             "structure_scatter": dict, "structure_residuals": dict}


def shipped_model_path() -> Path:
    """``config/response_model.json``: the model the designed campaign fits, which the
    repository ships beside the rig file it was fitted for (the CLI's and the planner's default)."""
    return config_file(SHIPPED_MODEL)


class ModelFileError(InputError):
    """A model file that cannot be used: unreadable, malformed, or for another robot or rig."""


def trial_list_digest(keys) -> str:
    """sha256 of the sorted trial names, one per line."""
    return hashlib.sha256("\n".join(sorted(str(k) for k in keys)).encode("utf-8")).hexdigest()


def _plain(v):
    """A JSON-safe copy of an option's value (arrays as lists)."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _options(model: ResponseModel) -> dict:
    return {k: _plain(v) for k, v in model.get_params().items() if k != "setting"}


def model_document(model: ResponseModel, *, archive: str | None = None) -> dict[str, Any]:
    """The JSON document of a fitted model (see the module notes)."""
    model._check_fitted()
    s = model._the_setting()
    keys = list(model.keys_)
    residuals = {k: (float(r) if math.isfinite(r) else None) for k, r in zip(keys, model.residuals_, strict=True)}
    doc = {
        "schema": SCHEMA, "schema_version": SCHEMA_VERSION, "kind": model.kind, "options": _options(model),
        "parameters": model.parameters(),
        "robot": {"name": s.robot.name, "files": dict(s.digests["robot"])},
        "rig": {"file": s.rig_file, "sha256": s.digests["rig"]},
        "paper": {"file": s.paper_file, "sha256": s.digests["paper"]},
        "fit": {"archive": None if archive is None else display_path(archive), "n_trials": int(model.n_trials_),
                "trial_list_sha256": trial_list_digest(keys), "residuals": residuals,
                "rms_log_residual": json_numbers(model.rms_log_residual_),
                "residual_scatter": json_numbers(model.residual_scatter_),
                "structure_scatter": {k: float(v) for k, v in getattr(model, "structure_scatter_", {}).items()},
                "structure_residuals": {k: dict(v) for k, v in getattr(model, "structure_residuals_", {}).items()}},
        "domain": model.domain_.to_json(),
        "package_version": __version__,
    }
    scatter = getattr(model, "scatter_model_", None)
    if scatter is not None:
        doc["fit"]["scatter_model"] = scatter.to_dict()
    doc["digest"] = content_digest(doc)
    return doc


def save_model(model: ResponseModel, path, *, archive: str | None = None) -> Path:
    """Write a fitted model to ``path`` (JSON, keys sorted, atomically); returns the path."""
    text = json.dumps(model_document(model, archive=archive), indent=1, sort_keys=True, allow_nan=False)
    write_atomic(path, text + "\n")
    return Path(path)


def _check_types(doc: dict, where: str) -> None:
    if not isinstance(doc, dict):
        raise ModelFileError(f"{where}: not a model file (the JSON is a {type(doc).__name__}, not an object)")
    for key, kind in _KEYS.items():
        if key not in doc:
            raise ModelFileError(f"{where}: not a complete model file (no key {key!r})")
        if not isinstance(doc[key], kind) or isinstance(doc[key], bool):
            raise ModelFileError(f"{where}: key {key!r} must be a JSON {kind.__name__}, got {type(doc[key]).__name__}")
    if doc["schema"] != SCHEMA:
        raise ModelFileError(f"{where}: schema {doc['schema']!r} is not {SCHEMA!r}")
    if doc["schema_version"] != SCHEMA_VERSION:
        raise ModelFileError(f"{where}: schema version {doc['schema_version']} is not {SCHEMA_VERSION} (this package "
                             f"reads version {SCHEMA_VERSION} only)")
    if doc["kind"] not in KINDS:
        raise ModelFileError(f"{where}: unknown model kind {doc['kind']!r}; known: {sorted(KINDS)}")
    for key, kind in _FIT_KEYS.items():
        if key not in doc["fit"]:
            raise ModelFileError(f"{where}: fit has no key {key!r}")
        if not isinstance(doc["fit"][key], kind) or isinstance(doc["fit"][key], bool):
            raise ModelFileError(f"{where}: fit.{key} has the wrong type ({type(doc['fit'][key]).__name__})")
    for part in ("rig", "paper"):
        if not isinstance(doc[part].get("sha256"), str):
            raise ModelFileError(f"{where}: {part} has no sha256")
    if not isinstance(doc["robot"].get("name"), str) or not isinstance(doc["robot"].get("files"), dict):
        raise ModelFileError(f"{where}: robot needs a name and the digests of its files")


def _check_provenance(doc: dict, setting: Setting, where: str) -> None:
    """The robot, rig file and paper tables the model was fitted for must be these."""
    if doc["robot"]["name"] != setting.robot.name:
        raise ModelFileError(f"{where}: fitted for robot {doc['robot']['name']!r}, not {setting.robot.name!r}")
    if doc["robot"]["files"] != setting.digests["robot"]:
        raise ModelFileError(f"{where}: fitted for other parameter files of robot {setting.robot.name!r} "
                             f"(their sha256 differ from the shipped drive file and URDF)")
    for part, file in (("rig", setting.rig_file), ("paper", setting.paper_file)):
        if doc[part]["sha256"] != setting.digests[part]:
            raise ModelFileError(f"{where}: fitted for the {part} file {doc[part].get('file')!r} with sha256 "
                                 f"{doc[part]['sha256'][:12]}..., not {file} ({setting.digests[part][:12]}...)")


def _checked_residuals(doc: dict, where: str) -> tuple[tuple, np.ndarray]:
    fit = doc["fit"]
    res = fit["residuals"]
    if len(res) != fit["n_trials"]:
        raise ModelFileError(f"{where}: fit lists {len(res)} residuals for {fit['n_trials']} trials")
    if trial_list_digest(res) != fit["trial_list_sha256"]:
        raise ModelFileError(f"{where}: the residuals' trials do not match fit.trial_list_sha256")
    values = []
    for k, v in res.items():
        if v is not None and (not isinstance(v, (int, float)) or isinstance(v, bool)):
            raise ModelFileError(f"{where}: residual of {k!r} is not a number")
        values.append(math.nan if v is None else float(v))
    return tuple(res), np.array(values, float)


def _restore(doc: dict, setting: Setting, where: str) -> ResponseModel:
    cls = KINDS[doc["kind"]]
    try:
        model = cls(setting, **doc["options"])
    except TypeError as exc:
        raise ModelFileError(f"{where}: options do not fit a {doc['kind']} model ({exc})") from None
    p = doc["parameters"]
    try:
        if doc["kind"] == "joint_impedance":
            model.set_fitted(p)
        elif doc["kind"] in ("eq11", "lambda"):
            model.lambdas_ = {str(k): np.asarray(v, float) for k, v in p["lambda"].items()}
            if doc["kind"] == "lambda":
                model.lambda_boot_ = {str(k): np.asarray(v, float).reshape(-1, setting.robot.nv)
                                      for k, v in p["lambda_bootstrap"].items()}
        else:
            model.fits_ = {}
            for cls_name, f in p.items():
                est = CoulombLambdaFit(setting.robot, ci=float(f["ci"]))
                est.lambda_, est.kappa_ = np.asarray(f["lambda"], float), np.asarray(f["kappa"], float)
                est.lambda_ci_ = np.asarray(f["lambda_ci"], dtype=float)
                est.kappa_ci_ = np.asarray(f["kappa_ci"], dtype=float)
                est.e_, est.m_b_ = float(f["e"]), float(f["m_b"])
                est.rms_log_residual_, est.n_trials_ = float(f["rms_log_residual"]), int(f["n_trials"])
                model.fits_[str(cls_name)] = est
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{where}: parameters of the {doc['kind']} model are incomplete or malformed "
                             f"({type(exc).__name__}: {exc})") from None
    keys, residuals = _checked_residuals(doc, where)
    model.keys_, model.residuals_, model.n_trials_ = keys, residuals, int(doc["fit"]["n_trials"])
    nan = math.nan
    model.rms_log_residual_ = nan if doc["fit"]["rms_log_residual"] is None else float(doc["fit"]["rms_log_residual"])
    model.residual_scatter_ = nan if doc["fit"]["residual_scatter"] is None else float(doc["fit"]["residual_scatter"])
    try:
        model.structure_scatter_ = {str(k): float(v) for k, v in doc["fit"]["structure_scatter"].items()}
        model.structure_residuals_ = {str(k): {str(t): (None if r is None else float(r)) for t, r in v.items()}
                                      for k, v in doc["fit"]["structure_residuals"].items()}
    except (AttributeError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{where}: fit.structure_scatter or fit.structure_residuals is malformed ({exc})") from None
    model.domain_ = Domain.from_json(doc["domain"], where=where, gain_sets=gain_sets(), bases=bases())
    if "scatter_model" in doc["fit"]:
        try:
            model.scatter_model_ = ScatterModel.from_dict(doc["fit"]["scatter_model"])
        except InputError as exc:
            raise ModelFileError(f"{where}: fit.scatter_model: {exc}") from None
    model.provenance_ = {k: doc[k] for k in ("robot", "rig", "paper", "package_version")}
    model.provenance_["archive"] = doc["fit"]["archive"]
    return model


def load_model(path, *, setting: Setting | None = None, rig=None) -> ResponseModel:
    """Read a model file and check it against the robot, rig file and paper tables in use
    (``setting``, or :meth:`Setting.from_rig` of ``rig``); ModelFileError names the problem."""
    where = str(path)
    try:
        with open_regular(path, "r", encoding="utf-8", what="model file", error=ModelFileError,
                          missing_ok=True) as fh:
            text = fh.read()  # a FIFO, socket or device is refused, never waited on
    except FileNotFoundError:
        raise ModelFileError(f"{where}: no such model file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{where}: cannot read the model file ({exc})") from None
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise ModelFileError(f"{where}: not valid JSON (corrupted?): {exc}") from None
    _check_types(doc, where)
    try:
        check_values(doc, where)
    except InputError as exc:
        raise ModelFileError(str(exc)) from None
    setting = Setting.from_rig(rig) if setting is None else setting
    _check_provenance(doc, setting, where)
    try:
        model = _restore(doc, setting, where)
        check_digest(doc, where)
    except ModelFileError:
        raise
    except InputError as exc:
        raise ModelFileError(str(exc)) from None
    return model
