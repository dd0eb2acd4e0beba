"""The workflow's fit job: the Virtual Rotor Inertia of one gain class from identification tables."""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..core.files import check_output_file, write_atomic
from ..core.timing import Timer
from ..core.vocabulary import FIXED
from ..identify.results import is_usable
from ..identify.table import read_identification
from ..joints.lambda_fit import IdentifiabilityWarning, LambdaFit
from ..model.robot import load_robot

__all__ = ["fit_lambda"]
def fit_lambda(ident_tables: Iterable[str | os.PathLike], out_json: str | os.PathLike, *,
               gain_class: str, gains: Sequence[str],
               base: str = FIXED, options: Mapping[str, Any] | None = None, seed: int = 0,
               timer: Timer | None = None) -> dict[str, Any]:
    """Fit lambda (eq 11, 15) to the identified effective masses of one gain class.

    The fit is :class:`campaign.joints.lambda_fit.LambdaFit` over the class's usable trials of ``base``
    (every configuration, speed and repeat), with the trials' robot and impact direction,
    as :func:`campaign.report.tables.fit_gain_classes` does for all classes at once.

    Parameters
    ----------
    ident_tables : iterable of path-like
        Identification CSVs (:func:`identify_trials`); rows of other bases or gains, and
        excluded trials, are left out.
    out_json : path-like
        :meth:`campaign.joints.lambda_fit.LambdaFit.summary` with the gain class, the gains pooled and
        the trials used and excluded (written atomically); all that Tables 3-4 read back
        (:func:`load_fits`).
    gain_class : str
        Name of the class (``paper.yaml`` ``gain_classes``: ``zero_low``, ``high``).
    gains : sequence of str
        The gain sets pooled in the class.
    base : str
        Base whose trials are fitted (the paper: fixed).
    options : mapping, optional
        :class:`campaign.joints.lambda_fit.LambdaFit` settings (``structure``, ``n_bootstrap``, ``ci``,
        ``min_sensitivity``, ``max_relative_ci``).
    seed : int
        Seed of the bootstrap (the workflow passes ``campaign_seed``).
    timer : Timer, optional
        Receives the seconds spent in ``fit``.

    Returns
    -------
    dict
        What was written to ``out_json``.

    Raises
    ------
    ValueError
        No usable trial, trials of several robots, an unknown fit option (named), or
        ``out_json`` cannot be written (a folder, a device, a full disk).
    """
    timer = timer if timer is not None else Timer()

    allowed = {"structure", "n_bootstrap", "ci", "min_sensitivity", "max_relative_ci"}
    unknown = sorted(set(options or {}) - allowed)
    if unknown:
        raise ValueError(f"fit: unknown option(s) {unknown}; known: {sorted(allowed)}")
    check_output_file(out_json, option="lambda fit")
    rows = [r for r in read_identification(ident_tables) if r["base"] == base and r["gain"] in gains]
    used = [r for r in rows if is_usable(r)]
    if not used:
        raise ValueError(f"fit {gain_class}: no usable {base}-base trial with gains {list(gains)} "
                         f"({len(rows)} found, all excluded)")
    robots = sorted({r["robot"] for r in used})
    if len(robots) != 1:
        raise ValueError(f"fit {gain_class}: the trials mix robots {robots}")
    # each trial is fitted along its own impact direction (a designed campaign strikes
    # poses from several horizontal directions)
    directions = np.array([r["impact_direction"] for r in used], float)
    with timer("fit"), warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)  # the findings are in the summary
        est = LambdaFit(load_robot(robots[0]), direction=directions[0], random_state=int(seed),
                        **dict(options or {}))
        est.fit(np.array([r["q_cmd"] for r in used]), np.array([r["m_eff"] for r in used]), directions=directions)
    result = {
        "gain_class": gain_class, "gains": list(gains), "base": base, "robot": robots[0], **est.summary(),
        "n_excluded": len(rows) - len(used), "configs": sorted({int(r["config"]) for r in used}),
        "units": {"lambda": "kg m^2", "lambda_ci": "kg m^2"},
    }
    write_atomic(out_json, json.dumps(result, indent=2, sort_keys=True) + "\n")
    lam = ", ".join(f"{x:.4g}" for x in np.ravel(est.lambda_))
    print(f"fit {gain_class} ({', '.join(gains)}): lambda = [{lam}] kg m^2 from {len(used)} trials "
          f"({len(rows) - len(used)} excluded); condition number {est.condition_number_:.3g}")
    for warning in est.warnings_:
        print(f"warning: {warning}")
    return result

