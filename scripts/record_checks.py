#!/usr/bin/env python3
"""``pycolfrag record-checks`` under its old name (pycolfrag/cli/record_checks.py).

    python scripts/record_checks.py fig10 --records SOURCE ...   # = pycolfrag record-checks fig10 ...
"""
import os
import sys

# the checkout's package first, as these scripts always ran it (no install needed)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from pycolfrag.cli.main import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(["record-checks", *sys.argv[1:]]))
