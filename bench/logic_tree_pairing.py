"""Common random numbers for a logic tree's run settings: the variance of a branch difference, paired against
independent (docs/logic_tree.md, "On the rare-event route").

Two run settings -- the pulse amplitude of Eq. (6) as printed (vp_scale 1) and scaled (``--scale``, 1.5) --
with real runs: the verification column (bench/data/column_two_drums.toml), the tiny site of the rare-event
tests (tests/data/site_rare_tiny.toml: one Mw 6.5 source at 5-10 km, four strata), records cut to
``--max-record-s`` (8 s) so that a run takes about 10 ms. For every repetition r (seeds 1, 2, ...):

* *paired*: the two settings simulated on the same events (:func:`pycolfrag.rare.paired.simulate_paired`, one
  seed), ``--runs`` runs each; the difference d_r = lambda_2 - lambda_1 of every level;
* *independent*: each setting its own single simulation (:func:`pycolfrag.rare.driver.simulate_site`) with its
  own seed (1000 + r for the second), as two separate studies would run them.

Printed per level: the variance of d over the repetitions, paired and independent, their ratio (the factor of
runs that pairing saves for the same precision of the difference), and the mean over the repetitions of the
variance of d estimated *within one paired run* (the stratified variance of the rows' differences w_i (y2_i -
y1_i): the same rows, the same weights) against V_1 + V_2 (what independent estimates would have). The full
benchmark (10 repetitions of 300 runs per setting: 12 000 runs) takes about 4 minutes on one core; ``--quick``
(4 of 150) about one. Results also in bench/results/logic_tree_pairing.json.
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from pycolfrag.rare.driver import SiteSettings, StopRule, simulate_site
from pycolfrag.rare.evaluator import GridEvaluator, RecordSettings
from pycolfrag.rare.paired import simulate_paired
from pycolfrag.risk.paired_difference import paired_differences
from pycolfrag.risk.site_risk import QUANTITIES
from pycolfrag.site.sources import load_site
from pycolfrag.structure.column import Column

ROOT = Path(__file__).resolve().parents[1]
LEVELS = ("u_top > 0.15", "u_top > 0.35", "u_d > 0.005", "collapse")


def _evaluator(folder: Path, record: RecordSettings) -> GridEvaluator:
    return GridEvaluator(folder, record, None, progress=False, log=lambda s: None)


def _records(args) -> tuple:
    col = Column.from_file(ROOT / "bench" / "data" / "column_two_drums.toml").to_dict()
    base = RecordSettings(column=col, max_record_s=args.max_record_s)
    scaled = RecordSettings(column=col, max_record_s=args.max_record_s, vp_scale=args.scale)
    return base, scaled


def _repetition(site, r: int, args, tmp: Path) -> dict:
    base, scaled = _records(args)
    settings = SiteSettings(seed=r, batch=args.batch)
    stop = StopRule(target_cov=0.01, max_runs=args.runs)            # the whole budget, every time
    quiet = lambda s: None  # noqa: E731
    pa, pb = simulate_paired(site, settings, stop, [_evaluator(tmp / f"p{r}a", base), _evaluator(tmp / f"p{r}b", scaled)],
                             QUANTITIES, log=quiet)
    ia = simulate_site(site, settings, stop, _evaluator(tmp / f"i{r}a", base), QUANTITIES, log=quiet)
    ib = simulate_site(site, SiteSettings(seed=1000 + r, batch=args.batch), stop, _evaluator(tmp / f"i{r}b", scaled),
                       QUANTITIES, log=quiet)
    out = {}
    paired = paired_differences(pa, pb)      # the product's paired variance (the batches as pieces, its floors)
    for lb in LEVELS:
        la, lb_ = pa.estimate.levels[lb], pb.estimate.levels[lb]
        out[lb] = {"paired": lb_.rate - la.rate,
                   "independent": ib.estimate.levels[lb].rate - ia.estimate.levels[lb].rate,
                   "within_paired": paired[lb].sd ** 2,
                   "within_independent": (la.cov * la.rate) ** 2 + (lb_.cov * lb_.rate) ** 2}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="4 repetitions of 150 runs per setting (about a minute)")
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--runs", type=int, default=300, help="runs per setting and simulation")
    ap.add_argument("--batch", type=int, default=140)
    ap.add_argument("--scale", type=float, default=1.5, help="vp_scale of the second run setting")
    ap.add_argument("--max-record-s", type=float, default=8.0)
    ap.add_argument("--site", default=str(ROOT / "tests" / "data" / "site_rare_tiny.toml"))
    ap.add_argument("--out", default=str(ROOT / "bench" / "results" / "logic_tree_pairing.json"))
    a = ap.parse_args(argv)
    if a.quick:
        a.reps, a.runs, a.batch = 4, 150, 65
    site = load_site(a.site)
    t0 = time.perf_counter()
    reps = []
    with tempfile.TemporaryDirectory(prefix="pcf_pairing_") as tmp:
        for r in range(1, a.reps + 1):
            reps.append(_repetition(site, r, a, Path(tmp)))
            print(f"repetition {r}/{a.reps} done ({time.perf_counter() - t0:.0f} s)", flush=True)
    wall = time.perf_counter() - t0
    print(f"\nvp_scale 1 against {a.scale:g}, {a.site}, {a.runs} runs per setting, {a.reps} repetitions, "
          f"{4 * a.runs * a.reps} runs in {wall:.0f} s")
    print(f"{'level':<14} {'mean d /yr':>11} {'var d paired':>13} {'var d indep':>12} {'ratio':>7} "
          f"{'within: paired':>15} {'V1+V2':>10} {'ratio':>7}")
    summary = {}
    for lb in LEVELS:
        dp = np.array([x[lb]["paired"] for x in reps])
        di = np.array([x[lb]["independent"] for x in reps])
        vp, vi = float(np.var(dp, ddof=1)), float(np.var(di, ddof=1))
        wp = float(np.mean([x[lb]["within_paired"] for x in reps]))
        wi = float(np.mean([x[lb]["within_independent"] for x in reps]))
        ratio = vi / vp if vp > 0 else math.inf
        wratio = wi / wp if wp > 0 else math.inf
        summary[lb] = {"mean_difference": float(np.mean(dp)), "var_paired": vp, "var_independent": vi,
                       "ratio": ratio, "within_paired": wp, "within_independent": wi, "within_ratio": wratio}
        print(f"{lb:<14} {np.mean(dp):11.3e} {vp:13.3e} {vi:12.3e} {ratio:7.2f} {wp:15.3e} {wi:10.3e} {wratio:7.2f}")
    print("ratio: the variance of the difference independent / paired = the factor of runs pairing saves for the "
          "same precision of the branch difference")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"settings": {k: v for k, v in vars(a).items()}, "wall_s": wall,
                                       "levels": summary, "repetitions": reps}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
