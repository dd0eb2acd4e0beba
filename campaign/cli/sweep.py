"""``campaign sweep``: simulate a batch of trials together and write one file per trial."""

from __future__ import annotations

import contextlib
import io
import sys
import time
from pathlib import Path

from ..archive import MANIFEST, TRIAL_BYTES
from ..core.errors import InputError
from ..core.files import check_output_dir
from ..core.vocabulary import FIXED, bases, config_folder, gain_sets, layout
from ..pipeline.sweep import run_cells
from ..scene.checks import check_seed
from .args import key_value
from .commands import HELP


def _items(text: str, *, option: str, convert, what: str) -> list:
    """A comma-separated option value as a list: no empty item, no item twice, at least one."""
    parts = [part.strip() for part in str(text).split(",")]
    if parts == [""]:
        raise InputError(f"{option} {text!r}: expected at least one {what}")
    out = []
    for i, part in enumerate(parts, 1):
        if not part:
            raise InputError(f"{option} {text}: item {i} is empty")
        try:
            value = convert(part)
        except ValueError:
            raise InputError(f"{option} {text}: {part!r} is not a {what}") from None
        if value in out:
            raise InputError(f"{option} {text}: {part} is given twice (each trial is simulated once)")
        out.append(value)
    return out


#: the most trials per speed (a campaign configuration's ``repeats`` maximum) and per sweep
MAX_REPEATS = 100
MAX_TRIALS = 10_000


def _check_not_finalized(out: str) -> None:
    """``out`` is not (inside) a finalized archive: its manifest lists every file with its
    sha256, so a trial added or replaced there would fail ``campaign archive verify``."""
    folder = Path(out).absolute()
    for parent in (folder, *folder.parents):
        if (parent / MANIFEST).is_file():
            where = "is" if parent == folder else f"is inside {parent}, which is"
            raise InputError(f"--out {out}: {where} a finalized archive ({MANIFEST} lists its files); a sweep there "
                             "would add or replace trials the manifest does not list: sweep into another folder")


def register(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help=HELP["sweep"],
        description="Simulate every configuration x gain set x speed x repeat of one base (every scene checked "
        "before any trial runs; the same numbers as `campaign trial` gives each of them), and "
        "write one NetCDF4/HDF5 file per trial under OUT, at the campaign's paths "
        "(<base>/config<N>/<gain>/v<speed>/r<repeat>.nc). Rig parameters come from config/rig.yaml (SI units). "
        "A trial file already there is replaced only by the same trial (same cell, seed and rig); another "
        "trial there, or a finalized archive (with its MANIFEST.sha256), is refused before any work.",
    )
    p.add_argument("--base", choices=bases(), default=FIXED, help="base of every trial (default fixed)")
    p.add_argument("--configs", default="1,2,3", metavar="N,N",
                   help="arm configurations of the robot (the PUMA 560's: the paper's Table 1; default 1,2,3)")
    p.add_argument("--gains", default=",".join(gain_sets()), metavar="G,G",
                   help="servo gain sets of Table 1 (default zero,low,high)")
    p.add_argument("--speeds", required=True, metavar="V,V",
                   help="hammer speeds along the impact direction [m/s], e.g. 1.0,1.5,2.5")
    p.add_argument("--repeats", type=int, default=1, metavar="R", help="trials per speed (default 1)")
    p.add_argument("--campaign-seed", type=int, default=0, metavar="S",
                   help="seed the trials' seeds derive from, with their cells (default 0)")
    p.add_argument("--rig", default=None, metavar="PATH", help="rig parameter file (default config/rig.yaml)")
    p.add_argument("--set", dest="params", type=key_value, action="append", default=[], metavar="KEY=VALUE",
                   help="override a rig parameter by dotted key, e.g. --set contact.stiffness=2000 (SI units)")
    p.add_argument("--out", required=True, metavar="DIR", help="folder the trial files go under (written atomically)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args) -> int:
    configs = _items(args.configs, option="--configs", convert=int, what="configuration number")
    gains = _items(args.gains, option="--gains", convert=str, what="gain set")
    speeds = _items(args.speeds, option="--speeds", convert=float, what="speed")
    if not 1 <= args.repeats <= MAX_REPEATS:
        raise InputError(f"--repeats {args.repeats}: expected 1 to {MAX_REPEATS} trials per speed (as a "
                         "campaign configuration's repeats)")
    check_seed(args.campaign_seed, key="--campaign-seed")
    total = len(configs) * len(gains) * len(speeds) * args.repeats
    if total > MAX_TRIALS:
        raise InputError(f"--speeds, --configs, --gains, --repeats: {total} trials, over the {MAX_TRIALS} one sweep "
                         "runs (about 0.1 s each; the full campaign has 216): split the sweep")
    for g in gains:
        if g not in gain_sets():
            raise InputError(f"--gains: unknown gain set {g!r}; expected one of {', '.join(gain_sets())}")
    cells = [(args.base, c, g) for c in configs for g in gains]
    files = [Path(*layout(args.base, config_folder(c), g, v, r)) for _, c, g in cells for v in speeds
             for r in range(args.repeats)]
    _check_not_finalized(args.out)
    # a trial file that exists is replaced when it holds the same trial (run_cells refuses
    # another one): its space comes back once its successor is written
    new = sum(not (Path(args.out) / f).is_file() for f in files)
    check_output_dir(args.out, files=files, need=max(new, 1) * TRIAL_BYTES[args.base])
    # a progress line redrawn in place on a terminal; nothing when the output is a file
    tty = sys.stderr.isatty() and not args.quiet
    t0 = time.perf_counter()

    def progress(done: int, total: int, cell: str) -> None:
        if tty:
            width = 30
            bar = "#" * (width * done // total) + "-" * (width - width * done // total)
            print(f"\r[{bar}] {done}/{total} trials, {time.perf_counter() - t0:.1f} s  {cell:<34}", end="",
                  file=sys.stderr, flush=True)
            if done == total:
                print(file=sys.stderr)

    log = io.StringIO()
    try:
        with contextlib.redirect_stdout(log):      # run_cells' per-trial lines, printed after the bar
            written = run_cells(cells, archive_dir=args.out, speeds=speeds, repeats=args.repeats,
                                campaign_seed=args.campaign_seed, rig=args.rig, params=dict(args.params),
                                progress=progress, keep_others="--out")
    finally:
        if not args.quiet:
            print(log.getvalue(), end="", flush=True)
    if not args.quiet:
        print(f"wrote {len(written)} trials under {args.out} in {time.perf_counter() - t0:.1f} s")
    return 0
