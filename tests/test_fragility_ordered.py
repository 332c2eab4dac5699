"""Nested limit states fitted with one common dispersion (pycolfrag.analysis.fragility.fit_ordered_fragility).

References: with one state the cumulative probit likelihood is the binomial one, so the fit equals
fit_lognormal_fragility to the optimisers' tolerance; with two states the likelihood is written out
here from scratch (math.erf, a plain loop over the three outcome classes) and maximised by Nelder-Mead
from another start -- the two optima must agree to 1e-4 in ln theta and ln beta (Nelder-Mead's
tolerance); and 4000 runs drawn from the model (theta 0.3 and 0.8 g, beta 0.5) give back their
parameters within 4 standard errors (about beta / sqrt(n p (1 - p)) ~ 0.02 in ln theta).
"""
import math

import numpy as np
import pytest
from scipy import optimize

from pycolfrag.analysis import fragility as fr
from pycolfrag.core.errors import ParameterError


def _draw(n=4000, seed=5):
    rng = np.random.default_rng(seed)
    x = np.exp(rng.uniform(np.log(0.05), np.log(3.0), n))
    capacity = np.exp(0.5 * rng.standard_normal(n))          # one capacity per run: nested outcomes
    return x, np.vstack([x > 0.3 * capacity, x > 0.8 * capacity])


def test_one_state_is_the_binomial_fit():
    x, y = _draw()
    [joint] = fr.fit_ordered_fragility(x, y[:1])
    sep = fr.fit_lognormal_fragility(x, y[0].astype(float), np.zeros(x.size, bool), 0.5)
    assert joint.median == pytest.approx(sep.median, rel=1e-6) and joint.beta == pytest.approx(sep.beta, rel=1e-6)
    assert joint.loglik == pytest.approx(sep.loglik, rel=1e-9)


def test_two_states_maximise_the_ordered_likelihood_and_recover_the_model():
    x, y = _draw()
    a, b = fr.fit_ordered_fragility(x, y)
    assert a.beta == b.beta
    c = y.sum(axis=0)

    def phi(z):
        return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))

    def nll(p):
        t1, t2, beta = p[0], p[0] + abs(p[1]), math.exp(p[2])
        s = 0.0
        for xi, ci in zip(np.log(x), c):
            p1, p2 = phi((xi - t1) / beta), phi((xi - t2) / beta)
            s += math.log(max((1 - p1, p1 - p2, p2)[ci], 1e-300))
        return -s

    ref = optimize.minimize(nll, [math.log(0.5), 0.5, math.log(0.8)], method="Nelder-Mead",
                            options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000})
    assert math.log(a.median) == pytest.approx(ref.x[0], abs=1e-4)
    assert math.log(b.median) == pytest.approx(ref.x[0] + abs(ref.x[1]), abs=1e-4)
    assert math.log(a.beta) == pytest.approx(ref.x[2], abs=1e-4)
    assert a.median == pytest.approx(0.3, rel=0.08) and b.median == pytest.approx(0.8, rel=0.08)
    assert a.beta == pytest.approx(0.5, rel=0.1)
    assert a.degenerate == b.degenerate == ""


def test_the_common_fit_never_crosses():
    x, y = _draw()
    a, b = fr.fit_ordered_fragility(x, y)
    grid = np.geomspace(1e-4, 1e4, 2000)
    assert np.all(b(grid) <= a(grid))


def test_states_that_are_not_nested_are_refused():
    x, y = _draw()
    with pytest.raises(ParameterError, match="not nested"):
        fr.fit_ordered_fragility(x, y[::-1])
