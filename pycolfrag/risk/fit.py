"""Checks of Eq. (4) in a site risk: does the lognormal fit of each cell predict its exceedances, and is
it an estimate at all?

**Goodness of fit.** Eq. (4) predicts n P expected exceedances of a level in a cell of n runs; the
runs show O. Under the fit, O is binomial (n, P), so the exact two-sided binomial test of O gives
each cell and level a p-value. A single cell of 20 runs has little power, and Eq. (4)'s misfits are
systematic in magnitude (on the default grid, u_d > 0.01 at Mw 5.5: 47.3 expected against 18
observed over the row's 700 runs, while no single cell is far off), so the cells of each magnitude
row are also tested together: their total O is a sum of independent binomials, whose exact
(Poisson-binomial) distribution gives the row's p-value. A cell fails when its own test or its
row's rejects at :data:`EQ4_FIT_ALPHA`; the statistics of every cell and row are in the outputs.
Where it fails, the risk falls back to the empirical ratio in that cell (``misfit="fallback"``, the
default under Eq. (4): the ratio is unbiased whatever the EDPs' distribution, at the cost of a wider
interval) or keeps Eq. (4) and marks it (``"warn"``). The p-values ignore that the lognormal's
two parameters were fitted to the same runs, which makes the test a little conservative.

**Degenerate fits.** :func:`pycolfrag.analysis.fragility.eq4_degenerate` says why a cell's Eq. (4)
is not an estimate (too few runs or standing runs, all EDPs equal); the reasons are gathered once
per cause for the whole risk -- one warning each, not one per cell, level and resample -- and
written into every output.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from pycolfrag.analysis import fragility as fr
from pycolfrag.risk.cells import point

__all__ = ["EQ4_FIT_ALPHA", "MISFIT_CHOICES", "two_sided_pvalue", "FitCheck", "check_eq4", "Degeneracy"]

#: Level of the fit tests: a cell whose own test or whose magnitude row's test has a p-value below it
#: fails. False alarms cost only variance (the empirical ratio is unbiased), so the level is the usual
#: 5 % rather than a stricter one.
EQ4_FIT_ALPHA = 0.05
#: What a cell that fails its test gets: the empirical ratio, or Eq. (4) with a mark.
MISFIT_CHOICES = ("fallback", "warn")


#: Binomial probabilities below this are taken as 0 in :func:`two_sided_pvalue`.
P_ZERO = 1e-300


def two_sided_pvalue(observed: int, ns, ps) -> float:
    """Exact two-sided p-value of a total count ``observed`` of independent binomials (n_k, p_k): the
    probability of every total no more likely than the one observed (the binomial test's rule,
    ``scipy.stats.binomtest``, for a single cell)."""
    pmf = np.ones(1)
    for n, p in zip(ns, ps):
        p = float(np.clip(p, 0.0, 1.0))
        # scipy's binomial pmf overflows for p near the smallest doubles (6e-309 raised OverflowError);
        # p < P_ZERO gives P(count >= 1) < n 1e-300, zero in any p-value, so such a p is taken as 0
        p = 0.0 if p < P_ZERO else p
        pmf = np.convolve(pmf, stats.binom.pmf(np.arange(int(n) + 1), int(n), p))
    if not 0 <= observed < pmf.size:
        return 0.0
    return float(min(1.0, np.sum(pmf[pmf <= pmf[observed] * (1 + 1e-7)])))


@dataclass
class FitCheck:
    """Eq. (4) against the counts for one level in one branch (arrays over the grid's cells)."""

    label: str
    branch: str
    expected: np.ndarray          # n P of Eq. (4)
    observed: np.ndarray          # runs that exceeded
    n: np.ndarray
    p_cell: np.ndarray            # exact binomial p-value of each cell
    p_row: np.ndarray             # exact Poisson-binomial p-value of each magnitude row
    failed: np.ndarray            # cell or row below EQ4_FIT_ALPHA

    def as_dict(self) -> dict:
        return {"branch": self.branch, "expected": self.expected.tolist(), "observed": self.observed.tolist(),
                "runs": self.n.tolist(), "p_cell": self.p_cell.tolist(), "p_row": self.p_row.tolist(),
                "failed": self.failed.tolist()}

    def worst_rows(self, mws) -> str:
        """The failed rows as text: ``Mw 5.5: 4.6 expected, 0 observed (p 0.01)``."""
        out = []
        for i in np.flatnonzero(self.p_row < EQ4_FIT_ALPHA):
            out.append(f"Mw {mws[i]:g}: {self.expected[i].sum():.1f} expected, {int(self.observed[i].sum())} "
                       f"observed (p {self.p_row[i]:.2g})")
        return "; ".join(out)


def check_eq4(cells: dict, shape, branch: str, threshold: float, label: str,
              alpha: float = EQ4_FIT_ALPHA) -> FitCheck:
    """The fit test of Eq. (4) of one level in one branch; ``cells`` maps (i, j) to the branch's
    :class:`~pycolfrag.risk.cells.BranchCell` (its ``kind`` is ignored: Eq. (4) is computed)."""
    E, O, N, pc = (np.zeros(shape) for _ in range(4))
    P = np.zeros(shape)
    for ij, bc in cells.items():
        p = point(type(bc)(bc.edp, bc.collapsed, bc.sample, "eq4"), threshold)
        o = int(np.sum(bc.outcomes(threshold)))
        P[ij], E[ij], O[ij], N[ij] = p, bc.n * p, o, bc.n
        pc[ij] = two_sided_pvalue(o, [bc.n], [p])
    pr = np.array([two_sided_pvalue(int(O[i].sum()), N[i], P[i]) for i in range(shape[0])])
    failed = (pc < alpha) | (pr[:, None] < alpha)
    return FitCheck(label, branch, E, O, N, pc, pr, failed)


@dataclass
class Degeneracy:
    """Why Eq. (4) is not an estimate in some cells: reason -> [(branch, edp, mw, r_km), ...]."""

    causes: dict = field(default_factory=dict)

    def add(self, reason: str, where: tuple) -> None:
        if reason and where not in self.causes.setdefault(reason, []):
            self.causes[reason].append(where)

    def check(self, cells: dict, branch: str, edp: str, mws, ds) -> None:
        """Record the reasons of every cell of one EDP in one branch."""
        for (i, j), bc in cells.items():
            self.add(fr.eq4_degenerate(bc.edp, bc.collapsed), (branch, edp, float(mws[i]), float(ds[j])))

    def warn(self) -> None:
        """One :class:`~pycolfrag.analysis.fragility.DegenerateFitWarning` per cause."""
        for reason, where in self.causes.items():
            warnings.warn(f"site risk: Eq. (4) is not an estimate in {len(where)} cell(s) and EDP(s) ({reason}), "
                          f"e.g. {where[0][0]} branch, {where[0][1]} at Mw {where[0][2]:g}, R {where[0][3]:g} km; "
                          "their levels are marked in the outputs", fr.DegenerateFitWarning, stacklevel=3)

    def lines(self) -> list:
        return [f"{reason}: {len(w)} cell(s) and EDP(s), e.g. {w[0][0]} branch, {w[0][1]} at Mw {w[0][2]:g}, "
                f"R {w[0][3]:g} km" for reason, w in self.causes.items()]

    def as_dict(self) -> dict:
        return {reason: [list(x) for x in w] for reason, w in self.causes.items()}
