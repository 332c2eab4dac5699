"""Degenerate fits said to be so wherever they arise, one warning per cause, and bad arguments of the
statistics refused with their name (pycolfrag.analysis.fragility).

Expected outcomes come from the likelihoods themselves: with every run at one IM level x the binomial
likelihood depends on (theta, beta) only through Phi(ln(x / theta) / beta), so any pair giving the
observed fraction maximises it and the optimiser cannot move from its start (median halfway between the
two outcomes' median ln IM -- here x itself -- and beta 0.5); a single MSA stripe is the same
likelihood in binomial form. The refusals are checked for the exception class and the bad value named.
"""
import warnings

import numpy as np
import pytest

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.fragility import DegenerateFitWarning, degenerate
from pycolfrag.core.errors import ParameterError


def test_a_fit_with_every_run_at_one_im_level_is_degenerate():
    im = np.full(20, 0.3)
    edp = np.r_[np.ones(10), np.full(10, 0.01)]            # 10 of 20 exceed 0.3
    with pytest.warns(DegenerateFitWarning, match="every run is at one IM level") as rec:
        fit = fr.fit_lognormal_fragility(im, edp, np.zeros(20, bool), 0.3)
    assert (fit.median, fit.beta) == (pytest.approx(0.3), pytest.approx(0.5))   # the optimiser's start
    assert "every run is at one IM level (0.3)" in fit.degenerate
    assert rec[0].message.causes == ("one_im_level",)


def test_an_msa_fit_on_one_stripe_is_degenerate_without_a_covariance():
    with pytest.warns(DegenerateFitWarning, match="every run is at one IM level"):
        f = fr.msa_fragility([0.3], [10], [4])
    assert "one IM level" in f.degenerate
    assert np.all(np.isnan(f.cov_ln))        # the information of one stripe has rank 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateFitWarning)
        assert fr.msa_fragility([0.1, 0.3], [10, 10], [2, 7]).degenerate == ""   # two stripes: identified


def test_one_warning_per_cause():
    """40 one-run groups (a --samples 1 grid's scenarios: too few runs, and too few standing runs behind
    the lognormal part) and 3 separable fits (beta on its bound, too): four warnings, each naming its
    count and cause, instead of 43."""
    rng = np.random.default_rng(0)
    im = np.geomspace(0.05, 1.0, 20)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with degenerate.one_warning_per_cause("fits"):
            for x in rng.uniform(0.1, 0.5, 40):
                fr.exceedance([x], [False], 0.35)
            for t in (0.2, 0.3, 0.4):
                fr.fit_lognormal_fragility(im, im, np.zeros(20, bool), t)
    msgs = sorted(str(w.message) for w in seen if issubclass(w.category, DegenerateFitWarning))
    assert len(msgs) == 4, msgs
    assert msgs[0].startswith("3 fits: a parameter on the optimiser's bound (e.g. fit_lognormal_fragility (0.2)")
    assert msgs[1].startswith("3 fits: the exceeding runs lie on one side")
    assert msgs[2].startswith("40 fits: fewer than 5 runs behind the fit (e.g. exceedance: only 1 run in the group")
    assert msgs[3].startswith("40 fits: fewer than 5 standing runs with EDP > 0")


def test_other_warnings_pass_through_the_collector():
    with pytest.warns(RuntimeWarning, match="unrelated"):
        with degenerate.one_warning_per_cause("fits"):
            warnings.warn("unrelated", RuntimeWarning, stacklevel=2)


E = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
C = [False] * 6
IM = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]


@pytest.mark.parametrize("call, words", [
    (lambda: fr.exceedance(E, C, None), "threshold must be a real number, got NoneType None"),
    (lambda: fr.empirical_exceedance(E, C, None), "threshold must be a real number"),
    (lambda: fr.binomial_ci(3, 2), "k = 3 successes out of n = 2 trials"),
    (lambda: fr.binomial_ci(-1, 5), r"k \(successes\) must be >= 0, got -1"),
    (lambda: fr.binomial_ci(1, 5, confidence=1.5), r"confidence must be in \(0, 1\), got 1.5"),
    (lambda: fr.binomial_ci(1.5, 4), r"k \(successes\) must be an integer, got float 1.5"),
    (lambda: fr.binomial_ci(1, 0), "k = 1 successes out of n = 0 trials"),
    (lambda: fr.binomial_ci(True, 4), "got the bool True"),
    (lambda: fr.fit_lognormal_fragility(IM, E, C, 0.35, n_boot=True), "n_boot must be an integer, got the bool True"),
    (lambda: fr.fit_lognormal_fragility(IM, E, C, 0.35, confidence=1.0), r"confidence must be in \(0, 1\)"),
    (lambda: fr.bootstrap_interval(E, C, 0.35, n_boot=True), "n_boot must be an integer, got the bool True"),
    (lambda: fr.scenario_table([6.5] * 6, [5.0] * 6, {"u_top": E}, C, n_boot=True), "got the bool True"),
    (lambda: fr.stripe_curve(IM, E, C, 0.35, n_boot=True), "got the bool True"),
    (lambda: fr.exceedance_surface([6.5] * 6, [5.0] * 6, E, C, 0.35, n_boot=2.0), "n_boot must be an integer"),
    (lambda: fr.collapse_surface([6.5] * 6, [5.0] * 6, C, n_boot=True), "got the bool True"),
])
def test_bad_arguments_are_named(call, words):
    with pytest.raises(ParameterError, match=words):
        call()


def test_binomial_ci_of_no_trial_and_numpy_integers():
    """0 of 0 has no interval (NaN, NaN); numpy integers are integers: 3 of 10 at 90 % is the
    Clopper-Pearson interval, whose lower limit is the 5 % quantile of Beta(3, 8) = 0.0873 (scipy.stats.beta)."""
    assert np.all(np.isnan(fr.binomial_ci(0, 0)))
    from scipy import stats
    lo, hi = fr.binomial_ci(np.int64(3), np.int64(10))
    assert lo == pytest.approx(stats.beta.ppf(0.05, 3, 8), rel=1e-9)
    assert hi == pytest.approx(stats.beta.ppf(0.95, 4, 7), rel=1e-9)


def test_the_summary_is_given_when_the_fits_end_in_an_error():
    with pytest.warns(DegenerateFitWarning, match="^1 fits: fewer than 5 runs"):
        with pytest.raises(ParameterError):
            with degenerate.one_warning_per_cause("fits"):
                fr.exceedance([0.4], [False], 0.35)
                fr.binomial_ci(3, 2)
