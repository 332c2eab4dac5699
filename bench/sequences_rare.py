"""The target of rare sequences (docs/sequences.md, "Rare sequences"): P(collapse within 50 years) with
accumulation at the example site and its CoV, the accumulated u_d's exceedance of Table IV's levels, and the
runs against those of the single-event rare route at the same CoV.

    mpirun -n 2 python -m mpi4py -m pycolfrag sequences examples/site_athens.toml results/sequences_rare \\
        --rare --target collapse --target-cov 0.2 --pilot 5          # resumable
    python bench/sequences_rare.py results/sequences_rare --single results/risk/rare/risk.json

``--single``: the rare route's ``risk.json`` of the same site and column (``make risk-rare``); the single-event
runs at the sequences' CoV are its runs times (its CoV / the sequences' CoV)^2 (a CoV falls as one over the
square root of the runs).
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folder", help="the output folder of pycolfrag sequences --rare (rare_summary.json)")
    p.add_argument("--single", default=None, help="the rare route's risk.json of the same site and column")
    p.add_argument("--years", type=float, default=50.0, help="the horizon of the sequences, years")
    args = p.parse_args(argv)
    sm = json.loads((Path(args.folder) / "rare_summary.json").read_text())
    est = sm["estimate"]
    print(f"rare sequences: {sm['rows']} rows over {sm['strata']} strata, {sm['runs']} event runs, "
          f"{sm['seconds']:.0f} s of runs ({platform.processor() or platform.machine()})\n")
    print(f"| quantity | P within {args.years:g} yr: accumulated [CoV] | intact [CoV] | restored [CoV] | hits | "
          "P on strata of < 20 rows |\n|---|---|---|---|---|---|")
    for q, a in est["accumulated"].items():
        cells = " | ".join(f"{est[w][q]['p']:.3g} [{est[w][q]['cov']:.2f}]" for w in ("accumulated", "intact", "restored"))
        print(f"| {q} | {cells} | {a['hits']} | {a['p_on_few_rows']:.2g} |")
    if args.single:
        single = json.loads(Path(args.single).read_text())
        c = single["levels"]["collapse"]
        cov_seq = est["accumulated"]["collapse"]["cov"]
        same = single["runs"] * (c["cov"] / cov_seq) ** 2
        p50 = 1.0 - math.exp(-args.years * c["rate"])
        print(f"\nsingle event (rare route): lambda(collapse) {c['rate']:.3g}/yr, CoV {c['cov']:.3f} from "
              f"{single['runs']} runs; P(collapse in {args.years:g} yr) = 1 - exp(-T lambda) = {p50:.3g}")
        print(f"its runs at the sequences' CoV {cov_seq:.3f}: {same:.0f}; the sequences' runs: {sm['runs']} "
              f"({sm['runs'] / same:.2f}x; target <= 2x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
