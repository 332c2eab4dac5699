"""The rare route's estimator with and without the weights' known mean as a control variate, on the surrogate of
the tests (tests/rare_surrogate.py: closed-form outcomes, exact rates by quadrature), docs/risk.md's table.

Each repetition simulates the tests' small site (tests/test_rare_site.py: 14 strata, 870 runs, seed 1000 + i)
once; both estimators read the same rows (a budget of 870 with a target CoV of 0.01 never stops early, so the
rows do not depend on the estimator). Per level: the mean's bias against the exact rate, the observed CoV over the
repetitions, the stated CoV (root mean square), the share of 90 % intervals holding the exact rate, and the
efficiency against crude Monte Carlo, Lambda^2 p (1 - p) / (observed variance x runs), p = lambda / Lambda the
probability per simulated event.

    nice -n 10 .venv/bin/python bench/rare_control_variate.py --reps 200      # about 5 CPU-minutes
"""
from __future__ import annotations

import argparse
import io
import math
import sys
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from pycolfrag.rare.driver import SiteSettings, StopRule, simulate_site  # noqa: E402
from pycolfrag.rare.estimate import estimate  # noqa: E402
from pycolfrag.risk.site_risk import QUANTITIES  # noqa: E402
from rare_surrogate import SurrogateEvaluator, exact_rates  # noqa: E402
from test_rare_site import SMALL, small_site  # noqa: E402

RUNS = 870
#: The estimators compared: the plain one (v3) and the weights' known mean as control variate (v4).
VARIANTS = ("plain", "control variate")


def _variant(key: str, run):
    return estimate(run.cols, run.strata, run.design, run.quantities, floor=run.floor, control=key != "plain",
                    pieces=True)


def repetitions(reps: int, first_seed: int = 1000) -> dict:
    """{estimator: (rates, covs, held)} arrays (reps, levels) of the plain and the control-variate estimator."""
    site = small_site()
    exact = exact_rates(site, QUANTITIES)
    out = {k: (np.zeros((reps, len(QUANTITIES))), np.zeros((reps, len(QUANTITIES))),
               np.zeros((reps, len(QUANTITIES)), bool)) for k in VARIANTS}
    for i in range(reps):
        with redirect_stdout(io.StringIO()):
            run = simulate_site(site, SiteSettings(seed=first_seed + i, batch=200, **SMALL), StopRule(0.01, RUNS),
                                SurrogateEvaluator(), QUANTITIES, log=lambda s: None)
        for key in VARIANTS:
            e = _variant(key, run)
            for j, q in enumerate(QUANTITIES):
                lv = e.levels[q.label]
                out[key][0][i, j], out[key][1][i, j] = lv.rate, lv.cov
                out[key][2][i, j] = lv.low <= exact[q.label] <= lv.high
    return out


def table(out: dict, reps: int) -> str:
    site = small_site()
    exact = exact_rates(site, QUANTITIES)
    total = sum(s.rate for s in site.sources)
    lines = [f"Surrogate small site, {reps} repetitions of {RUNS} runs (seeds 1000-{999 + reps}), both estimators on "
             "the same rows:", "",
             "| level | p per event | estimator | mean / exact - 1 (SE) | observed CoV | stated CoV (rms) | 90 % held | "
             "efficiency vs crude |", "|---|---:|---|---:|---:|---:|---:|---:|"]
    for j, q in enumerate(QUANTITIES):
        lam = exact[q.label]
        p = lam / total
        for key, (rates, covs, held) in out.items():
            sd = rates[:, j].std(ddof=1)
            eff = total ** 2 * p * (1 - p) / (sd ** 2 * RUNS)
            lines.append(f"| {q.label} | {p:.2e} | {key} | {rates[:, j].mean() / lam - 1:+.3f} "
                         f"({sd / lam / math.sqrt(reps):.3f}) | {sd / lam:.3f} | "
                         f"{math.sqrt(np.mean(covs[:, j] ** 2)):.3f} | {held[:, j].mean():.3f} | {eff:.2f} |")
    for key, (_, _, held) in out.items():
        lines.append(f"\n{key}: 90 % intervals holding the exact rate, all levels: {held.mean():.3f} "
                     f"(binomial SE {math.sqrt(0.09 / held.size):.3f})")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=200)
    a = ap.parse_args(argv)
    print(table(repetitions(a.reps), a.reps))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
