"""The steered allocation's finite-sample bias on the single-event rare route (docs/rare_events.md, "The steered
allocation's finite-sample bias"), on surrogates of the tests' column (tests/rare_surrogate.py): exact rates by
quadrature, the production driver (``simulate_site``: pilot, cross-entropy steps, batches, floors, control
variate) as ``pycolfrag risk --simulate`` runs it.

Each repetition simulates the tests' small site (tests/test_rare_site.py: 14 strata, 870 runs in batches of
200, seed 1000 + i; a target CoV of 0.01 never stops early, so every simulation makes its 870 runs) under one
surrogate and one allocation:

* surrogates -- ``base``: the tests' surrogate (a level is u_top above a threshold; the steering model's features
  Mw, ln R, z_vp, z_fp foresee ln u_top up to the record noise, sd 0.45); ``partly``: base, and besides a run
  collapses with probability q(Mw, R) = 0.04 exp(2 (Mw - 6.5)) min(1, 5 km / R) drawn from its record noise seed
  (a coin of the seed's own stream, independent of the noise: random given the features, reproducible);
  ``coin2``, ``coin05``: base, and a run collapses with a constant probability 0.02 or 0.005 whatever its event
  (hits that nothing of the event foretells). A collapse exceeds every level, so each level's probability
  given the event is P + q (1 - P), P the base surrogate's, and the exact rates are the quadrature of
  tests/rare_surrogate.py with it;
* allocations -- ``steered``: the driver's (v5: every batch split on its own by the minimax-CoV Neyman rule,
  model-steered, run and variance floors; the estimate the batches combined as pieces -- v4's pooled steered rows,
  docs/rare_events.md's "(v4)" table, are not reproduced by it);
  ``proportional``: every batch in proportion to the strata's event rates (``batch_counts`` of W_h (runs so
  far + batch)), which reads no outcome: the same driver with ``allocate_batch`` replaced; ``frozen`` (remedy
  (2) of the doc, prototyped here only): the steered allocation made once, from the pilot's rows, and every
  production batch split in proportion to that target (:class:`Frozen`), with no second cross-entropy step, so
  that after the pilot nothing reads an outcome; its estimators besides on the production rows alone
  (``production, ...``: given the pilot, their counts are fixed).

Per surrogate, allocation and level: the mean of the estimates over the repetitions against the exact rate (in %
and in pooled standard errors), the observed CoV, the stated CoV (root mean square) and the share of the stated
90 % intervals that hold the exact rate; both for the production estimator (the control variate) and the plain
stratum means on the same rows.

    nice -n 10 .venv/bin/python bench/rare_allocation_bias.py --reps 48      # 0.5-1.5 CPU-s a simulation of 870 runs

docs/rare_events.md's table of the pieces (v5, "Batches as pieces"; about 25 CPU-minutes), then pooled:

    B="nice -n 10 .venv/bin/python bench/rare_allocation_bias.py"
    $B --reps 120 --allocations steered --json p870a.json
    $B --reps 120 --first-seed 2000 --allocations steered --json p870b.json
    $B --reps 64 --runs 1670 --allocations steered --json p1670a.json
    $B --reps 64 --runs 1670 --first-seed 2000 --allocations steered --json p1670b.json
    $B --pool p870a.json p870b.json --levels collapse
    $B --pool p1670a.json p1670b.json --levels collapse
    $B --reps 64 --target-cov 0.25 --runs 4000 --allocations steered --json t025.json    # the stopping rule's part

The v4 tables (before the pieces: the steered rows are v4's driver's; about 12 CPU-minutes in all):

    B="nice -n 10 .venv/bin/python bench/rare_allocation_bias.py"
    $B --reps 80 --allocations steered --json s870.json
    $B --reps 48 --allocations proportional --json p870.json
    $B --reps 80 --first-seed 2000 --surrogates base --json base2000.json
    $B --reps 48 --runs 1670 --surrogates coin2 coin05 --allocations steered --json s1670.json
    $B --reps 48 --runs 1670 --surrogates coin2 coin05 --allocations proportional --json p1670.json
    $B --pool s870.json p870.json base2000.json s1670.json p1670.json --levels collapse

The frozen allocation (docs/rare_events.md, "A remedy prototyped in the bench, not taken", measured under v4; today
it keeps v5's first batch's split; about 15 CPU-minutes):

    $B --reps 120 --allocations frozen --json f870.json
    $B --reps 120 --first-seed 2000 --allocations frozen --json f870b.json
    $B --reps 64 --runs 1670 --allocations frozen --json f1670.json
    $B --reps 64 --runs 1670 --first-seed 2000 --allocations frozen --json f1670b.json
    $B --reps 48 --runs 1670 --surrogates base partly --allocations steered --json s1670bp.json
    $B --pool f870.json f870b.json f1670.json f1670b.json s1670bp.json --levels collapse
"""
from __future__ import annotations

import argparse
import io
import json
import math
import sys
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import rare_surrogate  # noqa: E402
from pycolfrag import results as _results  # noqa: E402
from pycolfrag.rare import allocation as _alloc  # noqa: E402
from pycolfrag.rare import driver  # noqa: E402
from pycolfrag.rare.driver import SiteSettings, StopRule, simulate_site  # noqa: E402
from pycolfrag.rare.estimate import estimate  # noqa: E402
from pycolfrag.risk.site_risk import QUANTITIES  # noqa: E402
from rare_surrogate import SurrogateEvaluator, level_probability  # noqa: E402
from test_rare_site import SMALL, small_site  # noqa: E402

RUNS = 870
#: The coin's stream under a run's record noise seed (the noise itself is the seed's first draw).
COIN_KEY = 7


def _partly(mw, r):
    return 0.04 * np.exp(2.0 * (np.asarray(mw) - 6.5)) * np.minimum(1.0, 5.0 / np.asarray(r))


#: q(Mw, R km): a run's probability of an extra collapse, by surrogate (None: the tests' surrogate).
CHANCE = {"base": None, "partly": _partly,
          "coin2": lambda mw, r: np.full(np.shape(mw), 0.02), "coin05": lambda mw, r: np.full(np.shape(mw), 0.005)}


def coin(hf_seed) -> float:
    """A uniform of the run's record noise seed, from a stream of its own (independent of the noise)."""
    return float(np.random.default_rng(np.random.SeedSequence(int(hf_seed), spawn_key=(COIN_KEY,))).random())


class CoinEvaluator(SurrogateEvaluator):
    """The tests' surrogate, a run collapsing besides when its coin falls below q(Mw, R)."""

    def __init__(self, chance):
        super().__init__()
        self.chance = chance

    def evaluate(self, name, inputs, purpose, limit=None):
        cols = super().evaluate(name, inputs, purpose, limit)
        if self.chance is not None:
            u = np.array([coin(s) for s in cols["hf_seed"]])
            extra = u < self.chance(cols["mw"], cols["dist_km"])
            cols["collapsed"] = (cols["collapsed"].astype(bool) | extra).astype(np.uint8)
        return cols


def exact_rates(site, quantities, chance) -> dict:
    """lambda of every level with the extra collapse: tests/rare_surrogate.py's quadrature of P + q (1 - P)."""
    if chance is None:
        return rare_surrogate.exact_rates(site, quantities)

    def prob(q, pulse, m, r):
        p = level_probability(q, pulse, m, r)
        return p + float(chance(m, r)) * (1.0 - p)
    return rare_surrogate.exact_rates(site, quantities, prob)


def proportional(cols, strata, design, settings, requested, stage, used, events, size, floor=None) -> dict:
    """The batch in proportion to the strata's event rates: reads the runs so far, never their outcomes."""
    W = strata.rates
    finished = np.asarray(cols["status"]) != _results.STATUS_PENDING
    done = np.bincount(np.asarray(cols["stratum"])[finished], minlength=len(strata))
    new = _alloc.batch_counts(W / W.sum() * (used + size), done, size)
    return {int(h): int(k) for h, k in enumerate(new) if k > 0}


class Frozen:
    """The steered allocation made once, from the pilot's rows, and kept: the driver's minimax-CoV target n_h
    of the first production batch (``driver.allocate_batch`` up to its last step), every production batch (the
    first included) split in proportion to it by largest remainder -- after the pilot no allocation reads an
    outcome. The target, not the first batch's increment n_h - pilot_h: the increment leaves out the strata
    whose pilot already meets their target, and the estimate on the production rows alone needs every stratum
    (each has n_h >= its pilot's 5 runs, so at least 3 of 200 runs a batch)."""

    def __init__(self):
        self.share = None

    def __call__(self, cols, strata, design, settings, requested, stage, used, events, size, floor=None) -> dict:
        if self.share is None:
            n = driver.allocate_batch(cols, strata, design, settings, requested, stage, used, events, size, floor)
            self.share = np.array([n.get(h, 0) for h in range(len(strata))], dtype=float) / float(size)
        new = _alloc.batch_counts(self.share, np.zeros(self.share.size), size)
        return {int(h): int(k) for h, k in enumerate(new) if k > 0}


#: The estimators of a repetition: (name, control variate, production rows only).
ESTIMATORS = {"control variate": (True, False), "plain": (False, False),
              "production, control variate": (True, True), "production, plain": (False, True)}


def repetitions(surrogate: str, allocation: str, reps: int, first_seed: int = 1000, runs: int = RUNS,
                target_cov: float = 0.01) -> dict:
    """{estimator: [rates, covs, held]} lists (reps x levels) of one surrogate and allocation, ``runs`` runs each.
    ``frozen``: :class:`Frozen`, and no second cross-entropy step (it reads the first batch's outcomes: every
    production batch keeps the first step's proposal, placed from the pilot); its estimators besides on the
    production rows alone (stage > 0)."""
    site = small_site()
    exact = exact_rates(site, QUANTITIES, CHANCE[surrogate])
    steered, thin_of = driver.allocate_batch, driver.thin_of
    keys = [k for k, (_, prod) in ESTIMATORS.items() if allocation == "frozen" or not prod]
    out: dict = {k: [[], [], [], []] for k in keys}
    spent: list = []
    try:
        if allocation == "proportional":
            driver.allocate_batch = proportional
        for i in range(reps):
            if allocation == "frozen":
                driver.allocate_batch, driver.thin_of = Frozen(), lambda *a: ()
            with redirect_stdout(io.StringIO()):
                run = simulate_site(site, SiteSettings(seed=first_seed + i, batch=200, **SMALL),
                                    StopRule(target_cov, runs), CoinEvaluator(CHANCE[surrogate]), QUANTITIES,
                                    log=lambda s: None)
            assert run.runs == runs or target_cov > 0.01      # a target CoV of 0.01 never stops early
            spent.append(run.runs)
            for key in out:
                control, prod = ESTIMATORS[key]
                pieces = allocation == "steered"          # the driver's own (v5): every batch a piece
                cols = run.cols
                if prod:
                    mask = np.asarray(cols["stage"]) > 0
                    cols = {k: np.asarray(v)[mask] for k, v in cols.items()}
                e = estimate(cols, run.strata, run.design, run.quantities, floor=run.floor, control=control,
                             pieces=pieces)
                lv = [e.levels[q.label] for q in QUANTITIES]
                out[key][0].append([x.rate for x in lv])
                out[key][1].append([x.cov for x in lv])
                out[key][2].append([bool(x.low <= exact[x.label] <= x.high) for x in lv])
                out[key][3].append([x.status == "refused" for x in lv])
    finally:
        driver.allocate_batch, driver.thin_of = steered, thin_of
    return {"exact": exact, "runs": runs, "spent": spent, **out}


def table(results: dict, levels=None) -> str:
    """The table of :func:`repetitions`' results, {(surrogate, allocation): result}; ``levels``: the labels shown."""
    lines = ["Surrogate small site (14 strata):", "",
             "| surrogate | allocation | runs | sims | level | exact /yr | estimator | mean / exact - 1 (SE) | bias / SE | "
             "observed CoV | stated CoV (rms) | 90 % held | refused | 90 % held, not refused |",
             "|---|---|---:|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for (sur, alloc, runs), res in results.items():
        for j, q in enumerate(QUANTITIES):
            if levels and q.label not in levels:
                continue
            lam = res["exact"][q.label]
            for key in (k for k in ESTIMATORS if k in res):
                rates, covs, held = (np.asarray(x, dtype=float) for x in res[key][:3])
                refused = np.asarray(res[key][3], dtype=bool) if len(res[key]) > 3 else np.zeros(held.shape, bool)
                kept = ~refused[:, j]
                kept_held = f"{held[kept, j].mean():.2f}" if kept.any() else "-"
                n = rates.shape[0]
                mean, sd = rates[:, j].mean(), rates[:, j].std(ddof=1)
                se = sd / math.sqrt(n)
                lines.append(f"| {sur} | {alloc} | {runs} | {n} | {q.label} | {lam:.3e} | {key} | {100 * (mean / lam - 1):+.1f} % "
                             f"({100 * se / lam:.1f}) | {(mean - lam) / se:+.1f} | {sd / lam:.3f} | "
                             f"{math.sqrt(np.nanmean(covs[:, j] ** 2)):.3f} | {held[:, j].mean():.2f} | "
                             f"{refused[:, j].mean():.2f} | {kept_held} |")
    for (sur, alloc, runs), res in results.items():
        if res.get("spent") and min(res["spent"]) < runs:
            lines.append(f"\n{sur} {alloc}: stopped by the target CoV after {np.mean(res['spent']):.0f} runs on average "
                         f"({min(res['spent'])}-{max(res['spent'])}; budget {runs})")
    lines.append("\n90 % intervals holding the exact rate, all levels, the production estimator:")
    for (sur, alloc, runs), res in results.items():
        lines.append(f"  {sur} {alloc} {runs}: {np.asarray(res['control variate'][2], dtype=float).mean():.2f}")
    return "\n".join(lines)


def merged(paths) -> dict:
    """The results of several ``--json`` files (other seeds of the same surrogates), pooled."""
    out: dict = {}
    for p in paths:
        for name, res in json.loads(Path(p).read_text()).items():
            key = (*name.split("/"), res.get("runs", RUNS))
            if key not in out:
                out[key] = {"exact": res["exact"], **{k: [list(x) for x in v] for k, v in res.items()
                                                      if k not in ("exact", "runs", "spent")}}
            else:
                for k, v in res.items():
                    if k not in ("exact", "runs", "spent"):
                        for acc, x in zip(out[key][k], v):
                            acc.extend(x)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=48)
    ap.add_argument("--surrogates", nargs="+", default=list(CHANCE), choices=list(CHANCE))
    ap.add_argument("--allocations", nargs="+", default=["steered", "proportional"],
                    choices=["steered", "proportional", "frozen"])
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--runs", type=int, default=RUNS, help="runs per simulation (870: pilot and 4 batches of 200)")
    ap.add_argument("--target-cov", type=float, default=0.01,
                    help="the stopping rule's target (default 0.01: never reached, every simulation spends --runs; "
                         "with another, --runs is the budget and the rule stops on the estimates, as in production)")
    ap.add_argument("--json", type=Path, help="also write the raw estimates here")
    ap.add_argument("--pool", type=Path, nargs="+", help="no simulation: the table of these --json files, pooled")
    ap.add_argument("--levels", nargs="+", help="the levels the table shows (default: all)")
    a = ap.parse_args(argv)
    if a.pool:
        print(table(merged(a.pool), a.levels))
        return 0
    results = {(s, al, a.runs): repetitions(s, al, a.reps, a.first_seed, a.runs, a.target_cov) for s in a.surrogates
               for al in a.allocations}
    if a.json:
        a.json.write_text(json.dumps({f"{s}/{al}": r for (s, al, _), r in results.items()}))
    print(table(results, a.levels))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
