"""Sequences of mainshocks at a site by crude Monte Carlo (docs/sequences.md, "Sequences at a site"):
prints P(collapse within the horizon) with and without accumulated damage, the accumulated u_d and tilt
at the horizon, the levels of Tables III/IV exceeded within it, and the effect of a restoration policy,
each with its binomial standard error (:mod:`pycolfrag.risk.sequences`).

    python bench/sequences_site.py --quick            # 50 sequences of the example site (~15 s on 1 core)
    python bench/sequences_site.py                    # 1000 sequences (a few minutes on 1 core)
    python bench/sequences_site.py --site examples/site_athens.toml --years 50 --n 1000 --restore-u-d 0.005 \
        --json results/sequences/athens.json

One process, one core (the runs are short: a sequence of the example site costs about 0.2 s).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from pycolfrag import Column
from pycolfrag.risk.sequences import DEFAULT_SEED, SequenceSettings, format_summary, run_site_sequences, summarize
from pycolfrag.site.sources import load_site
from pycolfrag.solver.sequence import Restoration

ROOT = Path(__file__).resolve().parents[1]


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--site", default=str(ROOT / "examples" / "site_athens.toml"), help="site file (TOML, docs/risk.md)")
    p.add_argument("--column", default=None, help="column file (default: Column.parthenon())")
    p.add_argument("--years", type=float, default=50.0, help="the horizon, years")
    p.add_argument("--n", type=int, default=1000, help="sequences")
    p.add_argument("--quick", action="store_true", help="50 sequences")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help="root seed")
    p.add_argument("--restore-u-d", type=float, default=0.005,
                   help="the policy: reassemble when the accumulated u_d exceeds this (default: Table IV's first level)")
    p.add_argument("--restore-tilt", type=float, default=math.inf, help="... or the residual tilt exceeds this, rad")
    p.add_argument("--max-record-s", type=float, default=None, help="cut the records (quick looks only)")
    p.add_argument("--json", default=None, help="also write the summary here")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="a line per 10 %% done")
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    n = 50 if args.quick else args.n
    site = load_site(args.site)
    col = Column.from_file(args.column) if args.column else Column.parthenon()
    st = SequenceSettings(years=args.years, n_sequences=n, seed=args.seed,
                          restoration=Restoration(u_d=args.restore_u_d, tilt_rad=args.restore_tilt),
                          max_record_s=args.max_record_s)

    def progress(done, total):
        if args.progress and (done == total or done % max(1, total // 10) == 0):
            print(f"  {done}/{total} sequences", file=sys.stderr, flush=True)
    sm = summarize(run_site_sequences(site, col, st, progress=progress))
    print(format_summary(sm, f"{site.name}: {col.name}, {n} sequences of {args.years:g} years"))
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(sm, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
