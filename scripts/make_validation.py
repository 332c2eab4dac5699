#!/usr/bin/env python3
"""``pycolfrag validation`` under its old name (pycolfrag/cli/validation.py), writing this
checkout's docs/validation.md unless ``--out`` says otherwise.

    python scripts/make_validation.py results/grid.h5 [--sensitivity NAME=FILE ...] [--notes FILE]
"""
import os
import sys

# the checkout's package first, as these scripts always ran it (no install needed)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from pycolfrag.cli.main import main  # noqa: E402

DOCS_PAGE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "validation.md")

if __name__ == "__main__":
    args = sys.argv[1:]
    if not any(a == "--out" or a.startswith("--out=") for a in args):
        args += ["--out", os.path.normpath(DOCS_PAGE)]
    sys.exit(main(["validation", *args]))
