"""The grid cells of a site risk: their rows, their probability estimates and draws of them.

A cell is one (Mw, R) scenario of the grid, in every branch (the pulse grid, and the no-pulse grid
made from the same seeds). Its probability of exceeding a level is estimated one of two ways
(``kind``): ``"count"`` -- the share of runs that exceeded (collapse, Eq. (3), always; every level
under the empirical estimator, or where Eq. (4) failed its fit test) -- or ``"eq4"``, the paper's
Eq. (4). The draws of a cell's probability that carry the Monte Carlo error to lambda are made
here: the bootstrap over the cell's runs, the pulse and no-pulse rows paired by sample number and
resampled together (their shared seeds correlate them), or the Jeffreys beta posterior of a count.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.core.errors import ResultsFileError

__all__ = ["BranchCell", "grid_cells", "point", "bootstrap_draws", "beta_draws", "surface_draws"]


@dataclass
class BranchCell:
    """The rows of one cell in one branch, for one level.

    ``edp``: the level's EDP of the rows (None for collapse); ``collapsed``: bool per row;
    ``sample``: sample numbers (None when the file has none); ``kind``: ``"count"`` or ``"eq4"``.
    """

    edp: np.ndarray | None
    collapsed: np.ndarray
    sample: np.ndarray | None
    kind: str

    @property
    def n(self) -> int:
        return int(np.size(self.collapsed))

    def outcomes(self, threshold) -> np.ndarray:
        """Whether each run exceeded: collapsed, or EDP >= threshold (Eq. (1))."""
        return self.collapsed if threshold is None else fr.exceeded(self.edp, self.collapsed, threshold)


def grid_cells(data):
    """Grid nodes and the row indices of each (Mw, R) cell of a results file; every cell must have runs."""
    mw = np.asarray(data["mw"], dtype=float)
    dist = np.asarray(data["dist_km"], dtype=float)
    mws, ds = np.unique(mw), np.unique(dist)
    rows = {}
    for i, m in enumerate(mws):
        for j, r in enumerate(ds):
            idx = np.flatnonzero((mw == m) & (dist == r))
            if idx.size == 0:
                raise ResultsFileError(f"{data.path}: no successful run at Mw {m:g}, R {r:g} km; the surface "
                                       "cannot be interpolated over a hole (run the missing scenarios)")
            rows[i, j] = idx
    return mws, ds, rows


def point(bc: BranchCell, threshold) -> float:
    """The cell's estimate: the share of runs that exceeded, or Eq. (4) (its degeneracy warnings are
    the caller's: they are gathered once per cause, :mod:`pycolfrag.risk.fit`)."""
    if bc.kind == "count" or threshold is None:
        return float(np.mean(bc.outcomes(threshold)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fr.DegenerateFitWarning)
        return fr.exceedance(bc.edp, bc.collapsed, threshold)


def _statistic(bc: BranchCell, threshold):
    """The estimate of every row of an index array (resamples x runs) at once."""
    if bc.kind == "count" or threshold is None:
        x = bc.outcomes(threshold)
        return lambda idx: np.mean(x[idx], axis=-1)
    e = np.nan_to_num(np.asarray(bc.edp, dtype=float), nan=0.0)
    c = np.asarray(bc.collapsed, dtype=bool)
    stat = fr.eq4_statistic(threshold)
    return lambda idx: stat(e[idx], c[idx], axis=-1)


def _pairs(ids, n):
    """Rows of one cell in every branch, split into the rows paired across the branches and the rest.

    ``ids`` maps a branch to the sample numbers of its rows in the cell (None: the file has no sample
    numbers), ``n`` to its number of rows. The branches of a site are the same grid run with and
    without pulses from the same seeds, so row ``k`` of a cell in one branch and row ``k`` in the
    other share their random stream: they are paired. Returns {branch: (positions of the paired
    rows, in a common order; positions of the others)}; one branch: all its rows count as paired.
    """
    branches = list(ids)
    if len(branches) == 1:
        return {branches[0]: (np.arange(n[branches[0]]), np.zeros(0, dtype=int))}
    if any(ids[b] is None for b in branches):         # nothing to pair them by (reported as unpaired)
        return {b: (np.zeros(0, dtype=int), np.arange(n[b])) for b in branches}
    common = ids[branches[0]]
    for b in branches[1:]:
        common = np.intersect1d(common, ids[b])
    out = {}
    for b in branches:
        _, pos, _ = np.intersect1d(ids[b], common, return_indices=True)   # sorted by sample number
        out[b] = (pos, np.setdiff1d(np.arange(n[b]), pos))
    return out


def bootstrap_draws(cell: dict, threshold, n_draws: int, rng):
    """``n_draws`` bootstrap draws of the cell's estimate in every branch: the runs resampled with
    replacement, the paired rows of the branches (:func:`_pairs`) resampled together, so that the
    branches' draws keep the correlation their shared seeds give them; rows without a partner are
    resampled within their branch. Returns ({branch: draws}, whether the draws are paired)."""
    pairs = _pairs({b: bc.sample for b, bc in cell.items()}, {b: bc.n for b, bc in cell.items()})
    paired = all(pos.size > 0 for pos, _ in pairs.values())
    n_common = next(iter(pairs.values()))[0].size
    shared = rng.integers(0, n_common, size=(n_draws, n_common)) if n_common else None
    out = {}
    for b, bc in cell.items():
        pos, rest = pairs[b]
        parts = [pos[shared]] if n_common else []
        if rest.size:
            parts.append(rest[rng.integers(0, rest.size, size=(n_draws, rest.size))])
        out[b] = _statistic(bc, threshold)(np.concatenate(parts, axis=1))
    return out, len(cell) == 1 or paired


def beta_draws(cell: dict, threshold, n_draws: int, rng):
    """Draws of a cell's proportions from the Jeffreys posterior Beta(k + 1/2, n - k + 1/2) of each
    branch; for two fully paired branches the four joint outcomes of the pairs are drawn from
    Dirichlet(counts + 1/4) (Perks' prior), whose margins are exactly those Jeffreys posteriors and
    which keeps the branches' correlation. A cell where a branch uses Eq. (4) is bootstrapped
    (:func:`bootstrap_draws`): Eq. (4) is not a proportion."""
    if any(bc.kind != "count" and threshold is not None for bc in cell.values()):
        return bootstrap_draws(cell, threshold, n_draws, rng)
    pairs = _pairs({b: bc.sample for b, bc in cell.items()}, {b: bc.n for b, bc in cell.items()})
    x = {b: bc.outcomes(threshold) for b, bc in cell.items()}
    full = all(pos.size > 0 and rest.size == 0 for pos, rest in pairs.values())
    if len(cell) == 2 and full:
        (bp, (pp, _)), (bn, (pn, _)) = pairs.items()
        a, b_ = x[bp][pp], x[bn][pn]
        counts = [np.sum(a & b_), np.sum(a & ~b_), np.sum(~a & b_), np.sum(~a & ~b_)]
        d = rng.dirichlet(np.asarray(counts, dtype=float) + 0.25, size=n_draws)
        return {bp: d[:, 0] + d[:, 1], bn: d[:, 0] + d[:, 2]}, True
    out = {}
    for b, v in x.items():
        k, n = int(np.sum(v)), v.size
        out[b] = rng.beta(k + 0.5, n - k + 0.5, size=n_draws)
    return out, len(cell) == 1


def surface_draws(cells: dict, shape, threshold, draw, n_draws: int, rng):
    """Point surfaces and draws of every cell: ``cells`` maps (i, j) to {branch: BranchCell};
    ``draw`` is an uncertainty method's draw function. Returns ({branch: point (n_mw, n_dist)},
    {branch: draws (n_draws, n_mw, n_dist)}, number of cells drawn without pairing)."""
    branches = next(iter(cells.values())).keys()
    pts = {b: np.zeros(shape) for b in branches}
    draws = {b: np.zeros((n_draws,) + shape) for b in branches}
    unpaired = 0
    for ij, cell in cells.items():
        res, paired = draw(cell, threshold, n_draws, rng)
        unpaired += not paired
        for b, bc in cell.items():
            pts[b][ij] = point(bc, threshold)
            draws[b][(slice(None),) + ij] = res[b]
    return pts, draws, unpaired
