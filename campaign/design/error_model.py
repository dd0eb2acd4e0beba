"""The measurement error of ln m* the experiment design weighs its trials by.

:class:`ErrorModel`: ``var(ln m*) = a^2 + b^2 x^2`` with ``x = (1 + m*/m_b) / v``. The
arm's velocity change along n is ``(1 + e) m_b v / (m* + m_b)`` (eq 13), measured through
20 ms joint-encoder samples to a roughly constant velocity error; its relative error, hence
that of m* (eq 10), grows as ``(1 + m*/m_b) / v``: a heavy effective mass or a slow hammer
leaves the arm almost still. ``a`` is the floor (pendulum encoder, contact edges).
``a^2, b^2 >= 0`` are fitted by non-negative, iteratively reweighted least squares to the
squared errors ``(ln m*_identified - ln m*_truth)^2`` of a campaign's own fixed-base trials,
where ``m*_truth`` is eq 10 on the simulator's true contact-edge velocities (the trial
file's ``truth`` group): identification's error alone, not the model's
(:func:`calibrate_error_model`; by default on the committed reference archive).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..archive import open_trial_arrays
from ..core.errors import InputError
from ..core.files import check_regular_file
from ..core.vocabulary import FIXED
from ..core.yamlfile import PROJECT_DIR
from ..identify.table import read_identification

__all__ = ["ErrorModel", "calibrate_error_model"]


@dataclasses.dataclass(frozen=True)
class ErrorModel:
    """``var(ln m*) = a^2 + b^2 ((1 + m*/m_b) / v)^2`` (see the module docstring).

    Attributes
    ----------
    a : float
        Error floor of ln m* (relative error of m*).
    b : float
        Coefficient of ``(1 + m*/m_b) / v`` [m/s].
    n_trials : int
        Trials it was calibrated on.
    source : str
        Where those trials came from.
    rms : float
        Root mean square of the calibration errors ``ln m*_identified - ln m*_truth``.
    """

    a: float
    b: float
    n_trials: int = 0
    source: str = ""
    rms: float = float("nan")

    def variance(self, m_ratio, speed) -> np.ndarray:
        """``var(ln m*)`` at ``m*/m_b`` and hammer speed [m/s] (broadcast)."""
        x = (1.0 + np.asarray(m_ratio, float)) / np.asarray(speed, float)
        return self.a**2 + (self.b * x) ** 2

    @classmethod
    def fit(cls, m_identified, m_truth, m_b, speed, *, source: str = "") -> ErrorModel:
        """Fit ``a^2, b^2 >= 0`` to ``(ln m*_identified - ln m*_truth)^2`` by non-negative
        least squares (one row per trial)."""
        from scipy.optimize import nnls  # on demand: nothing else of the design needs scipy

        mi, mt, mb, v = (np.asarray(x, float) for x in (m_identified, m_truth, m_b, speed))
        ok = np.isfinite(mi) & np.isfinite(mt) & (mi > 0) & (mt > 0) & np.isfinite(mb) & (v > 0)
        if ok.sum() < 2:
            raise InputError(f"the error model needs at least 2 trials with identified and true m*, got {int(ok.sum())}")
        r = np.log(mi[ok] / mt[ok])
        x = (1.0 + mt[ok] / mb[ok]) / v[ok]
        A = np.column_stack([np.ones_like(x), x**2])
        coef, _ = nnls(A, r**2)
        # r^2 has variance 2 var^2: reweight by the fitted variance (iteratively reweighted
        # least squares), so the many small errors pin the floor down as well as the large ones
        for _ in range(5):
            var = np.maximum(A @ coef, 1e-30)
            coef, _ = nnls(A / var[:, None], r**2 / var)
        return cls(a=float(math.sqrt(coef[0])), b=float(math.sqrt(coef[1])), n_trials=int(ok.sum()), source=source,
                   rms=float(np.sqrt(np.mean(r**2))))

    def to_dict(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "n_trials": self.n_trials, "source": self.source, "rms": self.rms,
                "formula": "var(ln m*) = a^2 + b^2 ((1 + m*/m_b) / v)^2"}


def _truth_m_eff(path: Path, m_b: float) -> float:
    """Eq 10 on the simulator's true contact-edge velocities of one trial."""
    t = open_trial_arrays(path, group="truth")
    g = lambda k: float(t[k].values)  # noqa: E731
    dv_a = g("v_a_post") - g("v_a_pre")
    return m_b * (g("v_b_pre") - g("v_b_post")) / dv_a if dv_a > 0 else float("nan")


def calibrate_error_model(ident_tables: Sequence[str | Path] | None = None, *,
                          archive_dir: str | Path | None = None) -> ErrorModel:
    """Calibrate :class:`ErrorModel` on a campaign's identified fixed-base trials vs their truth.

    Parameters
    ----------
    ident_tables : sequence of path-like, optional
        Identification CSVs (:func:`campaign.identify.table.identify_trials`); their rows name the
        trial files, whose ``truth`` groups give ``m*_truth``. Default: the committed
        reference archive's (``archive/reference.identification.csv``).
    archive_dir : path-like, optional
        Where the trial files are when the CSV's paths are not there (the last five parts of
        each path are taken relative to it). Default: ``archive/reference`` with the default
        table.
    """
    root = PROJECT_DIR / "archive"
    if ident_tables is None:
        ident_tables = [root / "reference.identification.csv"]
        archive_dir = root / "reference" if archive_dir is None else archive_dir
    for t in ident_tables:
        check_regular_file(t, what="identification table")
    try:
        rows = [r for r in read_identification(ident_tables) if r["base"] == FIXED and not r["excluded"]]
    except UnicodeDecodeError as exc:        # a trial file, a figure: not a CSV at all
        names = ", ".join(str(t) for t in ident_tables)
        raise InputError(f"identification table {names}: not a CSV table (not UTF-8 text: {exc.reason} at byte "
                         f"{exc.start})") from None
    mi, mt, mb, v = [], [], [], []
    for r in rows:
        path = Path(r["path"])
        if not path.is_file() and archive_dir is not None:
            path = Path(archive_dir).joinpath(*Path(r["path"]).parts[-5:])
        if not path.is_file():
            raise InputError(f"trial file {r['path']} of the identification table is missing")
        mi.append(r["m_eff"])
        mt.append(_truth_m_eff(path, r["hammer_mass"]))
        mb.append(r["hammer_mass"])
        v.append(r["speed"])
    names = ", ".join(str(t) for t in ident_tables)
    return ErrorModel.fit(mi, mt, mb, v, source=names)
