"""Compare two runs of the campaign (folders holding ``archive/`` and ``results/``) product by
product; exit 1 naming every difference, 0 when they agree.

Usage: ``python tests/cluster/compare_runs.py <reference run> <other run>``

What "agree" means for each kind of file, from what a local run reproduces when run twice:

- trial files (``*.nc``): HDF5 bytes differ run to run (the root attributes ``date_created``
  and ``history``, which starts with that time, unless ``SOURCE_DATE_EPOCH`` fixes it),
  so each group's ``content_sha256`` (a digest of the group's attributes and every variable's
  bytes and attributes, checked against the data when the archive is finalized) must be
  equal, and every root attribute except those two and the root digest that covers them;
- ``MANIFEST.sha256``: the same files listed, with equal digests for every file but trials;
- job manifests (``archive/<name>/.jobs/**.json``): the same job and trials, each with the
  same path, group digests, index row, clock rates and kept flag (a trial file's own sha256
  and size vary with its write time like its bytes);
- job logs (``results/*/logs``) and Snakemake benchmark records (``results/*/benchmarks``):
  present in both (they hold times and dates, so their contents are not compared);
- everything else (tables, figures, fits, identification tables, the archive's index and
  README, the calibration report): byte for byte.

Snakemake's own state (``.snakemake/``) is not a product and is ignored.
"""

from __future__ import annotations

import json
import sys
from collections import Counter
from pathlib import Path

import h5py

# root attributes of a trial file that depend on when it was written (see module docstring)
TIME_ATTRS = {"date_created", "history", "content_sha256"}
UNCOMPARED_DIRS = {"logs", "benchmarks"}


def products(run: Path) -> set[str]:
    """Relative paths of every file under ``run``'s archive/ and results/ folders."""
    return {p.relative_to(run).as_posix() for top in ("archive", "results") if (run / top).is_dir()
            for p in (run / top).rglob("*") if p.is_file()}


def kind(rel: str) -> str:
    parts = rel.split("/")
    if parts[-1].endswith(".nc"):
        return "trial"
    if parts[-1] == "MANIFEST.sha256":
        return "manifest"
    if parts[0] == "archive" and ".jobs" in parts and parts[-1].endswith(".json"):
        return "job manifest"
    if parts[0] == "results" and len(parts) > 2 and parts[2] in UNCOMPARED_DIRS:
        return "log"
    return "bytes"


def _plain(value):
    return value.tolist() if hasattr(value, "tolist") else value


def trial_summary(path: Path) -> dict[str, dict]:
    """{group: attributes compared} of one trial file: each group's digest, the root's attributes."""
    out = {}
    with h5py.File(path, "r") as f:
        out["/"] = {k: _plain(v) for k, v in f.attrs.items() if k not in TIME_ATTRS}

        def visit(name, obj):
            if isinstance(obj, h5py.Group):
                out[name] = {"content_sha256": _plain(obj.attrs.get("content_sha256"))}

        f.visititems(visit)
    return out


def manifest(path: Path) -> dict[str, str]:
    """{file: sha256} of a ``sha256sum``-format manifest."""
    entries = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        digest, _, name = line.partition("  ")
        entries[name] = digest
    return entries


# a job manifest entry's fields that depend on when its trial file was written
WRITE_FIELDS = {"sha256", "size"}


def job_manifest(path: Path) -> dict:
    """A job manifest without the fields of its entries that vary with the write time."""
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["trials"] = [{k: v for k, v in t.items() if k not in WRITE_FIELDS} for t in doc.get("trials", [])]
    return doc


def compare(a: Path, b: Path) -> tuple[Counter, list[str]]:
    """(files agreeing, by kind; differences) of run ``b`` against run ``a``."""
    files_a, files_b = products(a), products(b)
    problems = [f"only in {a}: {rel}" for rel in sorted(files_a - files_b)]
    problems += [f"only in {b}: {rel}" for rel in sorted(files_b - files_a)]
    agree: Counter = Counter()
    for rel in sorted(files_a & files_b):
        k = kind(rel)
        fa, fb = a / rel, b / rel
        if k == "trial":
            sa, sb = trial_summary(fa), trial_summary(fb)
            if sa.keys() != sb.keys():
                problems.append(f"{rel}: groups {sorted(sa)} vs {sorted(sb)}")
                continue
            bad = [g for g in sa if sa[g] != sb[g]]
            if any(sa[g].get("content_sha256") is None for g in sa if g != "/"):
                bad.append("(a group without content_sha256)")
            if bad:
                problems.append(f"{rel}: groups {bad} differ")
                continue
        elif k == "manifest":
            ma, mb = manifest(fa), manifest(fb)
            if ma.keys() != mb.keys():
                problems.append(f"{rel}: lists {sorted(ma.keys() ^ mb.keys())} in one run only")
                continue
            bad = [n for n in ma if not n.endswith(".nc") and ma[n] != mb[n]]
            if bad:
                problems.append(f"{rel}: digests of {bad} differ")
                continue
        elif k == "job manifest":
            ja, jb = job_manifest(fa), job_manifest(fb)
            if ja != jb:
                paths = [t.get("path") for t, u in zip(ja["trials"], jb["trials"], strict=False) if t != u]
                problems.append(f"{rel}: entries differ ({paths or 'job or trial list'})")
                continue
        elif k == "bytes" and fa.read_bytes() != fb.read_bytes():
            problems.append(f"{rel}: bytes differ")
            continue
        agree[k] += 1
    if not files_a:
        problems.append(f"{a} holds no products")
    return agree, problems


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: compare_runs.py <reference run> <other run>", file=sys.stderr)
        return 2
    a, b = (Path(p) for p in argv)
    for run in (a, b):
        if not run.is_dir():
            print(f"compare_runs.py: {run} is not a folder", file=sys.stderr)
            return 2
    agree, problems = compare(a, b)
    labels = {"bytes": "byte-identical", "trial": "trials with equal group digests",
              "manifest": "manifests agreeing (trials by digest)",
              "job manifest": "job manifests agreeing (trials by group digest)", "log": "logs/benchmark records present in both"}
    for k, label in labels.items():
        print(f"  {agree[k]:4d} {label}")
    for p in problems:
        print(f"  DIFFERENT: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
