"""``campaign import`` and ``campaign identify-recordings``: recorded hits of real robots."""

from __future__ import annotations

import sys

from ..core.errors import InputError
from ..core.files import check_output_dir, check_output_file
from ..recordings import (
    FITS,
    NO_LICENCE,
    RecordedHitOptions,
    check_mass,
    identify_folder,
    import_airhockey,
    import_mapped,
    write_hit_table,
)
from .commands import HELP

__all__ = ["register"]

FORMATS = ("airhockey", "csv")


def _import(args) -> int:
    check_output_dir(args.out)
    if args.format == "airhockey":
        if args.mapping:
            raise InputError("--mapping belongs to --format csv; the air-hockey layout needs none")
        if not args.source:
            raise InputError("--format airhockey needs one or more SOURCE folders of hits")
        check_mass(args.object_mass)
        done = import_airhockey(args.source, args.out, object_mass=args.object_mass, licence=args.license)
    else:
        if not args.mapping:
            raise InputError("--format csv needs --mapping FILE (a YAML file naming the columns, units and files)")
        done = import_mapped(args.mapping, args.out, object_mass=args.object_mass,
                             licence=None if args.license == NO_LICENCE else args.license)
    for path, report in done:
        print(f"{path}: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                      for k, v in report.items()))
    print(f"imported {len(done)} hit(s) into {args.out}", file=sys.stderr)
    return 0


def _identify(args) -> int:
    check_output_file(args.out)
    opts = RecordedHitOptions(fit=args.fit, n_boot=args.bootstrap, seed=args.seed)
    rows = identify_folder(args.dir, opts)
    write_hit_table(rows, args.out)
    ok = sum(r["flag"] == "ok" for r in rows)
    print(f"{args.out}: {len(rows)} hit(s), {ok} ok, "
          f"{sum(str(r['flag']).startswith('poor') for r in rows)} flagged, "
          f"{sum(str(r['flag']).startswith('refused') for r in rows)} refused ({args.fit} fits)")
    return 0


def register(sub) -> None:
    """Add ``campaign import`` and ``campaign identify-recordings``."""
    p = sub.add_parser("import", help=HELP["import"],
                       description="Import recorded hits of a real robot into a recording folder: one NetCDF4/HDF5 "
                       "file per hit (groups /robot and /object, no truth), index.csv, README.md and "
                       "MANIFEST.sha256. Stale rows are dropped, glitched stamps repaired and the object's clock "
                       "aligned to the robot's; each hit's line says what was done.")
    p.add_argument("source", nargs="*", metavar="SOURCE",
                   help="--format airhockey: session folders of <ROBOT>_hit_<N>.csv and object_<K>_hit_<N>.csv")
    p.add_argument("--format", choices=FORMATS, required=True,
                   help="airhockey: the air-hockey hitting dataset's layout; csv: any CSV files a --mapping describes")
    p.add_argument("--mapping", metavar="FILE", default=None,
                   help="--format csv: YAML file naming the files, columns, units, frames and object mass")
    p.add_argument("--object-mass", dest="object_mass", default=None, metavar="KG",
                   help="the struck object's mass [kg] (the air-hockey files do not hold it; for --format csv it "
                   "overrides the mapping's object_mass)")
    p.add_argument("--license", default=NO_LICENCE, metavar="TEXT",
                   help=f"the source's licence, stored with every hit (default: {NO_LICENCE!r})")
    p.add_argument("--out", required=True, metavar="DIR", help="recording folder to write into (created)")
    p.set_defaults(func=_import)

    p = sub.add_parser("identify-recordings", help=HELP["identify-recordings"],
                       description="Identify m* (momentum balance) and e per recorded hit of a recording folder, "
                       "with bootstrap intervals; a poorly conditioned hit is flagged or refused with the reason.")
    p.add_argument("dir", metavar="DIR", help="recording folder (campaign import)")
    p.add_argument("--fit", choices=FITS, default="quadratic",
                   help="model of each body's motion before and after the contact (default quadratic: constant "
                   "acceleration; linear: constant velocity)")
    p.add_argument("--bootstrap", type=int, default=400, metavar="N", help="bootstrap draws (default 400)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="seed of the bootstrap (default 0)")
    p.add_argument("--out", required=True, metavar="CSV", help="per-hit table to write")
    p.set_defaults(func=_identify)
