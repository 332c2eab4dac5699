#!/usr/bin/env python3
"""``pycolfrag record-checks`` under its old name (pycolfrag/analysis/record_checks.py).

    python scripts/record_checks.py fig10 --records SOURCE ...   # = pycolfrag record-checks fig10 ...
"""
import sys

from pycolfrag.commands import main

if __name__ == "__main__":
    sys.exit(main(["record-checks", *sys.argv[1:]]))
