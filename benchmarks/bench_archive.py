"""Archive I/O: time to write and read one trial file, for each file layout considered.

A trial is synthetic (``tests/synthetic.py``: the schema's channels at the rig's default
rates, 1 s of recording by default) so the numbers do not wait for the rig. Each layout is
timed several times after one warm-up; the table shows the median wall time, the median CPU
time of this process (steadier when other jobs share the machine) and the file size.

Write layouts:

- ``xarray tree``: one ``DataTree.to_netcdf`` call, h5netcdf engine, the archive's encodings
- ``xarray per group``: root, ``measured`` and ``truth`` by three ``Dataset.to_netcdf`` calls
- ``xarray tree, raw``: one call, no compression (not compliant: the archive compresses)
- ``h5py deflate N``: the archive's writer (``campaign.archive``), deflate level N + shuffle
- ``h5py deflate 1 + fletcher32``: with HDF5's per-chunk checksums as well
- ``h5py raw``: the archive's writer without compression (not compliant, for reference)
- ``write_trial``, ``write_trial, no fsync``: the public call (validation, digests, temp file,
  fsync, rename), and the same without the fsync

Read layouts: ``xr.open_dataset(group="measured")``, ``xr.open_datatree`` (both groups),
``open_trial`` (the archive's loader: one h5py read for the schema and digest check, whose
arrays then go through xarray's CF decoding; identical result to ``xr.open_dataset``) for
each group, ``open_trial_tree`` (both groups, identical to ``xr.open_datatree``), and the
check alone (h5py + digest).

Usage::

    python benchmarks/bench_archive.py                      # print the tables
    python benchmarks/bench_archive.py --readme benchmarks/out/summary.md   # also record them there

The archive's budget is 50 ms to write one trial; the script exits with status 1 if
``write_trial`` misses it (median wall time) for any base.
"""

from __future__ import annotations

import functools
import os

# one BLAS thread per job, set before numpy loads: the timings are those of one core
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import datetime
import platform
import statistics
import sys
import tempfile
from importlib.metadata import version
from pathlib import Path

import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from campaign import __version__, archive  # noqa: E402
from campaign.bench.common import blas_line, wall_and_cpu  # noqa: E402

from synthetic import synthetic_trial  # noqa: E402

HEADING = "## Archive I/O"
BUDGET_MS = 50.0


def _time(fn, repeats: int) -> tuple[float, float]:
    """(median wall, median CPU) in ms after one warm-up call."""
    wall, cpu = wall_and_cpu(fn, repeats)
    return statistics.median(wall) * 1e3, statistics.median(cpu) * 1e3


def _write_layouts(tree: xr.DataTree, folder: Path):
    prepared = archive.prepare_trial(tree)
    plan = archive.fileformat.plan_trial(tree)
    raw = prepared.copy()
    for node in raw.subtree:
        for var in node.variables.values():
            var.encoding = {k: v for k, v in var.encoding.items() if k not in ("zlib", "complevel", "shuffle")}
            if var.encoding.get("chunksizes") is not None:
                var.encoding["chunksizes"] = None

    def per_group(path):
        xr.Dataset(attrs=prepared.attrs).to_netcdf(path, engine="h5netcdf", mode="w")
        for group in archive.GROUPS:
            prepared[group].to_dataset().to_netcdf(path, engine="h5netcdf", mode="a", group=group)

    return [
        ("xarray tree", True, lambda p: prepared.to_netcdf(p, engine="h5netcdf")),
        ("xarray per group", True, per_group),
        ("xarray tree, raw", False, lambda p: raw.to_netcdf(p, engine="h5netcdf")),
        ("h5py deflate 1 (chosen)", True, lambda p: archive.write._write_h5(plan, p, level=1)),
        ("h5py deflate 4", True, lambda p: archive.write._write_h5(plan, p, level=4)),
        ("h5py deflate 9", True, lambda p: archive.write._write_h5(plan, p, level=9)),
        ("h5py deflate 1 + fletcher32", True, lambda p: archive.write._write_h5(plan, p, level=1, fletcher32=True)),
        ("h5py raw", False, lambda p: archive.write._write_h5(plan, p, level=0)),
        ("write_trial", True, lambda p: archive.write_trial(tree, p)),
        ("write_trial, no fsync", True, lambda p: archive.write_trial(tree, p, fsync=False)),
    ]


def _read_layouts(path: Path):
    def open_group():
        with xr.open_dataset(path, engine="h5netcdf", group="measured") as ds:
            ds.load()

    def open_tree():
        with xr.open_datatree(path, engine="h5netcdf") as tree:
            tree.load()

    return [
        ("xr.open_dataset, measured", open_group),
        ("xr.open_datatree, both groups", open_tree),
        ("open_trial, measured", lambda: archive.open_trial(path)),
        ("open_trial, truth", lambda: archive.open_trial(path, group="truth")),
        ("open_trial_tree, both groups", lambda: archive.open_trial_tree(path)),
        ("check only (h5py + digest), measured", lambda: archive.read.inspect_trial(path, groups=("measured",))),
    ]


def measure(*, duration: float, repeats: int) -> tuple[list[dict], list[dict]]:
    writes, reads = [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for base in ("fixed", "flexible"):
            tree = synthetic_trial(base=base, duration=duration)
            n_vars = sum(len(tree[g].variables) for g in archive.GROUPS)
            for name, compliant, write in _write_layouts(tree, folder):
                path = folder / f"{base}.nc"
                wall, cpu = _time(functools.partial(write, path), repeats)
                writes.append(dict(base=base, layout=name, compliant=compliant, wall=wall, cpu=cpu,
                                   size=path.stat().st_size, n_vars=n_vars))
            path = archive.write_trial(tree, folder / f"{base}.nc")
            for name, read in _read_layouts(path):
                wall, cpu = _time(read, repeats)
                reads.append(dict(base=base, layout=name, wall=wall, cpu=cpu))
    return writes, reads


def format_tables(writes: list[dict], reads: list[dict]) -> str:
    lines = ["| base | write layout | compliant | variables | median wall [ms] | median CPU [ms] | size [kB] |",
             "|---|---|---|---|---|---|---|"]
    for r in writes:
        lines.append(f"| {r['base']} | {r['layout']} | {'yes' if r['compliant'] else 'no'} | {r['n_vars']} | "
                     f"{r['wall']:.1f} | {r['cpu']:.1f} | {r['size'] / 1e3:.0f} |")
    lines += ["", "| base | read | median wall [ms] | median CPU [ms] |", "|---|---|---|---|"]
    for r in reads:
        lines.append(f"| {r['base']} | {r['layout']} | {r['wall']:.1f} | {r['cpu']:.1f} |")
    return "\n".join(lines)


def write_section(readme: Path, body: str) -> None:
    """Replace (or append) this script's section of ``readme`` (campaign.bench.write_section)."""
    from campaign.bench import write_section as _write_section

    _write_section(readme, HEADING, body)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=1.0, help="recording length of the synthetic trial [s]")
    parser.add_argument("--repeats", type=int, default=15, help="timed calls per layout (after one warm-up)")
    parser.add_argument("--readme", type=Path, help=f"write the summary under '{HEADING}' in this file")
    args = parser.parse_args(argv)
    print(blas_line())

    writes, reads = measure(duration=args.duration, repeats=args.repeats)
    table = format_tables(writes, reads)
    chosen = {r["base"]: r for r in writes if r["layout"] == "write_trial"}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    verdict = ", ".join(f"{b} {r['wall']:.1f} ms" for b, r in chosen.items())
    ok = all(r["wall"] <= BUDGET_MS for r in chosen.values())
    summary = "\n".join([
        f"Cost of one trial file ({args.duration:g} s synthetic recording at the rig's default rates, "
        f"`tests/synthetic.py`), median of {args.repeats} calls after a warm-up. `write_trial` "
        f"(validation, digests, temp file, fsync, rename): **{verdict}** against the budget of "
        f"{BUDGET_MS:.0f} ms ({'met' if ok else 'missed'}).",
        "",
        table,
        "",
        "Choice: xarray's h5netcdf engine spends about 5 ms of Python per variable, whatever its size "
        "(one `DataTree.to_netcdf` call or one call per group alike, compressed or not), so a trial's "
        "36-51 variables cost several times the budget. `campaign.archive` therefore writes the same "
        "netCDF-4 layout with h5py's low-level API (dimension scales, `_Netcdf4Dimid`, creation order), "
        "and the tests check that xarray decodes it identically to a file xarray writes itself. Deflate "
        "level 1 + shuffle: levels 4 and 9 shrink these float channels by well under 1 % for more time. "
        "Fletcher-32 is left off: each group's `content_sha256` already detects any change of content on "
        "read. Reads: xarray's h5netcdf backend costs the same 5 ms per variable, so `open_trial` does "
        "not reopen the file with it; it reads each file once with h5py for the schema and digest check "
        "and hands those arrays to xarray's own CF decoding (an in-memory data store), a few ms more than "
        "the check alone; the tests check the result is identical to `xr.open_dataset` (values, dtypes, "
        "attributes, encodings) on rig trials of both bases.",
        "",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPUs, load average {load:.1f} during the run; "
        f"Python {platform.python_version()}, xarray {version('xarray')}, h5netcdf {version('h5netcdf')}, "
        f"h5py {version('h5py')}, HDF5 {archive.h5py.version.hdf5_version}, campaign {__version__}; "
        f"{datetime.date.today().isoformat()}. Rerun: `.venv/bin/python benchmarks/bench_archive.py "
        "--readme benchmarks/out/summary.md`.",
    ])
    print(summary)
    if args.readme is not None:
        write_section(args.readme, summary)
        print(f"\nwrote the section '{HEADING}' of {args.readme}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
