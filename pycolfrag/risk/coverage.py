"""How honest a site risk's intervals are on a given grid: their coverage measured by subsampling.

A grid of N runs per cell stands in for the truth. Drawing n < N of each cell's runs and computing
the risk gives an interval; the share of repetitions whose interval holds the N-run value is the
coverage. The n runs are part of the N, so the N-run value lies closer to the n-run estimate than an
independent truth would: the difference has (1 - n/N) of the n-run variance, and an exact interval
of level c holds it with probability 2 Phi(z / sqrt(1 - n/N)) - 1, z = Phi^-1((1 + c)/2)
(:func:`expected_coverage`: 0.934 for c = 0.90, n = 20, N = 100). ``bench/risk_coverage.py`` prints
the table of docs/risk.md; ``tests/test_risk_coverage.py`` checks the default method with it.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from pycolfrag.analysis.data import ResultsData, as_data

__all__ = ["expected_coverage", "subsample_coverage"]


def expected_coverage(confidence: float, n_sub: int, n_full: int) -> float:
    """Coverage of an exact interval of level ``confidence`` against the value of the full grid that
    contains the subsample (see the module docstring)."""
    z = stats.norm.ppf((1 + confidence) / 2)
    return float(2 * stats.norm.cdf(z / np.sqrt(1 - n_sub / n_full)) - 1)


def _subset(data: ResultsData, rows, n_sub: int) -> ResultsData:
    """The rows kept, as a complete grid of ``n_sub`` runs per cell: its ``samples`` attribute says so
    (the file's would ask for the full grid's rows, and the subset would be refused as incomplete)."""
    s = {k: np.asarray(v)[rows] for k, v in data.samples.items()}
    attrs = dict(data.attrs)
    if "samples" in attrs:
        attrs["samples"] = n_sub
    return ResultsData(s, None, None, None, attrs, len(rows), 0, {}, f"{data.path} (subsample)")


def subsample_coverage(site, results, *, n_sub=20, reps=300, seed=2026, **risk_kw):
    """Coverage of the risk's intervals of every level when each cell keeps ``n_sub`` of its runs.

    ``results``: a path or ResultsData of one branch (the risk is computed pulse-only unless
    ``risk_kw`` says otherwise); ``risk_kw`` go to :func:`pycolfrag.risk.site_risk.site_risk`
    (estimator, uncertainty, n_draws, ...). Returns ({level: share of repetitions whose interval
    holds the full grid's value}, {level: share with that value above the interval}, {level: median
    width of the interval}, {level: the full grid's value}).
    """
    from pycolfrag.risk.site_risk import site_risk
    data = as_data(results)
    kw = dict(pulse_only=True, curves=False)
    kw.update(risk_kw)
    truth = {k: v[0] for k, v in site_risk(site, data, **kw).rate.items()}
    cells = {}
    for i, key in enumerate(zip(np.asarray(data["mw"]), np.asarray(data["dist_km"]))):
        cells.setdefault(key, []).append(i)
    if min(len(v) for v in cells.values()) <= n_sub:
        raise ValueError(f"every cell needs more than n_sub = {n_sub} runs to be subsampled")
    rng = np.random.default_rng(seed)
    inside, above, widths = ({k: [] for k in truth} for _ in range(3))
    for rep in range(reps):
        rows = np.concatenate([rng.choice(v, n_sub, replace=False) for v in cells.values()])
        for k, (_lam, lo, hi) in site_risk(site, _subset(data, rows, n_sub), rng=rep, **kw).rate.items():
            inside[k].append(lo <= truth[k] <= hi)
            above[k].append(truth[k] > hi)
            widths[k].append(hi - lo)
    mean = lambda d: {k: float(np.mean(v)) for k, v in d.items()}   # noqa: E731
    return mean(inside), mean(above), {k: float(np.median(v)) for k, v in widths.items()}, truth
