"""Coverage of the site risk's 90 % intervals at few runs per cell, for every estimator and method.

Subsamples a grid of many runs per cell (default: the default grid's EDPs shipped in
tests/data/default_grid_edps.npz, 100 runs per cell; or a results file) down to ``--runs`` per cell,
``--reps`` times, and prints per level how often each method's interval holds the full grid's value,
how often that value lies above it, and the median width (pycolfrag.risk.coverage). The
site is the example site, pulse branch alone. The table of docs/risk.md ("Sampling error") is this
script's output:

    python bench/risk_coverage.py --reps 300
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from pycolfrag.analysis.data import ResultsData
from pycolfrag.risk.coverage import expected_coverage, subsample_coverage
from pycolfrag.risk.site_risk import ESTIMATORS
from pycolfrag.risk.uncertainty import UNCERTAINTY_METHODS
from pycolfrag.site import sources as site_file

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", help="a results file (default: the default grid's EDPs in tests/data)")
    ap.add_argument("--site", default=str(ROOT / "examples" / "site_athens.toml"))
    ap.add_argument("--runs", type=int, default=20, help="runs kept per cell")
    ap.add_argument("--reps", type=int, default=300)
    ap.add_argument("--draws", type=int, default=600)
    ap.add_argument("--methods", nargs="*", default=list(UNCERTAINTY_METHODS))
    ap.add_argument("--estimators", nargs="*", default=list(ESTIMATORS))
    a = ap.parse_args(argv)
    if a.results:
        data = a.results
        n_full = None
    else:
        g = dict(np.load(ROOT / "tests" / "data" / "default_grid_edps.npz"))
        data = ResultsData(g, None, None, None, {"complete": True}, g["mw"].size, 0, {}, "default grid")
        n_full = 100
    site = replace(site_file.load_site(a.site), outside="zero")
    if n_full:
        print(f"exact 90 % interval against the {n_full}-run value: coverage "
              f"{expected_coverage(0.90, a.runs, n_full):.3f}")
    print("| estimator | method | level | coverage | truth above | median width | full-grid value |")
    print("|---|---|---|---:|---:|---:|---:|")
    for est in a.estimators:
        for m in a.methods:
            cov, above, width, truth = subsample_coverage(site, data, n_sub=a.runs, reps=a.reps, n_draws=a.draws,
                                                          estimator=est, uncertainty=m)
            for k in cov:
                print(f"| {est} | {m} | {k} | {cov[k]:.3f} | {above[k]:.3f} | {width[k]:.2e} | {truth[k]:.2e} |")
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
