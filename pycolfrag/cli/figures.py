"""``pycolfrag figures``: the paper's figures (Figs. 7, 8, 9, 11-16; PNG and PDF) from a results file.

    pycolfrag figures results/grid.h5 [--out results/figures] [--n-boot 500] [--seed 0]

(``python scripts/make_figures.py`` in a checkout is the same.)
"""
import argparse
import os
import sys

import matplotlib

from pycolfrag.analysis import figures
from pycolfrag.analysis.completeness import ALLOW_INCOMPLETE_HELP
from pycolfrag.core.errors import PycolfragError


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="pycolfrag figures", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", help="HDF5 results file of pycolfrag grid")
    p.add_argument("--out", default=None, help="output directory (default: <results dir>/figures)")
    p.add_argument("--n-boot", type=int, default=500, help="bootstrap resamples for surfaces and bands")
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstrap")
    p.add_argument("--allow-incomplete", action="store_true", help=ALLOW_INCOMPLETE_HELP)
    a = p.parse_args(argv)
    matplotlib.use("Agg")   # files only: no window, whatever backend the user's matplotlib would pick
    out = a.out or os.path.join(os.path.dirname(os.path.abspath(a.results)), "figures")
    try:
        paths = figures.make_all(a.results, out, n_boot=a.n_boot, rng=a.seed, allow_incomplete=a.allow_incomplete)
    except (PycolfragError, OSError) as exc:
        print(f"pycolfrag figures: {exc}", file=sys.stderr)
        return 2
    for path in paths:
        print(path)
    return 0
