"""CPU per trial of identification and of writing trial files: this tree against a revision before it.

Both stages are timed as the campaign's jobs run them, on the committed reference archive's
trials (``archive/reference``: the reduced campaign, 18 fixed-base and 8 space-class
flexible-base trials), old and new side by side in the same run:

``write``
    ``campaign.archive.write_trial_entry`` per trial, as a simulation job writes (checking,
    digests, the HDF5 image, the atomic write with its fsync, the file's sha256 and its
    index row), into a temporary campaign folder; the trials are read once beforehand.
``identify``
    what an identification job does per trial (``campaign.identify.identify_trials`` less its
    CSV): ``load_trial(path, arrays=True)`` (the checked read) and ``identify_trial``, on
    the files that revision's own writer wrote, with its split into the two.

Each measurement runs in a fresh process (the old revision's ``campaign`` and ``config``
extracted with ``git archive``), BLAS pinned to one thread before numpy loads, after one
untimed pass over the trials; rounds interleave old and new so that both see the same
machine load; the table gives medians over the rounds of the CPU per trial
(``time.process_time``) and the files' mean size.

Target: each stage at most half the old revision's CPU per trial on both bases. Exits with
status 1 if a target is missed.

Usage::

    python benchmarks/bench_identify_write.py                       # against OLD_REV, 3 rounds
    python benchmarks/bench_identify_write.py --old main --rounds 5
"""

from __future__ import annotations

import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tarfile  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
REFERENCE = REPO / "archive" / "reference"
#: the revision before identification and the trial files were made cheaper (the "old" columns)
OLD_REV = "e0f3c47c1a96134b180e22bff81968c825ae884b"
#: the full campaign's 18 cells at 600 speeds and 2 repeats: half fixed, half flexible
ARCHIVE_TRIALS = 21_600
#: each stage's new CPU per trial at most this fraction of the old
TARGET = 0.5
#: timed passes per process; the least counts
PASSES = 3


# -- the measuring process -------------------------------------------------------------------
def child(base: str, folder: Path) -> dict:
    """CPU per trial [s] of this process's ``campaign`` writing and identifying one base's trials."""
    import gc

    import scipy.optimize  # noqa: F401  (identification's edge fits: keep the import out of the timing)

    from campaign.archive import open_trial_tree
    from campaign.archive.jobs import write_trial_entry
    from campaign.identify import identify_trial
    from campaign.identify.loading import load_trial
    from campaign.model.robot import load_robot

    sources = sorted((REFERENCE / base).rglob("*.nc"))
    trees = [open_trial_tree(p) for p in sources]
    paths = [folder / p.relative_to(REFERENCE) for p in sources]
    n = len(paths)
    robot = load_robot(str(trees[0].attrs["robot"]))

    def write():
        for tree, path in zip(trees, paths, strict=True):
            write_trial_entry(tree, path, campaign_dir=folder)

    def identify(split=None):
        for path in paths:
            c0 = time.process_time()
            measured, attrs = load_trial(path, arrays=True)
            c1 = time.process_time()
            identify_trial(measured, robot=robot, meta={**attrs, "path": str(path)}, where=str(path))
            if split is not None:
                split["load"] += (c1 - c0) / n
                split["fit"] += (time.process_time() - c1) / n

    def timed(fn):
        """The least CPU per trial of :data:`PASSES` passes (another job's load only adds)."""
        best = float("inf")
        for _ in range(PASSES):
            gc.collect()
            c0 = time.process_time()
            fn()
            best = min(best, (time.process_time() - c0) / n)
        return best

    write()      # warm-up, untimed: the first pass pays for lazy imports and caches
    out = {"write": timed(write), "size": sum(p.stat().st_size for p in paths) / n}
    identify()
    out["identify"] = timed(identify)
    splits = []
    for _ in range(PASSES):
        split = {"load": 0.0, "fit": 0.0}
        gc.collect()
        identify(split)
        splits.append(split)
    out.update(min(splits, key=lambda d: d["load"] + d["fit"]))
    return out


def layouts(base: str) -> list[dict]:
    """Size and CPU of a trial file's HDF5 image per storage setting that HDF5 and netCDF-C
    both read (this tree's writer, one base's trials): no compression, deflate at levels 1,
    4 and 6 with and without shuffle on every time series, and the writer's own choice."""
    import gc

    from campaign.archive import fileformat, open_trial_tree, write

    trees = [open_trial_tree(p) for p in sorted((REFERENCE / base).rglob("*.nc"))]
    plans = [fileformat.plan_trial(t) for t in trees]
    chosen = {id(v): dict(v.encoding) for _, groups in plans for g in groups.values() for v in g.variables}
    settings = [("none", 0, False), ("deflate 1", 1, False), ("deflate 1 + shuffle", 1, True),
                ("deflate 4 + shuffle", 4, True), ("deflate 6 + shuffle", 6, True), ("chosen", None, None)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "trial.nc"
        for label, level, shuffle in settings:
            for _, groups in plans:
                for g in groups.values():
                    for v in g.variables:
                        enc = v.encoding = dict(chosen[id(v)])
                        if level is None or not (v.dims and v.dims[0] in fileformat.CLOCKS):
                            continue
                        rows_ = enc.get("chunksizes") or ((v.data.shape[0],) + v.data.shape[1:])
                        enc.update(zlib=bool(level), shuffle=shuffle, chunksizes=rows_ if level else None)
            lvl = fileformat.DEFLATE_LEVEL if level is None else max(level, 1)

            def image(lvl=lvl):
                return [write._hdf5_image(plan, scratch, level=lvl) for plan in plans]

            image()
            best = float("inf")
            for _ in range(PASSES):
                gc.collect()
                c0 = time.process_time()
                sizes = [len(b) for b in image()]
                best = min(best, (time.process_time() - c0) / len(plans))
            rows.append({"setting": label, "cpu": best, "size": sum(sizes) / len(sizes)})
    return rows


# -- the driver ------------------------------------------------------------------------------
def _old_tree(rev: str, dest: Path) -> Path:
    """The old revision's ``campaign`` package and ``config`` folder, extracted under ``dest``."""
    data = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", rev, "campaign", "config"],
                          check=True, capture_output=True).stdout
    tar = dest / "old.tar"
    tar.write_bytes(data)
    with tarfile.open(tar) as tf:
        tf.extractall(dest / "old", filter="data")
    return dest / "old"


def _run(root: Path, base: str, folder: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root)}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", base, "--folder", str(folder)]
    res = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True, cwd=str(root))
    return json.loads(res.stdout.strip().splitlines()[-1])


def _rows(base: str, old: list, new: list) -> tuple[list[str], bool, dict]:
    """Table rows of one base from the rounds' measurements, whether both targets are met,
    and the medians."""
    def med(runs, key):
        return 1e3 * statistics.median(r[key] for r in runs)

    rows, ok, m = [], True, {}
    for stage in ("write", "identify"):
        a, b = med(old, stage), med(new, stage)
        met = b <= TARGET * a
        ok &= met
        m[stage] = (a, b)
        extra = (f"load {med(old, 'load'):.1f} + fit {med(old, 'fit'):.1f} -> load {med(new, 'load'):.1f} + "
                 f"fit {med(new, 'fit'):.1f}" if stage == "identify" else
                 f"{old[0]['size'] / 1e3:.0f} kB -> {new[0]['size'] / 1e3:.0f} kB a file")
        rows.append(f"| {base} {stage} | {a:.1f} | {b:.1f} | {a / b:.2f}x | {extra} | "
                    f"{'met' if met else 'MISSED'} |")
    m["size"] = (old[0]["size"], new[0]["size"])
    return rows, ok, m


def _layout_table(bases) -> str:
    """The storage settings' size against CPU, per base (this tree, one fresh process each)."""
    head = "| setting | " + " | ".join(f"{b} CPU [ms] | {b} size [kB]" for b in bases) + " |"
    measured = {}
    for base in bases:
        env = {**os.environ, "PYTHONPATH": str(REPO)}
        cmd = [sys.executable, str(Path(__file__).resolve()), "--child-layouts", base]
        res = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True, cwd=str(REPO))
        measured[base] = json.loads(res.stdout.strip().splitlines()[-1])
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for i, row in enumerate(measured[bases[0]]):
        cells = " | ".join(f"{measured[b][i]['cpu'] * 1e3:.1f} | {measured[b][i]['size'] / 1e3:.0f}" for b in bases)
        lines.append(f"| {row['setting']} | {cells} |")
    return ("HDF5 image of a trial file per storage setting (no checks, digests, fsync or sha256; "
            "least of 3 passes):\n" + "\n".join(lines))


def _archive_line(medians: dict) -> str:
    """What an archive of :data:`ARCHIVE_TRIALS` trials (half of each base) costs, old and new."""
    half = ARCHIVE_TRIALS / 2
    parts = []
    for i, label in ((0, "old"), (1, "new")):
        disk = sum(medians[b]["size"][i] for b in medians) * half / 1e9
        cpu = sum(medians[b]["write"][i] for b in medians) * half / 1e3
        parts.append(f"{label} {disk:.1f} GB, {cpu / 60:.1f} CPU min to write")
    return f"{ARCHIVE_TRIALS:,} trials (half fixed, half flexible): " + "; ".join(parts)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--bases", nargs="+", default=["fixed", "flexible"], choices=("fixed", "flexible"))
    ap.add_argument("--old", default=OLD_REV, help="revision of the old code (default: %(default)s)")
    ap.add_argument("--child", choices=("fixed", "flexible"), help=argparse.SUPPRESS)
    ap.add_argument("--folder", help=argparse.SUPPRESS)
    ap.add_argument("--child-layouts", choices=("fixed", "flexible"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child, Path(args.folder))))
        return 0
    if args.child_layouts:
        print(json.dumps(layouts(args.child_layouts)))
        return 0

    from campaign.bench.common import blas_line, machine_line

    print(blas_line())
    print(f"old: {args.old[:12]} (extracted with git archive); new: {REPO}; {args.rounds} interleaved rounds, "
          "each measurement in a fresh process after one untimed pass")
    head = "| stage | old [ms] | new [ms] | speed-up | detail | target (new <= old / 2) |"
    lines, all_ok, medians = [head, "|---" * (head.count("|") - 1) + "|"], True, {}
    print("\n".join(lines), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        old_root = _old_tree(args.old, Path(tmp))
        for base in args.bases:
            old, new = [], []
            for r in range(args.rounds):
                order = (("old", old_root, old), ("new", REPO, new))
                for role, root, into in (order if r % 2 == 0 else order[::-1]):
                    into.append(_run(root, base, Path(tmp) / f"{role}-{r}"))
            rows, ok, medians[base] = _rows(base, old, new)
            lines += rows
            all_ok &= ok
            print("\n".join(rows), flush=True)
    print()
    print("\n".join(lines))
    print("[CPU ms per trial: medians over", args.rounds, "rounds of the least of", PASSES, "passes]")
    print()
    print(_layout_table(args.bases))
    if set(medians) == {"fixed", "flexible"}:
        print(_archive_line(medians))
    print(machine_line())
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
