"""Fragility models fitted to a pycolfrag results file: the export's limit states, its default IML range,
its rule for crossing fits, and its refusals (degenerate fits, an incomplete file).

Four rules, each stated in the model's description (the NRML file's ``description``):

* **Fits.** Every limit state is the binomial maximum-likelihood lognormal fit
  (:func:`~pycolfrag.analysis.fragility.fit_lognormal_fragility`) over the successful rows: exceedance
  of a performance level (a collapse counts as exceeding it), then collapse itself.
* **Range.** OpenQuake holds a continuous function at its value at ``minIML`` for every weaker motion
  and at ``maxIML`` for every stronger one. The default range is therefore where the fits themselves
  reach the ends: ``minIML`` where every limit state's fitted probability is at most
  :data:`RANGE_FLOOR_POE` (the floor then adds at most 1e-8 times the rate of the weakest hazard level:
  1e-7 /yr for a level exceeded ten times a year, beside damage rates of 1e-5 /yr and more -- where the
  data's lowest PGA as a floor gave 23 % of a damage-limitation rate), ``maxIML``
  where every one is at least :data:`RANGE_CEILING_POE` (stronger motions are rare: holding 0.999 loses
  at most 0.1 % of their rate), both widened to the data's range and kept within
  :data:`RANGE_FACTOR_LIMIT` of it.
* **Crossing fits.** Separate fits of nested limit states can cross (two lognormal curves of different
  dispersions do, somewhere); where a more severe state is the more probable one, the damage state
  between them gets a negative probability. Limit states whose fits cross within the exported range by
  more than :data:`~pycolfrag.analysis.openquake.CROSSING_TOL` are refitted together with one common
  dispersion (:func:`~pycolfrag.analysis.fragility.fit_ordered_fragility`), which cannot cross; the
  others keep their own fits. On the default grid this joins near collapse and collapse (44 and 43
  exceedances of 3500 runs: one run exceeded u_top > 1 without collapsing).
* **Refusals.** A degenerate fit (``LognormalFragility.degenerate``: too few runs, separable outcomes,
  a parameter on the optimiser's bound, one IM level) is not an estimate, and OpenQuake would take it
  as one: refused unless ``allow_degenerate``, then marked in the description. An incomplete results
  file is refused unless ``allow_incomplete`` (:mod:`pycolfrag.analysis.completeness`), then marked.
"""
from __future__ import annotations

import math
import re

import numpy as np
from scipy import stats

from pycolfrag.analysis import fragility as _frag
from pycolfrag.analysis.completeness import check_complete
from pycolfrag.analysis.data import read_table
from pycolfrag.analysis.fragility import U_TOP_LEVELS
from pycolfrag.analysis.fragility.degenerate import one_warning_per_cause
from pycolfrag.analysis.openquake.functions import CROSSING_TOL, ContinuousFragility, DiscreteFragility, FragilityModel
from pycolfrag.analysis.openquake.hazard import imt_of
from pycolfrag.core.errors import ParameterError

#: The word that marks a degenerate fit in the description and the printout (read back by ``read_nrml``).
DEGENERATE_MARK = "DEGENERATE"

#: Largest fitted probability of any limit state at the default ``minIML``.
RANGE_FLOOR_POE = 1e-8
#: Smallest fitted probability of any limit state at the default ``maxIML``.
RANGE_CEILING_POE = 0.999
#: The default range reaches at most this factor below the data's smallest IM and above its largest (a
#: fit with beta on its bound of 5, exported with ``allow_degenerate``, would otherwise span 1e-20 to 1e20).
RANGE_FACTOR_LIMIT = 1e3


#: What OpenQuake's engine gave with ``steps_per_interval`` > 1 on the default grid's continuous export
#: (range 0.0104-18.5 g, the engine run on it by hand), quoted in the export's warning and in docs/risk.md.
ENGINE_STEPS_NOTE = ("on the default grid's export (0.0104-18.5 g) the engine's collapse rate went up x 406 with 20 "
                     "levels, x 57 with 40 and x 2.8 with 100, P(no damage in 50 years) 0.9935 -> 0.816")


def steps_per_interval_warning(model: FragilityModel) -> str | None:
    """The warning a continuous export carries: OpenQuake's ``steps_per_interval`` > 1 evaluates it at
    ``continuous_fragility_discretization`` levels spaced linearly over the whole range (docs/risk.md); None
    for a discrete model (its log-spaced IMLs are cut into steps each, fine where the function changes)."""
    if model.format != "continuous":
        return None
    lo, hi = model.domain
    width = min(f.median * f.beta for f in model.functions)
    return (f"continuous functions over {lo:.4g}-{hi:.4g}: with steps_per_interval > 1 OpenQuake evaluates them at "
            f"continuous_fragility_discretization levels spaced linearly over that range, every {(hi - lo) / 19:.3g} "
            f"with its default 20 levels, against a narrowest fit of median x beta {width:.3g}: {ENGINE_STEPS_NOTE}. "
            "Keep steps_per_interval = 1 (the hazard's own levels), or export --format discrete; `damage "
            "--steps-per-interval S` on your hazard says how many levels it needs (docs/risk.md)")


def _ls_name(level) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", level.name.strip()).strip("_").lower()


def _outcomes(table, im, period_s, levels, collapse):
    """(IM of the successful rows with a positive IM, its label, [(name, exceeded, fit)] per limit state)."""
    x, label = _frag.table_im(table, im, period_s)
    ok = _frag.ok_rows(table) & np.isfinite(x) & (x > 0)
    x = x[ok]
    coll = np.asarray(table["collapsed"])[ok].astype(bool)
    states = []
    for lev in levels:
        edp = np.asarray(table[lev.edp], dtype=float)[ok]
        try:
            fit = _frag.fit_lognormal_fragility(x, edp, coll, lev.threshold)
        except ParameterError as exc:
            raise ParameterError(f"limit state {lev.label} on {label}: {exc}") from None
        states.append((_ls_name(lev), _frag.exceeded(edp, coll, lev.threshold), fit))
    if collapse:
        try:
            fit = _frag.fit_lognormal_fragility(x, np.zeros(x.size), coll, 1.0)
        except ParameterError as exc:
            raise ParameterError(f"limit state collapse on {label}: {exc}") from None
        states.append(("collapse", coll, fit))
    return x, label, states


def _default_range(fits, x) -> tuple[float, float]:
    """``(minIML, maxIML)`` by the range rule of the module docstring."""
    z_lo, z_hi = stats.norm.isf(RANGE_FLOOR_POE), stats.norm.ppf(RANGE_CEILING_POE)
    lo = min(min(f.median * math.exp(-z_lo * f.beta) for f in fits), float(x.min()))
    hi = max(max(f.median * math.exp(z_hi * f.beta) for f in fits), float(x.max()))
    return max(lo, float(x.min()) / RANGE_FACTOR_LIMIT), min(hi, float(x.max()) * RANGE_FACTOR_LIMIT)


def _first_crossing(fits, lo, hi):
    """(k, excess, at) of the first pair k, k+1 whose fits cross in [lo, hi] by more than CROSSING_TOL, or None."""
    check = np.geomspace(lo, hi, 400)
    for k in range(len(fits) - 1):
        worse = np.asarray(fits[k + 1](check)) - np.asarray(fits[k](check))
        if worse.max() > CROSSING_TOL:
            return k, float(worse.max()), float(check[int(np.argmax(worse))])
    return None


def _uncrossed(x, states, iml_range, label):
    """The fits with the crossing rule applied, the range, and the groups fitted together (names)."""
    names = [s[0] for s in states]
    fits = [s[2] for s in states]
    groups = [[k] for k in range(len(states))]
    while True:
        lo, hi = _default_range(fits, x) if iml_range is None else iml_range
        crossing = _first_crossing(fits, lo, hi)
        if crossing is None:
            return fits, (lo, hi), [tuple(names[k] for k in g) for g in groups if len(g) > 1]
        k, excess, at = crossing
        ga = next(g for g in groups if k in g)
        gb = next(g for g in groups if k + 1 in g)
        merged = sorted(ga + gb)
        groups = [g for g in groups if g is not ga and g is not gb] + [merged]
        start = ([fits[j].median for j in merged], math.exp(np.mean([math.log(fits[j].beta) for j in merged])))
        try:
            joint = _frag.fit_ordered_fragility(x, np.array([states[j][1] for j in merged]), x0=start)
        except ParameterError as exc:
            raise ParameterError(f"limit states cross on {label}: P({names[k + 1]}) exceeds P({names[k]}) by "
                                 f"{excess:.3g} at {at:.4g}, and they cannot be fitted together ({exc})") from None
        for j, fit in zip(merged, joint):
            fits[j] = fit


def _checked_range(iml_range):
    if iml_range is None:
        return None
    lo, hi = float(iml_range[0]), float(iml_range[1])
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ParameterError(f"iml_range must be 0 < lo < hi, got {(lo, hi)}")
    return lo, hi


def _refuse_degenerate(names, fits, label, allow: bool) -> list:
    """The ``(limit state, reason)`` of the degenerate fits; ParameterError unless ``allow``."""
    bad = [(n, f.degenerate) for n, f in zip(names, fits) if f.degenerate]
    if bad and not allow:
        raise ParameterError(f"degenerate fit(s) on {label}, which are not estimates and which OpenQuake would take "
                             "as such: " + "; ".join(f"{n}: {why}" for n, why in bad)
                             + ". Leave the limit state out (--levels, --no-collapse), use a grid with more runs, or "
                             "pass --allow-degenerate (allow_degenerate=True) to write them marked DEGENERATE")
    return bad


def _description(label, n, rng, given_range, joint, bad, note, fits) -> str:
    lo, hi = rng
    text = [f"pycolfrag IM-based fragility on {label}: binomial maximum-likelihood lognormal fits over {n} runs."]
    if given_range:
        text.append(f"minIML {lo:.4g} and maxIML {hi:.4g} were given; there the limit states' fitted probabilities "
                    f"are {', '.join(f'{f(lo):.3g}' for f in fits)} and {', '.join(f'{f(hi):.3g}' for f in fits)}, "
                    "which OpenQuake holds for every weaker and stronger motion.")
    else:
        p_lo, p_hi = max(float(f(lo)) for f in fits), min(float(f(hi)) for f in fits)
        limited = p_lo > RANGE_FLOOR_POE * (1 + 1e-9) or p_hi < RANGE_CEILING_POE * (1 - 1e-12)
        text.append(f"minIML {lo:.4g} and maxIML {hi:.4g} are where every limit state's fitted probability is at most "
                    f"{RANGE_FLOOR_POE:g} and at least {RANGE_CEILING_POE:g}"
                    + (f" as far as {RANGE_FACTOR_LIMIT:g} times beyond the data's IM range allows (here at most "
                       f"{p_lo:.3g} and at least {p_hi:.4g})" if limited else "")
                    + " (OpenQuake holds each curve at its value there for weaker and stronger motions), so the fits, "
                    "not those limits, decide the damage rates.")
    for g in joint:
        text.append(f"Limit states {', '.join(g)} crossed when fitted separately and are fitted together with one "
                    "common dispersion (cumulative probit), which cannot cross.")
    for name, why in bad:
        text.append(f"{DEGENERATE_MARK} fit of {name} (not an estimate): {why}.")
    if note:
        text.append(note + ".")
    return " ".join(text)


def fragility_from_results(results, im: str = "pga_g", *, period_s: float | None = None, levels=None,
                           collapse: bool = True, fmt: str = "continuous", imls=None, n_imls: int = 20,
                           iml_range=None, no_damage_limit: float | None = None, taxonomy: str = "column",
                           model_id: str = "pycolfrag", description: str | None = None,
                           allow_degenerate: bool = False, allow_incomplete: bool = False) -> FragilityModel:
    """IM-based fragility of a results file as an OpenQuake fragility model (rules: module docstring).

    Parameters
    ----------
    results : path, :class:`~pycolfrag.analysis.data.Results` or a suite table (dict)
    im : ``pga_g``, ``pgv_cm_s`` or ``sa_g`` (with ``period_s``)
    levels : performance levels in increasing severity (default: Table III, ``U_TOP_LEVELS``)
    collapse : add collapse as the last limit state
    fmt : ``continuous`` (``mean``/``stddev`` of the IML, :meth:`ContinuousFragility.from_lognormal`)
        or ``discrete`` (the fitted curves at ``imls``, default ``n_imls`` levels log-spaced over the range)
    iml_range : (lo, hi) -- ``minIML``/``maxIML`` of a continuous model, range of a discrete one; default
        by the range rule
    no_damage_limit : IML below which OpenQuake sets every probability to 0 (default none)
    description : the model's description (default: the rules as applied, see the module docstring)
    allow_degenerate, allow_incomplete : write degenerate fits, or fits of an incomplete file, marked
        instead of refusing them
    """
    if fmt not in ("continuous", "discrete"):
        raise ParameterError(f"fmt must be 'continuous' or 'discrete', got {fmt!r}")
    levels = tuple(U_TOP_LEVELS if levels is None else levels)
    given_range = _checked_range(iml_range)
    table = read_table(results)
    note = check_complete(table, allow_incomplete, "an OpenQuake fragility export",
                          path=None if isinstance(results, dict) or hasattr(results, "attrs") else results)
    with one_warning_per_cause("limit-state fit(s)"):
        x, label, states = _outcomes(table, im, period_s, levels, collapse)
        fits, (lo, hi), joint = _uncrossed(x, states, given_range, label)
    names = tuple(s[0] for s in states)
    bad = _refuse_degenerate(names, fits, label, allow_degenerate)
    if fmt == "continuous":
        funcs = [ContinuousFragility.from_lognormal(f.median, f.beta, lo, hi, no_damage_limit) for f in fits]
    else:
        grid = np.geomspace(lo, hi, int(n_imls)) if imls is None else np.asarray(imls, dtype=float)
        funcs = [DiscreteFragility(tuple(grid), tuple(np.asarray(f(grid), dtype=float)), no_damage_limit)
                 for f in fits]
    desc = description or _description(label, x.size, (lo, hi), given_range is not None, joint, bad, note, fits)
    return FragilityModel(imt_of(im, period_s), names, funcs, taxonomy=taxonomy, model_id=model_id,
                          description=desc, fits=fits, joint=tuple(joint), notes=tuple(
                              [f"{DEGENERATE_MARK} fit of {n} (not an estimate): {why}" for n, why in bad]
                              + ([note] if note else [])))
