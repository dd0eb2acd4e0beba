"""``campaign archive``: verify, finalize and list a campaign folder of trial files."""

from __future__ import annotations

import argparse
import csv
import sys

from campaign.archive import INDEX_COLUMNS, finalize_campaign, list_trials, verify_report
from campaign.core.errors import InputError
from campaign.recordings import is_recording_folder, verify_recordings

from .commands import HELP

__all__ = ["register"]


def _filters(items: list[str] | None) -> dict[str, str]:
    """``["gain=low", "config=1,2"]`` -> ``{"gain": "low", "config": "1,2"}``."""

    out: dict[str, str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--filter expects key=value, got {item!r}")
        out[key.strip()] = value.strip()
    return out


def _verify(args: argparse.Namespace) -> int:

    if is_recording_folder(args.dir):
        found = verify_recordings(args.dir)
        for rel, message in found:
            print(f"{args.dir.rstrip('/')}/{rel}: {message}")
        if found:
            print(f"campaign archive verify: {len(found)} problem(s)", file=sys.stderr)
            return 1
        print(f"{args.dir}: ok")
        return 0
    report = verify_report(args.dir)
    problems = report.problems
    for problem in problems:
        print(f"{args.dir.rstrip('/')}/{problem}")
    # information, not a problem: a campaign run on a cluster spans nodes of several CPUs
    note = report.platform_note()
    if note:
        print(f"{args.dir}: {note}")
    if problems:
        files = len({p.file for p in problems})
        print(f"campaign archive verify: {len(problems)} problem(s) in {files} file(s)", file=sys.stderr)
        return 1
    print(f"{args.dir}: ok")
    return 0


def _finalize(args: argparse.Namespace) -> int:

    written = finalize_campaign(args.dir)
    n = len(list_trials(args.dir))
    for path in written.values():
        print(path)
    print(f"finalized {n} trial(s)", file=sys.stderr)
    return 0


def _ls(args: argparse.Namespace) -> int:


    records = list_trials(args.dir, **_filters(args.filter))
    if args.format == "csv":
        writer = csv.DictWriter(sys.stdout, fieldnames=INDEX_COLUMNS, lineterminator="\n")
        writer.writeheader()
        for rec in records:
            writer.writerow(rec.row())
        return 0
    columns = ("path", "base", "config", "gain", "speed", "repeat", "seed", "scene")
    rows = [[str(rec.row()[c]) for c in columns] for rec in records]
    widths = [max([len(c)] + [len(r[i]) for r in rows]) for i, c in enumerate(columns)]
    print("  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True)).rstrip())
    for r in rows:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)).rstrip())
    print(f"{len(records)} trial(s)", file=sys.stderr)
    return 0


def register(subparsers) -> None:
    """Add ``campaign archive {verify,finalize,ls}``."""
    parser = subparsers.add_parser(
        "archive", help=HELP["archive"],
        description="Work on a campaign folder (archive/<name>/): one NetCDF4/HDF5 file per trial, "
        "index.csv, README.md and MANIFEST.sha256.")
    sub = parser.add_subparsers(dest="archive_command", metavar="ACTION", required=True)

    p = sub.add_parser("verify", help="check every file against the manifest and every trial against the schema",
                       description="Check a campaign folder: manifest hashes, missing and unlisted files, and "
                       "each trial's schema version, channels and content digest. Prints one line per "
                       "problem naming its file; exit status 1 if there is any, 2 if DIR is not a campaign. "
                       "Trials computed on more than one platform (CPU, BLAS kernel, library versions) are "
                       "listed per platform, as information: that is no problem.")
    p.add_argument("dir", metavar="DIR", help="campaign folder")
    p.set_defaults(func=_verify)

    p = sub.add_parser("finalize", help="write index.csv, README.md and MANIFEST.sha256",
                       description="Check every trial, then write index.csv, README.md (generated from the "
                       "schema) and MANIFEST.sha256 (sha256sum format) into DIR.")
    p.add_argument("dir", metavar="DIR", help="campaign folder")
    p.set_defaults(func=_finalize)

    p = sub.add_parser("ls", help="list the trials of a campaign, optionally filtered",
                       description="List the trials of a campaign folder with their scene parameters.")
    p.add_argument("dir", metavar="DIR", help="campaign folder")
    p.add_argument("--filter", action="append", metavar="KEY=VALUE",
                   help="keep trials whose KEY (base, config, gain, speed, repeat, seed, scene, scene_sha256, "
                   "robot) is VALUE; VALUE may be a comma-separated list; repeat the option to combine")
    p.add_argument("--format", choices=("table", "csv"), default="table", help="output format (default: table)")
    p.set_defaults(func=_ls)
