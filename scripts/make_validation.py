#!/usr/bin/env python
"""Write docs/validation.md: the paper's quantitative statements against a results file.

    python scripts/make_validation.py results/grid.h5 \
        [--sensitivity vp_scale=2=results/sensitivity/vp2.h5 ...] [--out docs/validation.md] [--notes FILE]

NAME=FILE pairs split at the last '='. ``--notes`` appends a hand-written Markdown file (e.g. the
discussion of the sensitivity runs) after the generated sections.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from pycolfrag.analysis import validation  # noqa: E402


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", help="main HDF5 results file (the paper's grid)")
    p.add_argument("--sensitivity", action="append", default=[], metavar="NAME=FILE",
                   help="further results file to compare key numbers with (repeatable)")
    p.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs",
                                                  "validation.md"))
    p.add_argument("--notes", default=None, help="Markdown file appended at the end")
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstraps")
    a = p.parse_args(argv)
    sens = {}
    for item in a.sensitivity:
        if "=" not in item:
            p.error(f"--sensitivity expects NAME=FILE, got {item!r}")
        name, path = item.rsplit("=", 1)
        sens[name] = path
    out = validation.write_validation(a.results, a.out, sens, rng=a.seed)
    if a.notes:
        with open(out, "a", encoding="utf-8") as fh, open(a.notes, encoding="utf-8") as nf:
            fh.write("\n" + nf.read())
    print(os.path.normpath(out))


if __name__ == "__main__":
    main()
