"""Emulation error of the VES-II loop: base motion under the loop against the ideal coupling.

Simulates one flexible-base trial (configuration 2, High gains, 2.5 m/s) twice: the VES-II
emulation loop at its default rate, latency and bandwidth (``ves.mode = loop``), and arm and
structure integrated as one system (``ves.mode = ideal``), and compares the emulated base
displacement along x after the impact: the peaks and their relative difference (target
< 5 %) and the rms difference after the touch (``emulation_error.csv``), both traces
(``traces.csv``) and a figure of them (``emulation_error.png``).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..core.files import write_atomic
from ..core.vocabulary import FLEXIBLE, HIGH
from ..rig import simulate
from ..scene.description import make_scene
from .common import Log, quiet, write_csv

__all__ = ["traces", "compare", "plot", "run"]


def traces(config: int, gain: str, speed: float) -> dict:
    """{mode: (time after the contact start [s], base displacement x [m])} for both VES modes."""
    out = {}
    for mode in ("loop", "ideal"):
        tree = simulate(make_scene(base=FLEXIBLE, config=config, gain=gain, speed=speed, params={"ves.mode": mode}))
        m = tree["measured"]
        t0 = float(tree["truth"].contact_start)
        out[mode] = (m.t_base.values - t0, m.base_position.sel(axis="x").values)
    return out


def compare(tr: dict) -> dict:
    """Peak displacements after the touch, the loop's relative difference and the rms
    difference on the loop's samples (interpolated ideal) over the ideal peak."""
    peaks = {m: float(np.max(np.abs(x[t >= 0]))) for m, (t, x) in tr.items()}
    t, xl = tr["loop"]
    xi = np.interp(t, *tr["ideal"])
    return {"peak_ideal_m": peaks["ideal"], "peak_loop_m": peaks["loop"],
            "peak_relative_difference": peaks["loop"] / peaks["ideal"] - 1.0,
            "rms_difference_over_peak": float(np.sqrt(np.mean((xl - xi)[t >= 0] ** 2)) / peaks["ideal"])}


def plot(tr: dict, png, title: str) -> None:
    """Both traces in one figure (PNG)."""
    import matplotlib  # matplotlib loads only where the figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.2), constrained_layout=True)
    for mode, style in (("ideal", dict(color="0.2", lw=2.0, label="ideal coupling (one system)")),
                        ("loop", dict(color="tab:orange", lw=1.2, ls="--", label="VES-II emulation loop"))):
        t, x = tr[mode]
        ax.plot(t, 1e3 * x, **style)
    ax.axvline(0.0, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("time after the contact start [s]")
    ax.set_ylabel("base displacement x [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=150)
    plt.close(fig)
    write_atomic(png, buf.getvalue())


def run(out_dir, *, quick: bool = False, log: Log = quiet, config: int = 2, gain: str = HIGH,
        speed: float = 2.5) -> list[str]:
    """Run the study and write its files into ``out_dir``; returns their paths. ``quick``
    changes nothing: the study is two trials."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tr = traces(config, gain, speed)
    p = make_scene(base=FLEXIBLE).p
    row = {"config": config, "gain": gain, "speed_m_s": speed, "ves_rate_Hz": p("ves.rate"),
           "ves_latency_s": p("ves.latency"), "ves_bandwidth_Hz": p("ves.bandwidth"), **compare(tr)}
    log(f"loop vs ideal peak {100 * row['peak_relative_difference']:+.2f} %")
    plot(tr, out / "emulation_error.png", f"Base motion, configuration {config}, {gain} gains, {speed} m/s: "
         f"loop vs ideal peak {100 * row['peak_relative_difference']:+.1f} %")
    samples = [{"mode": mode, "t_s": t, "x_m": x} for mode, (ts, xs) in tr.items() for t, x in zip(ts, xs, strict=True)]
    return [write_csv(out / "emulation_error.csv", [row], tuple(row)),
            write_csv(out / "traces.csv", samples, ("mode", "t_s", "x_m")), str(out / "emulation_error.png")]
