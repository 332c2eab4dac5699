#!/usr/bin/env python3
"""``pycolfrag figures`` under its old name (pycolfrag/cli/figures.py).

    python scripts/make_figures.py results/grid.h5 [--out results/figures]   # = pycolfrag figures ...
"""
import os
import sys

# the checkout's package first, as these scripts always ran it (no install needed)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from pycolfrag.cli.main import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(["figures", *sys.argv[1:]]))
