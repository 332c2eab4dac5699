"""``pycolfrag validation``: the paper's quantitative statements against a results file (docs/validation.md).

    pycolfrag validation results/grid.h5 \
        [--sensitivity vp_scale=2=results/sensitivity/vp2.h5 ...] [--out validation.md] [--notes FILE]

(``python scripts/make_validation.py`` in a checkout is the same, and writes the checkout's
docs/validation.md by default.)

NAME=FILE pairs split at the last '='. ``--notes`` appends a hand-written Markdown file (e.g. the
discussion of the sensitivity runs) after the generated sections.
"""
import argparse
import os
import sys

from pycolfrag.analysis import validation
from pycolfrag.analysis.completeness import ALLOW_INCOMPLETE_HELP
from pycolfrag.core.errors import PycolfragError
from pycolfrag.core.input_files import read_text


def main(argv=None) -> int:
    """Command-line entry point; exit code 0, or 2 with one line naming the bad input (a record-suite
    file, an incomplete or damaged one, an unreadable notes file)."""
    p = argparse.ArgumentParser(prog="pycolfrag validation", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", help="main HDF5 results file (the paper's grid)")
    p.add_argument("--sensitivity", action="append", default=[], metavar="NAME=FILE",
                   help="further results file to compare key numbers with (repeatable)")
    p.add_argument("--out", default=None, help="the page to write (default: validation.md beside the results file)")
    p.add_argument("--notes", default=None, help="Markdown file appended at the end")
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstraps")
    p.add_argument("--allow-incomplete", action="store_true", help=ALLOW_INCOMPLETE_HELP)
    a = p.parse_args(argv)
    sens = {}
    for item in a.sensitivity:
        if "=" not in item:
            p.error(f"--sensitivity expects NAME=FILE, got {item!r}")
        name, path = item.rsplit("=", 1)
        sens[name] = path
    try:
        notes = read_text(a.notes, "notes file", max_bytes=16 << 20) if a.notes else None
        target = a.out or os.path.join(os.path.dirname(os.path.abspath(a.results)), "validation.md")
        out = validation.write_validation(a.results, target, sens, rng=a.seed, allow_incomplete=a.allow_incomplete)
        if notes is not None:
            with open(out, "a", encoding="utf-8") as fh:
                fh.write("\n" + notes)
    except (PycolfragError, OSError) as exc:
        print(f"pycolfrag validation: {exc}", file=sys.stderr)
        return 2
    print(os.path.normpath(out))
    return 0
