#!/usr/bin/env python3
"""``pycolfrag figures`` under its old name (pycolfrag/analysis/figures_command.py).

    python scripts/make_figures.py results/grid.h5 [--out results/figures]   # = pycolfrag figures ...
"""
import sys

from pycolfrag.commands import main

if __name__ == "__main__":
    sys.exit(main(["figures", *sys.argv[1:]]))
