"""Fragility models fitted to a pycolfrag results file (the export's limit states, range and rules)."""
from __future__ import annotations

import math
import re

import numpy as np

from ...errors import ParameterError
from .. import fragility as _frag
from ..data import read_table
from ..fragility import U_TOP_LEVELS
from .functions import ContinuousFragility, DiscreteFragility, FragilityModel
from .hazard import imt_of


def _ls_name(level) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", level.name.strip()).strip("_").lower()


#: Largest excess of a limit state's probability over the previous one's tolerated in an export (a
#: damage-state probability of -1e-6 at worst: below what any report prints).
CROSSING_TOL = 1e-6


def fragility_from_results(results, im: str = "pga_g", *, period_s: float | None = None, levels=None,
                           collapse: bool = True, fmt: str = "continuous", imls=None, n_imls: int = 20,
                           iml_range=None, no_damage_limit: float | None = None, taxonomy: str = "column",
                           model_id: str = "pycolfrag", description: str | None = None) -> FragilityModel:
    """IM-based fragility of a results file as an OpenQuake fragility model.

    Every limit state is pycolfrag's binomial maximum-likelihood lognormal fit
    (:func:`pycolfrag.analysis.fragility.fit_lognormal_fragility`) over the successful rows: exceedance of a
    performance level (a collapse counts as exceeding), and collapse itself last when ``collapse``.

    Parameters
    ----------
    results : path, :class:`~pycolfrag.analysis.data.Results` or a suite table (dict)
    im : ``pga_g``, ``pgv_cm_s`` or ``sa_g`` (with ``period_s``)
    levels : performance levels in increasing severity (default: Table III, ``U_TOP_LEVELS``)
    fmt : ``continuous`` (``mean``/``stddev`` of the IML, :meth:`ContinuousFragility.from_lognormal`)
        or ``discrete`` (the fitted curves at ``imls``, default ``n_imls`` levels log-spaced over
        ``iml_range``)
    iml_range : (lo, hi) -- ``minIML``/``maxIML`` of a continuous model, range of a discrete one;
        default the range of the IM over the rows the curves were fitted to (beyond it OpenQuake holds the
        curve constant)
    no_damage_limit : IML below which OpenQuake sets every probability to 0 (default none)

    The fitted curves must not cross within the exported IML range (each limit state at most as
    probable as the one before it), else ParameterError naming the two: OpenQuake would turn such
    curves into negative damage-state probabilities.
    """
    if fmt not in ("continuous", "discrete"):
        raise ParameterError(f"fmt must be 'continuous' or 'discrete', got {fmt!r}")
    levels = tuple(U_TOP_LEVELS if levels is None else levels)
    table = read_table(results)
    x, label = _frag.table_im(table, im, period_s)
    imt = imt_of(im, period_s)
    ok = _frag.ok_rows(table) & np.isfinite(x) & (x > 0)
    x = x[ok]
    coll = np.asarray(table["collapsed"])[ok].astype(bool)
    fits, names = [], []
    for lev in levels:
        edp = np.asarray(table[lev.edp], dtype=float)[ok]
        try:
            fits.append(_frag.fit_lognormal_fragility(x, edp, coll, lev.threshold))
        except ParameterError as exc:
            raise ParameterError(f"limit state {lev.label} on {label}: {exc}") from None
        names.append(_ls_name(lev))
    if collapse:
        try:
            fits.append(_frag.fit_lognormal_fragility(x, np.zeros(x.size), coll, 1.0))
        except ParameterError as exc:
            raise ParameterError(f"limit state collapse on {label}: {exc}") from None
        names.append("collapse")
    lo, hi = (float(x.min()), float(x.max())) if iml_range is None else (float(iml_range[0]), float(iml_range[1]))
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ParameterError(f"iml_range must be 0 < lo < hi, got {(lo, hi)}")
    check = np.geomspace(lo, hi, 200)
    for (a, fa), (b, fb) in zip(zip(names, fits), zip(names[1:], fits[1:])):
        worse = np.asarray(fb(check)) - np.asarray(fa(check))
        if worse.max() > CROSSING_TOL:
            at = check[int(np.argmax(worse))]
            raise ParameterError(f"limit states cross on {label}: P({b}) exceeds P({a}) by {worse.max():.3g} at "
                                 f"{at:.4g} (within the exported range {lo:.4g}-{hi:.4g}); OpenQuake would give a "
                                 "negative damage-state probability there. Leave a limit state out (levels=..., "
                                 "collapse=False; --no-collapse) or narrow iml_range")
    if fmt == "continuous":
        funcs = [ContinuousFragility.from_lognormal(f.median, f.beta, lo, hi, no_damage_limit) for f in fits]
    else:
        grid = np.geomspace(lo, hi, int(n_imls)) if imls is None else np.asarray(imls, dtype=float)
        funcs = [DiscreteFragility(tuple(grid), tuple(np.asarray(f(grid), dtype=float)), no_damage_limit)
                 for f in fits]
    desc = description or (f"pycolfrag IM-based fragility on {label}: binomial MLE lognormal fits over "
                           f"{x.size} runs")
    return FragilityModel(imt, tuple(names), funcs, taxonomy=taxonomy, model_id=model_id, description=desc,
                          fits=fits)

