"""Site risk: annual rates and T-year probabilities of the column's damage levels at a site.

The fragility of a results file, P(EDP > x | Mw, R) on the grid's scenarios, is combined with a
site's earthquake sources (``docs/risk.md``)::

    lambda(EDP > x) = sum_sources nu * int int P(EDP > x | m, r) f(m, r) dm dr
    P(in T years)   = 1 - exp(-lambda T)                        (Poisson occurrence)

for every level of Tables III and IV and for collapse. The site and its sources come from a site
file (:mod:`pycolfrag.site.sources`); f(m, r) is each source's joint density, given as weighted events by
the source itself. Every synthetic motion of a grid carries a velocity pulse, so a results file is
one branch; a no-pulse grid (the stochastic part alone, the same seeds) is the other, and the two
are mixed per event with the event's pulse-occurrence probability p::

    P(EDP > x | event) = p P_pulse(EDP > x | m, r) + (1 - p) P_nopulse(EDP > x | m, r)

A pulse-only answer is given only when it is asked for explicitly (``model = "pulse-only"`` or
``--pulse-only``) and every output says so.

The parts, one module each: the rate weights of the grid's scenarios and the interpolation
(:mod:`.weights`), the cells' estimates and draws (:mod:`.cells`), the interval methods
(:mod:`.uncertainty`, a registry), the checks of Eq. (4) (:mod:`.fit`), the checks of the
files (:mod:`.branches`), the report and files (:mod:`.report`).

The command line (``pycolfrag risk``) is :mod:`pycolfrag.risk.site_risk`, which also dispatches to the
logic tree (:mod:`.tree_grid`) and the simulation; this module computes, so that both import it and not
each other.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.codes import code_history
from pycolfrag.analysis.data import as_data
from pycolfrag.core import progress
from pycolfrag.core.errors import ParameterError
from pycolfrag.risk.branches import check_branches, check_complete, code_identity, declared_pulse, no_pulse_command
from pycolfrag.risk.cells import BranchCell, grid_cells, surface_draws
from pycolfrag.risk.fit import MISFIT_CHOICES, Degeneracy, check_eq4
from pycolfrag.risk.report import SiteRisk, report_section, write_outputs
from pycolfrag.risk.uncertainty import DEFAULT_UNCERTAINTY, method_of
from pycolfrag.risk.weights import interpolate, node_weights, pulse_share
from pycolfrag.site.models import PulseOnly, Table
from pycolfrag.site.sources import OUTSIDE_CHOICES, Site, load_site, read_pulse_model

__all__ = ["RiskQuantity", "QUANTITIES", "ESTIMATORS", "DEFAULT_ESTIMATOR", "MAX_DRAW_BYTES", "CURVE_X", "node_weights",
           "interpolate", "declared_pulse", "SiteRisk", "site_risk", "report_section", "write_outputs"]


@dataclass(frozen=True)
class RiskQuantity:
    """One exceedance event whose rate is computed: a performance level, or collapse."""

    label: str
    name: str
    level: fr.PerformanceLevel | None = None   # None: collapse

    @property
    def edp(self):
        return None if self.level is None else self.level.edp

    @property
    def threshold(self):
        return None if self.level is None else self.level.threshold


#: The six levels of Tables III and IV, then collapse (Eq. (3)).
QUANTITIES = tuple(RiskQuantity(lv.label, lv.name, lv) for lv in fr.PERFORMANCE_LEVELS) + (
    RiskQuantity("collapse", "Collapse"),)
#: A cell's probability of exceeding a level: the share of its runs that exceeded (Eq. (1) counted)
#: or the paper's Eq. (4). The default is the share: it is unbiased whatever the distribution of the
#: EDPs, and its intervals cover at 20 runs per cell (docs/risk.md); Eq. (4)'s lognormal misses the
#: u_d levels at low magnitudes on the default grid.
ESTIMATORS = ("empirical", "eq4")
DEFAULT_ESTIMATOR = "empirical"
#: The most memory the draws of one level may take (draws x cells x branches x 8 bytes).
MAX_DRAW_BYTES = 1 << 30
#: Horizon of the probabilities printed on the command line, years.
_PRINTED_YEARS = 50.0

CURVE_X = {"u_top": np.geomspace(0.05, 1.5, 25), "u_d": np.geomspace(0.001, 0.05, 25)}


@dataclass
class _Context:
    """What every level of a site risk shares: the site, the branches, their cells and weights."""

    site: Site
    branches: dict                  # branch -> ResultsData
    mws: np.ndarray
    ds: np.ndarray
    rows: dict                      # branch -> {(i, j): row indices}
    weights: dict                   # branch -> W (n_mw, n_dist)
    per_source: dict                # branch -> [W per source]
    estimator: str
    method: object
    misfit: str
    confidence: float
    rng: np.random.Generator
    degenerate: dict = field(default_factory=dict)   # (branch, edp) -> bool mask of degenerate Eq. (4)

    @property
    def shape(self):
        return (self.mws.size, self.ds.size)

    def branch_cells(self, b, edp, kind):
        d = self.branches[b]
        sample = np.asarray(d["sample"]) if "sample" in d.samples else None
        return {ij: BranchCell(None if edp is None else np.asarray(d[edp])[idx], np.asarray(d["collapsed"])[idx],
                               None if sample is None else sample[idx], kind[ij] if isinstance(kind, np.ndarray)
                               else kind) for ij, idx in self.rows[b].items()}


def _check_settings(estimator, uncertainty, misfit, confidence, n_draws, rng):
    if estimator not in ESTIMATORS:
        raise ParameterError(f"estimator must be one of {', '.join(map(repr, ESTIMATORS))}, got {estimator!r}")
    method = method_of(uncertainty)
    if misfit not in MISFIT_CHOICES:
        raise ParameterError(f"eq4_misfit must be one of {', '.join(map(repr, MISFIT_CHOICES))}, got {misfit!r}")
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0 < confidence < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    if isinstance(n_draws, bool) or not isinstance(n_draws, (int, np.integer)) or n_draws < 10:
        raise ParameterError(f"n_draws must be an integer >= 10, got {n_draws!r}")
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool) and rng < 0:
        raise ParameterError(f"the seed must be >= 0, got {rng!r}")
    return method, fr.as_rng(rng)


def _resolve_site(site, pulse_only, pulse_model, outside, years):
    if not isinstance(site, Site):
        site = load_site(site)
    if pulse_model is not None:
        if isinstance(pulse_model, str):
            pulse_model = _inline_table(pulse_model)
        model = read_pulse_model(Table(pulse_model, "--pulse-model", "pulse"))
        site = replace(site, sources=tuple(s.with_pulse(model) for s in site.sources))
    if pulse_only:
        site = replace(site, sources=tuple(s.with_pulse(PulseOnly()) for s in site.sources))
    if outside is not None:
        if outside not in OUTSIDE_CHOICES:
            raise ParameterError(f"outside must be one of {', '.join(OUTSIDE_CHOICES)}, got {outside!r}")
        site = replace(site, outside=outside)
    extra = [y for y in years]
    if any(isinstance(y, bool) or not isinstance(y, (int, float)) or not (math.isfinite(y) and y > 0)
           for y in extra):
        raise ParameterError(f"years must be positive numbers, got {list(years)!r}")
    return replace(site, years=tuple(sorted(set(site.years) | {float(y) for y in extra})))


def _inline_table(text: str) -> dict:
    try:
        return tomllib.loads(f"pulse = {text}")["pulse"]
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"--pulse-model must be a TOML inline table such as '{{model = \"probability\", "
                             f"probability = 0.2}}', got {text!r} ({exc})") from None


def _read_branches(site, pulse_results, no_pulse_results, allow_incomplete):
    pulse = as_data(pulse_results)
    no_pulse = None if no_pulse_results is None else as_data(no_pulse_results)
    need = [s.name for s in site.sources if s.pulse.needs_no_pulse_branch]
    if no_pulse is None and need:
        raise ParameterError(
            f"sources {', '.join(map(repr, need))} have p_pulse < 1 but only the pulse branch was given: "
            f"give the no-pulse results (--no-pulse H5): make them with {no_pulse_command(pulse)} ; "
            "or ask for the pulse branch alone explicitly (model = 'pulse-only' or --pulse-only; it overstates "
            "the risk)")
    if no_pulse is not None and not need:
        raise ParameterError("a no-pulse branch was given but every source is pulse-only (p_pulse = 1): "
                             "drop one of the two")
    check_branches(pulse, no_pulse)
    branches = {"pulse": pulse} if no_pulse is None else {"pulse": pulse, "no-pulse": no_pulse}
    return branches, check_complete(branches, allow_incomplete)


def _asked_grid(data, mws, ds):
    """The (Mw, R) nodes an incomplete file's run asked for (its ``mw`` and ``dist_km`` attributes), or None
    when it does not say or they do not hold the computed nodes."""
    m, r = data.attrs.get("mw"), data.attrs.get("dist_km")
    if m is None or r is None:
        return None
    am, ad = np.unique(np.asarray(m, dtype=float)), np.unique(np.asarray(r, dtype=float))
    if not (np.all(np.isin(mws, am)) and np.all(np.isin(ds, ad))):
        return None
    return am, ad


def _context(site, branches, estimator, method, misfit, confidence, g, n_draws, incomplete=()):
    grids = {b: grid_cells(data) for b, data in branches.items()}
    mws, ds, _ = grids["pulse"]
    for b, (m2, d2, _) in grids.items():
        if not (np.array_equal(m2, mws) and np.array_equal(d2, ds)):
            raise ParameterError(f"the {b} branch's grid (Mw {m2.tolist()}, R {d2.tolist()}) differs from the pulse "
                                 f"branch's (Mw {mws.tolist()}, R {ds.tolist()}); run both on the same scenarios")
    need = int(n_draws) * mws.size * ds.size * len(branches) * 8
    if need > MAX_DRAW_BYTES:
        raise ParameterError(f"n_draws = {n_draws} would take {need / 2**30:.1f} GiB of draws per level "
                             f"({mws.size * ds.size} cells x {len(branches)} branches x 8 bytes), more than the "
                             f"{MAX_DRAW_BYTES / 2**30:g} GiB allowed (the default is 2000)")
    weights, per_source = {}, {}
    reports = None
    asked = _asked_grid(branches["pulse"], mws, ds) if incomplete else None
    for b in branches:
        key = "all" if len(branches) == 1 else b
        weights[b], per_source[b], rep = node_weights(site.sources, mws, ds, outside=site.outside, branch=key,
                                                      asked=asked)
        reports = reports or rep
    if any(o.not_computed > 0 for o in reports) and not any(np.any(w > 0) for w in weights.values()):
        raise ParameterError(f"none of the site's rate falls on the scenarios computed so far (Mw {mws[0]:g}-"
                             f"{mws[-1]:g}, R {ds[0]:g}-{ds[-1]:g} km of the grid asked for, Mw {asked[0][0]:g}-"
                             f"{asked[0][-1]:g}, R {asked[1][0]:g}-{asked[1][-1]:g} km): every rate would be an "
                             "unknown reported as 0; finish the run (rerun its command to resume)")
    ctx = _Context(site, branches, mws, ds, {b: grids[b][2] for b in branches}, weights, per_source, estimator,
                   method, misfit, confidence, g)
    return ctx, reports


def _degeneracy(ctx) -> Degeneracy:
    """Why Eq. (4) is not an estimate, cell by cell, for every EDP and branch (used under Eq. (4) only)."""
    deg = Degeneracy()
    for b in ctx.branches:
        for edp in ("u_top", "u_d"):
            cells = ctx.branch_cells(b, edp, "eq4")
            deg.check(cells, b, edp, ctx.mws, ctx.ds)
            ctx.degenerate[b, edp] = np.zeros(ctx.shape, dtype=bool)
            for ij, bc in cells.items():
                ctx.degenerate[b, edp][ij] = bool(fr.eq4_degenerate(bc.edp, bc.collapsed))
    return deg


def _kinds(ctx, threshold, edp, label):
    """Each branch's estimate kind per cell ("count"/"eq4") and the fit checks of Eq. (4)."""
    fits, kinds = [], {}
    for b in ctx.branches:
        if threshold is None:
            kinds[b] = np.full(ctx.shape, "count", dtype=object)
            continue
        fit = check_eq4(ctx.branch_cells(b, edp, "eq4"), ctx.shape, b, threshold, label)
        fits.append(fit)
        k = np.full(ctx.shape, "count" if ctx.estimator == "empirical" else "eq4", dtype=object)
        if ctx.estimator == "eq4" and ctx.misfit == "fallback":
            k[fit.failed] = "count"
        kinds[b] = k
    return kinds, fits


def _rate(ctx, threshold, edp, label, n_draws):
    """Lambda of one level: estimate, interval, contributions, and what was checked on the way."""
    kinds, fits = _kinds(ctx, threshold, edp, label)
    per_b = {b: ctx.branch_cells(b, edp, kinds[b]) for b in ctx.branches}
    cells = {ij: {b: per_b[b][ij] for b in ctx.branches} for ij in ctx.rows["pulse"]}
    pts, draws, unpaired = surface_draws(cells, ctx.shape, threshold, ctx.method.draw, n_draws, ctx.rng)
    lam = sum(float(np.sum(ctx.weights[b] * pts[b])) for b in ctx.branches)
    lam_draws = sum(np.tensordot(draws[b], ctx.weights[b], axes=([1, 2], [0, 1])) for b in ctx.branches)
    w_max = 0.0
    for ij, cell in cells.items():
        w_max = max(w_max, sum(ctx.weights[b][ij] / bc.n for b, bc in cell.items() if bc.kind == "count"))
    lo, hi = ctx.method.interval(lam, lam_draws, w_max, ctx.confidence)
    info = {"fits": fits, "unpaired": unpaired, "w_max": w_max,
            "fallback": int(sum(np.sum((kinds[b] == "count") & (ctx.weights[b] > 0)) for b in ctx.branches))
            if threshold is not None and ctx.estimator == "eq4" else 0,
            "degenerate": int(sum(np.sum(ctx.degenerate.get((b, edp), np.zeros(ctx.shape, bool))
                                         & (kinds[b] == "eq4") & (ctx.weights[b] > 0)) for b in ctx.branches))}
    return lam, (lo, hi), pts, info


def site_risk(site, pulse_results, no_pulse_results=None, *, pulse_only=False, estimator=DEFAULT_ESTIMATOR,
              uncertainty=DEFAULT_UNCERTAINTY, eq4_misfit="fallback", pulse_model=None, outside=None, years=(),
              n_draws=2000, confidence=0.90, rng=0, curves=True, curve_draws=200, allow_incomplete=False) -> SiteRisk:
    """Annual rates and T-year probabilities of every Table III/IV level and of collapse at a site.

    Parameters
    ----------
    site : Site or path
        The site file (:func:`pycolfrag.site.sources.load_site`).
    pulse_results, no_pulse_results : path or ResultsData
        Results of the grid with pulses and of the same grid without (``run_grid.py --pulse none``);
        the second is required unless every source is pulse-only.
    pulse_only : bool
        Ask for the pulse branch alone (p_pulse = 1 for every source); the outputs say so.
    pulse_model : dict or str, optional
        A pulse-occurrence model for every source instead of the site file's, as a site file's
        ``[pulse]`` table (a dict, or its TOML inline-table text): another epistemic branch.
    estimator : {"empirical", "eq4"}
        A cell's probability: the share of its runs that exceeded, or the paper's Eq. (4).
    uncertainty : str
        A method of :data:`pycolfrag.risk.uncertainty.UNCERTAINTY_METHODS`.
    eq4_misfit : {"fallback", "warn"}
        Under Eq. (4), what a cell that fails the fit test gets (:mod:`pycolfrag.risk.fit`).
    outside : {"refuse", "clamp", "zero"}, optional
        Overrides the site file's choice.
    years : sequence of float
        Horizons besides 50, 100, 475 years and the site file's.
    n_draws, confidence, rng
        Draws of every cell's probability, two-sided level of the intervals, seed (>= 0) or Generator.
    curves, curve_draws : bool, int
        Also lambda(EDP > x) over a range of x per EDP (risk curves, fewer draws).
    allow_incomplete : bool
        Compute from a results file that lacks rows (refused otherwise); every output says so.
    """
    method, g = _check_settings(estimator, uncertainty, eq4_misfit, confidence, n_draws, rng)
    site = _resolve_site(site, pulse_only, pulse_model, outside, years)
    branches, incomplete = _read_branches(site, pulse_results, no_pulse_results, allow_incomplete)
    ctx, reports = _context(site, branches, estimator, method, eq4_misfit, confidence, g, n_draws, incomplete)
    deg = _degeneracy(ctx) if estimator == "eq4" else Degeneracy()
    deg.warn()
    rate, checks, deagg, source_rate = {}, {}, {}, {s.name: {} for s in site.sources}
    for q in progress.steps(QUANTITIES, "risk levels", unit="level"):
        lam, (lo, hi), pts, info = _rate(ctx, q.threshold, q.edp, q.label, int(n_draws))
        rate[q.label] = (lam, lo, hi)
        checks[q.label] = info
        contrib = sum(ctx.weights[b] * pts[b] for b in branches)
        deagg[q.label] = contrib / lam if lam > 0 else np.zeros(ctx.shape)
        for k, s in enumerate(site.sources):
            source_rate[s.name][q.label] = sum(float(np.sum(ctx.per_source[b][k] * pts[b])) for b in branches)
    prob = {t: {k: tuple(1.0 - math.exp(-x * t) for x in v) for k, v in rate.items()} for t in site.years}
    out = SiteRisk(site, {b: str(d.path) for b, d in branches.items()}, tuple(branches), estimator, method.name,
                   confidence, int(n_draws), ctx.mws, ctx.ds, QUANTITIES, rate, prob, source_rate, deagg, reports,
                   ctx.weights, {s.name: pulse_share(s, ctx.mws, ctx.ds) for s in site.sources},
                   max(c["unpaired"] for c in checks.values()), misfit=eq4_misfit, checks=checks,
                   degeneracy=deg, incomplete=incomplete, identity=_identity(branches))
    if curves:
        out.curves = _curves(ctx, int(curve_draws))
    return out


def _identity(branches) -> dict:
    """Per branch: its seed, its code identity, its successful runs and how many collapsed, and every code that
    wrote its rows with the rows of each (:mod:`pycolfrag.analysis.codes`; more than one after ``--allow-code-change``)."""
    return {b: {"seed": None if d.attrs.get("seed") is None else str(d.attrs.get("seed")),
                "code": None if code_identity(d.attrs) is None else str(code_identity(d.attrs)[1]),
                "runs": d.n, "collapses": int(np.sum(np.asarray(d["collapsed"], dtype=bool))),
                "codes": code_history(d.attrs, d.n_total)}
            for b, d in branches.items()}


def _curves(ctx, n_draws):
    res = {}
    for edp, xs in CURVE_X.items():
        lam, lo, hi = (np.zeros(xs.size) for _ in range(3))
        for k, x in enumerate(progress.steps(xs, f"risk curve of {edp}", unit="level")):
            lam[k], (lo[k], hi[k]), _, _ = _rate(ctx, float(x), edp, f"{edp} > {x:g}", n_draws)
        res[edp] = {"x": xs, "rate": lam, "low": lo, "high": hi}
    return res


# --------------------------------------------------------------------------- command
