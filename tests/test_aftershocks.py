"""Aftershocks of a sequence's mainshocks (pycolfrag/risk/aftershocks.py; docs/sequences.md, "Aftershocks"):
Reasenberg & Jones (1989)'s rate 10^(a + b (Mm - M)) (t + c)^-p, generic California a = -1.67, b = 0.91,
p = 1.08, c = 0.05 d. The expected count over a window is the closed form of the modified Omori law's integral;
the draws are held to it, and the sequences' mainshocks are unchanged by drawing aftershocks."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from pycolfrag.core.errors import ParameterError
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import model_ranges
from pycolfrag.risk import sequences as sq
from pycolfrag.risk.aftershocks import REASENBERG_JONES_1989 as RJ
from pycolfrag.risk.aftershocks import Aftershocks
from pycolfrag.site.sources import site_from_dict

PM = PulseMap(sq.DEFAULT_PULSE_SHAPE, 1.0, sq.DEFAULT_TP_MODEL)


def test_the_papers_generic_parameters():
    """Reasenberg & Jones (1989), generic California: a = -1.67, b = 0.91, p = 1.08, c = 0.05 days."""
    assert (RJ.a, RJ.b, RJ.p, RJ.c_days) == (-1.67, 0.91, 1.08, 0.05)


@pytest.mark.parametrize("p", [1.08, 1.0])
def test_the_expected_count_is_the_omori_laws_integral(p):
    """N(M >= 5.5 in [1, 10] d | Mm 6.5) = 10^(a + b) integral (t + c)^-p dt: the closed form against scipy's
    quadrature of the rate itself (rel 1e-9: the quadrature's error), p = 1 by its logarithm."""
    m = Aftershocks(p=p)
    rate = lambda t: 10 ** (m.a + m.b * (6.5 - 5.5)) * (t + m.c_days) ** -p  # noqa: E731
    assert m.expected(6.5, 1.0, 10.0, m=5.5) == pytest.approx(integrate.quad(rate, 1.0, 10.0, epsrel=1e-12)[0],
                                                              rel=1e-9)


def test_the_draws_hold_the_closed_form():
    """20 000 mainshocks of Mw 6.2: the mean count within the year, the counts in [0, 0.2], [1, 10] and [100, 365.25]
    days, and the share of
    aftershocks of M >= 6 (Gutenberg-Richter: 10^-(b (6 - 5))) each within 4 standard errors of the closed form
    (Poisson counts: the variance of the mean count is its mean / 20 000)."""
    rng = np.random.default_rng(3)
    n = 20000
    draws = [RJ.sample(6.2, rng) for _ in range(n)]
    counts = np.array([t.size for t, _ in draws])
    mu = RJ.expected(6.2)
    assert abs(counts.mean() - mu) < 4 * math.sqrt(mu / n), (counts.mean(), mu)
    for t1, t2 in ((0.0, 0.2), (1.0, 10.0), (100.0, 365.25)):    # the first hours (where c acts), days, months
        k = np.array([np.count_nonzero((t >= t1) & (t <= t2)) for t, _ in draws])
        mu_w = RJ.expected(6.2, t1, t2)
        assert abs(k.mean() - mu_w) < 4 * math.sqrt(mu_w / n), ((t1, t2), k.mean(), mu_w)
    mags = np.concatenate([m for _, m in draws])
    share, want = float(np.mean(mags >= 6.0)), 10 ** -RJ.b
    assert abs(share - want) < 4 * math.sqrt(want * (1 - want) / mags.size), (share, want)
    assert all(np.all(np.diff(t) >= 0) and np.all((t >= 0) & (t <= RJ.window_days)) for t, _ in draws)


def _site():
    return site_from_dict({"name": "t", "outside": "zero", "pulse": {"probability": 0.5}, "sources": [
        {"name": "near", "rate": 0.3, "magnitude": {"type": "characteristic", "mw": 6.5},
         "distance": {"type": "uniform", "min_km": 5.0, "max_km": 10.0}}]})


def test_aftershocks_are_wired_into_the_sequences_and_leave_the_mainshocks_as_they_were():
    """With aftershocks the mainshocks are the same events, bit for bit (their streams are untouched); each
    aftershock follows its mainshock at its distance; over 400 sequences of 20 years the aftershocks number as
    the closed form says: sum over mainshocks of N within min(1 yr, what is left of the horizon), within 4
    standard errors (Poisson)."""
    ranges = model_ranges()
    n_seq, years = 400, 20.0
    total, expected = 0, 0.0
    for s in range(n_seq):
        plain = sq.sequence_events(_site(), years, 9, s, PM, ranges)
        both = sq.sequence_events(_site(), years, 9, s, PM, ranges, aftershocks=RJ)
        assert [e for e in both if e.parent < 0] == plain
        assert [e.time_yr for e in both] == sorted(e.time_yr for e in both)
        mains = {e.index: e for e in plain}
        for e in both:
            if e.parent >= 0:
                m = mains[e.parent]
                assert e.time_yr >= m.time_yr and e.r_km == m.r_km and e.source == m.source
        total += sum(e.parent >= 0 for e in both)
        expected += sum(RJ.expected(m.mw, 0.0, min(RJ.window_days, (years - m.time_yr) * 365.25)) for m in plain)
    assert abs(total - expected) < 4 * math.sqrt(expected), (total, expected)


@pytest.mark.parametrize("kw, named", [({"p": 0.0}, "p"), ({"c_days": -1.0}, "c_days"), ({"a": math.nan}, "a"),
                                       ({"window_days": True}, "window_days")])
def test_bad_parameters_are_refused_by_name(kw, named):
    with pytest.raises(ParameterError, match=named):
        Aftershocks(**kw)


def test_the_rare_sequences_take_aftershocks():
    """Once refused by name; now taken (tests/test_sequences_rare_aftershocks.py holds them to the exact answer)."""
    from pycolfrag.risk import sequences_rare as R
    assert R.RareSequenceSettings(sequences=sq.SequenceSettings(aftershocks=RJ)).sequences.aftershocks == RJ
