"""Fragility analysis: paper Eqs. (1)-(4), surfaces over (Mw, R), stripe curves, MLE curves, bootstrap.

Psycharis, Fragiadakis & Stefanou, "Seismic reliability assessment of classical columns subjected to
near-fault ground motions", section "Fragility assessment":

* Eq. (1)  F_R(Mw, R) = P(EDP >= edp | Mw, R)
* Eq. (2)  F_R = 1 - Phi((ln edp - mu_lnEDP) / beta_lnEDP)               (no collapses)
* Eq. (3)  P(C | Mw, R) = collapsed / total
* Eq. (4)  P(EDP >= edp) = P(C) + (1 - P(C)) (1 - Phi((ln edp - mu) / beta)),  mu, beta of the
  non-collapsed data.

``mu`` and ``beta`` are the maximum-likelihood lognormal parameters of the non-collapsed EDPs
(``scipy.stats.lognorm.fit(x, floc=0)``, i.e. the mean and the ``ddof=0`` standard deviation of
``ln x``).  Non-collapsed EDPs that are exactly zero (a run that never moved) cannot enter a
lognormal fit; they are counted as "below every positive threshold", so Eq. (4) becomes
``P(C) + (1 - P(C)) q (1 - Phi(...))`` with ``q`` the fraction of positive non-collapsed EDPs and
the fit done on the positive ones (for data without zeros this is exactly Eq. (4)).

Collapsed runs: their EDP values are never used (collapse counts as exceeding every level, and
means and fits take the non-collapsed runs only), so they may be NaN -- ``u_d`` of a collapsed run
is NaN by definition (it has no residual state). Every function here gives the same result whatever
the collapsed rows hold; only the EDPs of non-collapsed runs must be finite and non-negative.

Beyond the paper:

* the empirical ratio of Eq. (1) (``empirical_exceedance``), reported next to Eq. (4);
* stripe curves accept equal-width (paper, 12 stripes) or equal-count stripes;
* a smooth lognormal fragility function fitted by maximum likelihood over all samples
  (``fit_lognormal_fragility``): each sample contributes a Bernoulli outcome
  y = [collapsed or EDP >= edp] with P(y = 1 | IM) = Phi((ln IM - ln theta) / beta);
  the binomial log-likelihood is maximised over (ln theta, ln beta) with scipy.optimize;
* for record suites (docs/records.md): stripe curves on every IM of a suite table
  (``stripe_analysis``), a cloud analysis (ln EDP regressed on ln IM, collapse by logistic
  regression: ``cloud_analysis``) and multiple-stripe fragility by the binomial likelihood of
  Baker (2015) (``msa_fragility``, ``msa_from_table``);
* percentile-bootstrap confidence intervals (``scipy.stats.bootstrap``, resampling within each
  scenario or stripe; stratified over scenarios for the MLE curve), with a seeded Generator.

Every EDP here is dimensionless (u_top and u_d of the paper); IMs are in the units of the results
file (PGA in g, PGV in cm/s, SA in g, SV in cm/s).
"""
from __future__ import annotations

from pycolfrag.analysis.fragility.bootstrap import as_rng, bootstrap_interval, eq4_statistic
from pycolfrag.analysis.fragility.degenerate import MIN_FIT_POINTS, DegenerateFitWarning
from pycolfrag.analysis.fragility.eq4 import (
    binomial_ci,
    collapse_probability,
    empirical_exceedance,
    eq4_degenerate,
    exceedance,
    lognormal_parameters,
)
from pycolfrag.analysis.fragility.mle import BETA_MAX, BETA_MIN, LognormalFragility, fit_lognormal_fragility
from pycolfrag.analysis.fragility.ordered import fit_ordered_fragility
from pycolfrag.analysis.fragility.stripes import StripeCurve, stripe_curve, stripe_edges
from pycolfrag.analysis.fragility.suites import (
    CloudFit,
    LogisticCollapse,
    MSAFragility,
    cloud_analysis,
    fit_logistic_collapse,
    msa_fragility,
    msa_from_table,
    ok_rows,
    stripe_analysis,
    table_im,
)
from pycolfrag.analysis.fragility.surfaces import (
    ScenarioRow,
    Surface,
    collapse_surface,
    degenerate_scenarios,
    exceedance_surface,
    mean_edp_surface,
    scenario_table,
)
from pycolfrag.damage import (
    PERFORMANCE_LEVELS,
    U_D_LEVELS,
    U_TOP_LEVELS,
    PerformanceLevel,
    exceedance_score,
    exceeded,
)

__all__ = [
    "PerformanceLevel",
    "PERFORMANCE_LEVELS",
    "U_TOP_LEVELS",
    "U_D_LEVELS",
    "collapse_probability",
    "binomial_ci",
    "lognormal_parameters",
    "exceedance",
    "eq4_statistic",
    "as_rng",
    "ok_rows",
    "empirical_exceedance",
    "bootstrap_interval",
    "ScenarioRow",
    "scenario_table",
    "Surface",
    "exceedance_surface",
    "mean_edp_surface",
    "collapse_surface",
    "StripeCurve",
    "stripe_curve",
    "stripe_edges",
    "LognormalFragility",
    "fit_lognormal_fragility",
    "BETA_MIN",
    "BETA_MAX",
    "fit_ordered_fragility",
    "exceeded",
    "exceedance_score",
    "DegenerateFitWarning",
    "MIN_FIT_POINTS",
    "eq4_degenerate",
    "degenerate_scenarios",
    # record suites (docs/records.md)
    "table_im",
    "stripe_analysis",
    "LogisticCollapse",
    "fit_logistic_collapse",
    "CloudFit",
    "cloud_analysis",
    "MSAFragility",
    "msa_fragility",
    "msa_from_table",
]

