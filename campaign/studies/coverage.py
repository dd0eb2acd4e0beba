"""The response model's accuracy and interval coverage broken down by what makes m* harder.

:func:`coverage_table` groups held-out trials (the rows of
:func:`campaign.studies.response_model.evaluate`) by base, gain set, speed band (below,
inside and above the 1.0-2.5 m/s the model was once fitted on) and decade of the
identified m*, and gives per group the m* error's median and worst, the signed median (the
bias) against the identified m* and against the simulator's own (diagnosis only: it tells
the model's bias from the identification's noise), and the share of trials the 90 % and
95 % intervals hold, with a binomial 95 % interval of that share (Wilson's) so that a
group's miss can be told from its size.
:func:`bias_by_speed` gives the signed median error per finer speed band.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["SPEED_BANDS", "BIAS_BANDS", "speed_band", "decade", "coverage_table", "bias_by_speed", "wilson",
           "coverage_markdown", "COVERAGE_COLUMNS"]

#: speed bands [m/s]: below, inside and above the 1.0-2.5 m/s the model was first fitted on
SPEED_BANDS = (("below 1.0", 0.0, 1.0), ("1.0-2.5", 1.0, 2.5 + 1e-9), ("above 2.5", 2.5 + 1e-9, math.inf))
#: finer speed bands for the bias [m/s]
BIAS_BANDS = ((0.3, 0.5), (0.5, 0.7), (0.7, 1.0), (1.0, 1.75), (1.75, 2.5), (2.5, 3.0 + 1e-9))
COVERAGE_COLUMNS = ("group", "value", "trials", "median_error", "worst_error", "bias", "bias_truth", "covered_90",
                    "covered_95", "covered_95_low", "covered_95_high")


def speed_band(speed: float) -> str:
    """The :data:`SPEED_BANDS` name of ``speed`` [m/s]."""
    return next(name for name, lo, hi in SPEED_BANDS if lo <= speed < hi)


def decade(m: float) -> str:
    """``"1-10 kg"``, ``"10-100 kg"``, ... of ``m`` [kg]."""
    k = int(math.floor(math.log10(m)))
    return f"{10 ** k:g}-{10 ** (k + 1):g} kg"


def wilson(k: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson's 95 % interval of a share ``k / n``."""
    if n == 0:
        return math.nan, math.nan
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def _group_row(group: str, value: str, rows: Sequence[dict]) -> dict:
    err = np.array([r["error"] for r in rows], float)
    c90 = [bool(r["covered_90"]) for r in rows]
    c95 = [bool(r["covered"]) for r in rows]
    lo, hi = wilson(sum(c95), len(c95))
    truth = [r["model_vs_truth"] for r in rows if r.get("model_vs_truth") is not None]
    return {"group": group, "value": value, "trials": len(rows), "median_error": float(np.median(np.abs(err))),
            "worst_error": float(np.max(np.abs(err))), "bias": float(np.median(err)),
            "bias_truth": float(np.median(truth)) if truth else math.nan,
            "covered_90": float(np.mean(c90)), "covered_95": float(np.mean(c95)), "covered_95_low": lo,
            "covered_95_high": hi}


def _base(r: dict) -> str:
    return r["base"] if not r.get("structure") else f"{r['base']} {r['structure']}"


def coverage_table(rows: Sequence[dict]) -> list[dict]:
    """One row per group of held-out trials (all; per base, gain set, speed band, m* decade;
    per base x gain set), see the module notes."""
    rows = [r for r in rows if r.get("error") is not None and math.isfinite(r["error"])]
    out = [_group_row("all", "all", rows)] if rows else []
    keys = (("base", _base), ("gain set", lambda r: r["gain"]), ("speed band", lambda r: speed_band(r["speed_m_s"])),
            ("m* decade", lambda r: decade(r["m_identified_kg"])),
            ("base x gain set", lambda r: f"{_base(r)}, {r['gain']}"))
    for group, key in keys:
        values = sorted({key(r) for r in rows}, key=lambda v: (len(v), v) if group == "m* decade" else v)
        out += [_group_row(group, v, [r for r in rows if key(r) == v]) for v in values]
    return out


def bias_by_speed(rows: Sequence[dict]) -> list[dict]:
    """The signed median error per :data:`BIAS_BANDS` band, per base."""
    out = []
    for base in sorted({_base(r) for r in rows}):
        for lo, hi in BIAS_BANDS:
            sel = [r for r in rows if _base(r) == base and lo <= r["speed_m_s"] < hi]
            if sel:
                out.append({**_group_row("bias", f"{base}, {lo:g}-{min(hi, 3.0):g} m/s", sel)})
    return out


def coverage_markdown(table: Sequence[dict], bias: Sequence[dict], *, seeds: str) -> str:
    """The coverage table and the bias per speed band as Markdown."""
    lines = ["# Response model: accuracy and interval coverage per group", "", seeds, "",
             "| group | value | trials | m* median / worst | bias (signed median) | against the truth | 90 % cover | "
             "95 % cover (Wilson 95 %) |", "|---|---|---|---|---|---|---|---|"]
    for r in list(table) + list(bias):
        lines.append(f"| {r['group']} | {r['value']} | {r['trials']} | {100 * r['median_error']:.2f} / "
                     f"{100 * r['worst_error']:.2f} % | {100 * r['bias']:+.2f} % | {100 * r['bias_truth']:+.2f} % | "
                     f"{100 * r['covered_90']:.1f} % | "
                     f"{100 * r['covered_95']:.1f} % ({100 * r['covered_95_low']:.0f}-{100 * r['covered_95_high']:.0f})"
                     " |")
    return "\n".join(lines) + "\n"
