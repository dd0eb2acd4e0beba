"""A model file checked for what it means: every value in its valid range, and its content digest.

:func:`check_values` refuses (one line naming the entry and the value) a parameter, option or
fit statistic out of its range: non-finite numbers, negative damping or friction, a
restitution outside (0, 1], an estimate outside its own 95 % interval, a covariance that is
not symmetric positive semi-definite, an unknown option value, ``steps`` < 1, a residual
scatter <= 0. :func:`content_digest` is what the fit writes: the sha256 of the file's
content and of each of its entries; :func:`check_digest` refuses a file whose content no
longer matches it, naming the entries that changed (a hand-edited copy; a re-fit writes a
new digest). The digest is a checksum against edits, not a signature against forgery.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping

import numpy as np

from ..core.errors import InputError

__all__ = ["check_values", "content_digest", "check_digest", "COUPLINGS"]

#: the flexible base's couplings a joint_impedance model may name (None: the rig's)
COUPLINGS = (None, "ideal", "loop")
#: relative tolerance of the covariance's symmetry and positive semi-definiteness
COVARIANCE_RTOL = 1e-9


def _bad(where: str, entry: str, value, rule: str) -> InputError:
    shown = format(value, ".6g") if isinstance(value, float) else repr(value)
    return InputError(f"{where}: {entry} = {shown} {rule}")


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _finite(where: str, entry: str, v, *, low=None, low_open=False, high=None, none_ok=False) -> float | None:
    """``v`` as a float, refused unless a finite number in the given range."""
    if v is None and none_ok:
        return None
    if not _number(v) or not math.isfinite(v):
        raise _bad(where, entry, v, "must be a finite number")
    if low is not None and (v <= low if low_open else v < low):
        raise _bad(where, entry, v, f"must be {'>' if low_open else '>='} {low:g}")
    if high is not None and v > high:
        raise _bad(where, entry, v, f"must be <= {high:g}")
    return float(v)


def _array(where: str, entry: str, v, shape: tuple, *, low=None, low_open=False) -> np.ndarray:
    a = np.asarray(v, dtype=object)
    if a.shape != shape:
        raise InputError(f"{where}: {entry} must have shape {shape}, got {a.shape}")
    for idx in np.ndindex(shape):
        _finite(where, f"{entry}{list(idx)}", a[idx], low=low, low_open=low_open)
    return a.astype(float)


def _numbers(where: str, entry: str, v) -> None:
    """Every number in a nested list or dict finite (None allowed: an undetermined value)."""
    if isinstance(v, Mapping):
        for k, x in v.items():
            _numbers(where, f"{entry}.{k}", x)
    elif isinstance(v, list):
        for i, x in enumerate(v):
            _numbers(where, f"{entry}[{i}]", x)
    elif v is not None and not isinstance(v, (bool, str)):
        _finite(where, entry, v)


def _check_impedance(p: Mapping, options: Mapping, where: str) -> None:
    damping = p.get("damping")
    nv = len(damping) if isinstance(damping, list) else 0
    if nv == 0:
        raise InputError(f"{where}: parameters.damping must be a list of one value per joint")
    beta = _array(where, "parameters.damping", damping, (nv,), low=0.0, low_open=True)
    s = _finite(where, "parameters.friction_scale", p.get("friction_scale"), low=0.0, low_open=True)
    _finite(where, "parameters.restitution", p.get("restitution"), low=0.0, low_open=True, high=1.0)
    for key in ("coulomb_pos", "coulomb_neg"):
        _array(where, f"parameters.{key}", p.get(key), (nv,), low=0.0)
    cov = _array(where, "parameters.covariance", p.get("covariance"), (nv + 1, nv + 1))
    scale = float(np.max(np.abs(cov))) if cov.size else 0.0
    if np.max(np.abs(cov - cov.T)) > COVARIANCE_RTOL * scale:
        raise InputError(f"{where}: parameters.covariance is not symmetric")
    low_eig = float(np.min(np.linalg.eigvalsh(0.5 * (cov + cov.T))))
    if low_eig < -COVARIANCE_RTOL * scale:
        raise InputError(f"{where}: parameters.covariance is not positive semi-definite (eigenvalue {low_eig:.3g})")
    ci = _array(where, "parameters.params_ci", p.get("params_ci"), (2, nv + 1), low=0.0, low_open=True)
    est = np.concatenate([beta, [s]])
    names = [f"damping[{j}]" for j in range(nv)] + ["friction_scale"]
    for j, name in enumerate(names):
        if not ci[0, j] * (1 - 1e-12) <= est[j] <= ci[1, j] * (1 + 1e-12):
            raise _bad(where, f"parameters.{name}", float(est[j]),
                       f"lies outside its own 95 % interval params_ci [{ci[0, j]:.6g}, {ci[1, j]:.6g}]")
    _array(where, "parameters.relative_ci", p.get("relative_ci"), (nv + 1,), low=0.0)
    _finite(where, "parameters.condition_number", p.get("condition_number"), low=1.0, none_ok=True)
    ident = p.get("identifiable")
    if not (isinstance(ident, list) and len(ident) == nv + 1 and all(isinstance(x, bool) for x in ident)):
        raise _bad(where, "parameters.identifiable", ident, f"must be {nv + 1} true/false values")
    if options.get("coupling") not in COUPLINGS:
        raise _bad(where, "options.coupling", options.get("coupling"), "is not one of null, 'ideal', 'loop'")
    for key in ("steps", "samples"):
        v = options.get(key)
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
            raise _bad(where, f"options.{key}", v, "must be an integer >= 1")
    _finite(where, "options.max_relative_ci", options.get("max_relative_ci"), low=0.0, low_open=True)


def _check_other(kind: str, p: Mapping, options: Mapping, where: str) -> None:
    _numbers(where, "parameters", p)
    if kind in ("eq11", "lambda"):
        for cls, lam in (p.get("lambda") or {}).items():
            if isinstance(lam, list):
                for j, v in enumerate(lam):
                    _finite(where, f"parameters.lambda.{cls}[{j}]", v, low=0.0)
    if kind == "lambda":
        for key, low in (("n_bootstrap", 0), ("random_state", 0)):
            v = options.get(key)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= low):
                raise _bad(where, f"options.{key}", v, f"must be an integer >= {low}")
    if kind == "lambda_coulomb":
        for cls, f in p.items():
            if isinstance(f, Mapping):
                _finite(where, f"parameters.{cls}.e", f.get("e"), low=0.0, low_open=True, high=1.0)
                _finite(where, f"parameters.{cls}.m_b", f.get("m_b"), low=0.0, low_open=True)


def check_values(doc: Mapping, where: str) -> None:
    """Refuse (InputError, one line naming the entry and the value) a model file's parameter,
    option or fit statistic outside its valid range (see the module notes)."""
    p, options, fit = doc["parameters"], doc["options"], doc["fit"]
    if doc["kind"] == "joint_impedance":
        _check_impedance(p, options, where)
    else:
        _check_other(doc["kind"], p, options, where)
    if fit["n_trials"] < 1:
        raise _bad(where, "fit.n_trials", fit["n_trials"], "must be >= 1")
    _finite(where, "fit.residual_scatter", fit["residual_scatter"], low=0.0, low_open=True)
    _finite(where, "fit.rms_log_residual", fit["rms_log_residual"], low=0.0)
    for name, v in fit["structure_scatter"].items():
        _finite(where, f"fit.structure_scatter.{name}", v, low=0.0, low_open=True)
    for name, res in fit["structure_residuals"].items():
        _numbers(where, f"fit.structure_residuals.{name}", res)
    _numbers(where, "fit.residuals", fit["residuals"])


# ----------------------------------------------------------------------------------------
# the digest
# ----------------------------------------------------------------------------------------
def _sha(value) -> str:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _parts(doc: Mapping) -> dict[str, str]:
    """sha256 of each entry: a top-level key, or each key of a top-level object."""
    out = {}
    for key, value in doc.items():
        if key == "digest":
            continue
        if isinstance(value, Mapping) and value:
            for sub, item in value.items():
                out[f"{key}.{sub}"] = _sha(item)
        else:
            out[key] = _sha(value)
    return out


def content_digest(doc: Mapping) -> dict:
    """The digest a fit writes into its model file: ``sha256`` of the whole content (every key
    but ``digest``) and ``entries``, the sha256 of each entry (:func:`check_digest`)."""
    return {"sha256": _sha({k: v for k, v in doc.items() if k != "digest"}), "entries": _parts(doc)}


def check_digest(doc: Mapping, where: str) -> None:
    """Refuse (InputError, one line) a model file whose content is not what its fit wrote,
    naming the entries that changed."""
    d = doc.get("digest")
    if not (isinstance(d, Mapping) and isinstance(d.get("sha256"), str) and isinstance(d.get("entries"), Mapping)):
        raise InputError(f"{where}: the model file has no content digest (digest.sha256 and digest.entries, "
                         "written by the fit)")
    try:
        now = content_digest(doc)
    except ValueError as exc:
        raise InputError(f"{where}: the model file holds a value JSON cannot hold ({exc})") from None
    if now["sha256"] == d["sha256"]:
        return
    old = d["entries"]
    changed = sorted(k for k in set(now["entries"]) | set(old) if now["entries"].get(k) != old.get(k))
    shown = ", ".join(changed[:4]) + (f" and {len(changed) - 4} more" if len(changed) > 4 else "")
    raise InputError(f"{where}: edited after its fit: {shown or 'the digest itself'} "
                     f"{'differ' if len(changed) > 1 else 'differs'} from the content the fit wrote "
                     "(digest.sha256); re-fit the model to change it")
