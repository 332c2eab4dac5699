"""How a site risk carries the Monte Carlo error of the grid's cells to its rates: a registry of methods.

A method draws every cell's probability (``draw``: :func:`~pycolfrag.risk.cells.bootstrap_draws`
or :func:`~pycolfrag.risk.cells.beta_draws`), the draws are summed with the rate weights into
draws of lambda, and its ``interval`` turns them into a two-sided interval. A new method is one
:func:`uncertainty_method` line below (``--uncertainty`` offers every registered name).

* ``gamma`` (default): the gamma interval of Fay & Feuer (1997, Statistics in Medicine 16, 791-801)
  for a weighted sum of counts, built for directly standardised rates -- the same sum of many cells
  with few events each. The gamma distribution has lambda's estimate as mean and the variance of
  lambda's draws (the paired bootstrap); the upper limit adds one more event in the cell where it
  would weigh most, ``w_M`` = the largest rate weight over runs, ``max_ij sum_b W_ij / n_ij``, over
  the cells whose estimate is a count. That term is what keeps a cell where nothing happened in 20
  runs from being read as "never": 0 of 20 is also what a 5 % chance per run gives a third of the
  time. With equal weights the interval is the exact Poisson (Garwood) interval of the total count;
  for binomial counts the Poisson variance is an upper bound, so the interval errs on the wide side.
  Measured on the default grid by subsampling (docs/risk.md): it covers the 100-run value in
  0.95-1.00 of 300 repetitions at 20 runs per cell for every level with the empirical estimator.
* ``bootstrap``: the 5-95 % percentiles of the bootstrap draws (the default before; it under-covers
  at 20 runs per cell: 0.68-0.85 for Eq. (4)'s u_d levels and for collapse, always with the truth
  above, and gives [0, 0] where nothing happened).
* ``beta``: the percentiles of Jeffreys-posterior draws of the counts (Bayesian; above the plug-in
  estimate where most cells have 0 of n).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import stats

from pycolfrag.core.errors import ParameterError
from pycolfrag.risk.cells import beta_draws, bootstrap_draws

__all__ = ["UncertaintyMethod", "UNCERTAINTY_METHODS", "DEFAULT_UNCERTAINTY", "uncertainty_method",
           "percentile_interval", "gamma_interval", "method_of"]


@dataclass(frozen=True)
class UncertaintyMethod:
    """A way to an interval of lambda: its name (``--uncertainty``), one line saying what it is,
    the draw of a cell (``draw(cell, threshold, n_draws, rng)``) and the interval of lambda
    (``interval(estimate, draws, w_max, confidence) -> (low, high)``; ``w_max``: the weight of one more
    event in the heaviest count-estimated cell, 0 when no cell is a count)."""

    name: str
    description: str
    draw: Callable
    interval: Callable


#: Every uncertainty method, by name.
UNCERTAINTY_METHODS: dict = {}
#: The method a site risk uses unless asked otherwise.
DEFAULT_UNCERTAINTY = "gamma"


def uncertainty_method(name: str, description: str, draw: Callable, interval: Callable) -> UncertaintyMethod:
    """Register a method under ``name``."""
    if name in UNCERTAINTY_METHODS:
        raise ValueError(f"uncertainty method {name!r} is registered twice")
    UNCERTAINTY_METHODS[name] = UncertaintyMethod(name, description, draw, interval)
    return UNCERTAINTY_METHODS[name]


def method_of(name) -> UncertaintyMethod:
    """The registered method ``name``, or ParameterError naming the choices."""
    try:
        return UNCERTAINTY_METHODS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"uncertainty must be one of {', '.join(map(repr, UNCERTAINTY_METHODS))}, "
                             f"got {name!r}") from None


def percentile_interval(estimate, draws, w_max, confidence):
    """The (1 - confidence)/2 and (1 + confidence)/2 percentiles of the draws."""
    a = 100 * (1 - confidence) / 2
    lo, hi = np.percentile(draws, [a, 100 - a])
    return float(lo), float(hi)


def gamma_interval(estimate, draws, w_max, confidence):
    """Fay & Feuer's (1997) gamma interval: lower limit the alpha/2 quantile of the gamma with mean y and
    variance v, upper limit the 1 - alpha/2 quantile of the gamma with mean y + w_M and variance
    v + w_M^2 (y: the estimate; v: the variance of the draws; w_M: ``w_max``)."""
    a = (1 - confidence) / 2
    y, v, wm = float(estimate), float(np.var(draws, ddof=1)), float(w_max)
    lo = stats.gamma.ppf(a, y * y / v, scale=v / y) if y > 0 and v > 0 else 0.0
    if y + wm <= 0:
        return float(lo), 0.0
    if v + wm * wm <= 0:                           # nothing varies and nothing is a count: the estimate
        return float(lo), y
    hi = stats.gamma.ppf(1 - a, (y + wm) ** 2 / (v + wm * wm), scale=(v + wm * wm) / (y + wm))
    return float(min(lo, y)), float(max(hi, y))


uncertainty_method("gamma", "gamma interval of a weighted sum of counts (Fay & Feuer 1997): mean the estimate, "
                   "variance from the paired bootstrap, one more event in the heaviest count cell for the upper "
                   "limit", bootstrap_draws, gamma_interval)
uncertainty_method("bootstrap", "percentile bootstrap over each cell's runs (under-covers at 20 runs per cell)",
                   bootstrap_draws, percentile_interval)
uncertainty_method("beta", "Jeffreys beta posterior of k of n for the counts (Dirichlet of the paired "
                   "outcomes for two branches), the bootstrap for Eq. (4) cells; percentiles",
                   beta_draws, percentile_interval)
