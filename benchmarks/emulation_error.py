"""Emulation error of the VES-II loop: base motion under the loop vs the ideal coupling.

Simulates one flexible-base trial twice -- the VES-II emulation loop at its default rate,
latency and bandwidth (``ves.mode = loop``), and arm + structure integrated as one system
(``ves.mode = ideal``) -- and compares the emulated base displacement along x after the
impact. Prints the peak displacements and their relative difference (the target is
< 5 %), writes a PNG of both traces and, with ``--readme``, its section of
benchmarks/README.md.

Rerun: ``.venv/bin/python benchmarks/emulation_error.py --png benchmarks/emulation_error.png
--readme benchmarks/README.md``
"""

from __future__ import annotations

import argparse
import datetime
import platform
from pathlib import Path

import numpy as np

HEADING = "## VES-II emulation error"


def run(config: int, gain: str, speed: float):
    from campaign.rig import simulate
    from campaign.scene.description import make_scene

    out = {}
    for mode in ("loop", "ideal"):
        tree = simulate(make_scene(base="flexible", config=config, gain=gain, speed=speed,
                                   params={"ves.mode": mode}))
        m = tree["measured"]
        t0 = float(tree["truth"].contact_start)
        out[mode] = (m.t_base.values - t0, m.base_position.sel(axis="x").values)
    return out


def plot(traces, png: Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.2), constrained_layout=True)
    for mode, style in (("ideal", dict(color="0.2", lw=2.0, label="ideal coupling (one system)")),
                        ("loop", dict(color="tab:orange", lw=1.2, ls="--", label="VES-II emulation loop"))):
        t, x = traces[mode]
        ax.plot(t, 1e3 * x, **style)
    ax.axvline(0.0, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("time after the contact start [s]")
    ax.set_ylabel("base displacement x [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.savefig(png, dpi=150)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=int, default=2)
    parser.add_argument("--gain", default="high")
    parser.add_argument("--speed", type=float, default=2.5, help="impact speed [m/s]")
    parser.add_argument("--png", type=Path, default=Path("benchmarks/emulation_error.png"))
    parser.add_argument("--readme", type=Path, default=None)
    args = parser.parse_args(argv)
    traces = run(args.config, args.gain, args.speed)
    peaks = {m: float(np.max(np.abs(x[t >= 0]))) for m, (t, x) in traces.items()}
    rel = peaks["loop"] / peaks["ideal"] - 1.0
    # compare on the loop's samples after the touch (the recordings may differ by a sample)
    t, xl = traces["loop"]
    xi = np.interp(t, *traces["ideal"])
    rms = float(np.sqrt(np.mean((xl - xi)[t >= 0] ** 2)) / peaks["ideal"])
    title = (f"Base motion, configuration {args.config}, {args.gain} gains, {args.speed} m/s: "
             f"loop vs ideal peak {100 * rel:+.1f} %")
    plot(traces, args.png, title)
    from campaign.scene.description import make_scene
    p = make_scene(base="flexible").p
    body = "\n".join([
        f"Configuration {args.config}, {args.gain} gains, {args.speed} m/s; VES loop at its defaults "
        f"(rate {p('ves.rate'):g} Hz, latency {p('ves.latency'):g} s, bandwidth {p('ves.bandwidth'):g} Hz) "
        "against arm and structure integrated as one system. Traces: `benchmarks/emulation_error.png`.",
        "",
        "| quantity | ideal coupling | VES loop | relative difference |",
        "|---|---|---|---|",
        f"| peak base displacement x [mm] | {1e3 * peaks['ideal']:.4f} | {1e3 * peaks['loop']:.4f} | "
        f"{100 * rel:+.2f} % (target < 5 %) |",
        f"| rms difference after the touch / ideal peak | | | {100 * rms:.1f} % |",
        "",
        f"Machine: {platform.machine()}; Python {platform.python_version()}; "
        f"{datetime.date.today().isoformat()}. Rerun: see the script's docstring.",
    ])
    print(body)
    if args.readme:
        from campaign.bench import write_section
        write_section(args.readme, HEADING, body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
