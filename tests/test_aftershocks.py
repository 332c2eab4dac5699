"""Aftershocks of a sequence's mainshocks (pycolfrag/risk/aftershocks.py; docs/sequences.md, "Aftershocks"):
Reasenberg & Jones (1989)'s rate 10^(a + b (Mm - M)) (t + c)^-p, generic California a = -1.67, b = 0.91,
p = 1.08, c = 0.05 d, or Page et al. (2016)'s generic parameters by tectonic region (b = 1, c = 0.018 d). The
expected count over a window is the closed form of the modified Omori law's integral; the draws are held to it,
and the sequences' mainshocks are unchanged by drawing aftershocks."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from pycolfrag.core.errors import ParameterError
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import model_ranges
from pycolfrag.risk import sequences as sq
from pycolfrag.risk.aftershocks import AFTERSHOCK_MODELS, Aftershocks, aftershock_model
from pycolfrag.risk.aftershocks import REASENBERG_JONES_1989 as RJ
from pycolfrag.site.sources import site_from_dict

PM = PulseMap(sq.DEFAULT_PULSE_SHAPE, 1.0, sq.DEFAULT_TP_MODEL)
SZ = aftershock_model("page2016-sz-generic")

#: PageEtAlGenericParams_032116.csv as it stands in opensha/opensha-oaf at commit
#: f9edf3523993ae48b87e484efba5971fd0471bc1 (src/main/resources/org/opensha/oaf/rj/; last changed by commit
#: 20431f4202b1a15904f381f4ca236fa8518daedb), the USGS's operational copy of Page et al. (2016)'s table, verbatim
#: (the trailing spaces of five names included).
PAGE_CSV = """\
regionName,aValue_MaxLike,pValue_MaxLike,aValue_Mean,aValue_Sigma,aValue_Sigma1,aValue_Sigma0,bValue,cValue
ANSR-ABSLDEC,-2.04,1.01,-2.29,0.63,560,0.49,1.00,0.018
ANSR-ABSLOCB,-2.00,0.64,-2.82,0.80,890,0.49,1.00,0.018
ANSR-ABSLSHC,-2.44,1.06,-2.85,0.75,800,0.49,1.00,0.018
ANSR-DEEPCON,-2.01,0.98,-2.13,0.52,250,0.49,1.00,0.018
ANSR-HOTSPOT,-2.84,1.12,-3.00,0.68,680,0.49,1.00,0.018
ANSR-OCEANBD ,-2.69,1.08,-3.19,0.60,500,0.49,1.00,0.018
ANSR-SHALCON,-2.16,0.98,-2.42,0.63,570,0.49,1.00,0.018
SCR-GENERIC,-2.28,0.73,-2.85,0.78,870,0.49,1.00,0.018
SOR-GENERIC,-2.98,0.97,-3.04,0.67,650,0.49,1.00,0.018
SZ-GENERIC,-2.09,0.88,-2.47,0.63,570,0.49,1.00,0.018
SZ-INLBACK ,-2.09,0.86,-2.43,0.66,640,0.49,1.00,0.018
SZ-ONSHORE ,-2.02,0.81,-2.34,0.60,500,0.49,1.00,0.018
SZ-OUTERTR ,-1.97,0.92,-2.42,0.64,540,0.49,1.00,0.018
SCR-ABVSLAB,-2.28,0.73,-2.85,0.78,870,0.49,1.00,0.018
SOR-ABVSLAB,-2.98,0.97,-3.04,0.67,650,0.49,1.00,0.018
"""


def test_the_papers_generic_parameters():
    """Reasenberg & Jones (1989), generic California: a = -1.67, b = 0.91, p = 1.08, c = 0.05 days."""
    assert (RJ.a, RJ.b, RJ.p, RJ.c_days) == (-1.67, 0.91, 1.08, 0.05)


def test_page_2016_is_the_usgs_file_row_for_row():
    """Page et al. (2016) by the USGS's file (PAGE_CSV above): SZ-GENERIC's row is a = -2.09 (aValue_MaxLike, the
    pooled maximum-likelihood a), p = 0.88 (pValue_MaxLike), b = 1.00, c = 0.018 days; every row of the file is a
    model "page2016-" + its region in lower case with those four columns, Mw >= 5 within a year as for rj1989,
    and the models are the file's rows and rj1989, no more."""
    assert (SZ.a, SZ.p, SZ.b, SZ.c_days, SZ.m_min, SZ.window_days) == (-2.09, 0.88, 1.0, 0.018, 5.0, 365.25)
    rows = [line.split(",") for line in PAGE_CSV.splitlines()[1:]]
    for name, a, p, _mean, _sigma, _s1, _s0, b, c in rows:
        m = aftershock_model("page2016-" + name.strip().lower())
        assert (m.a, m.p, m.b, m.c_days) == (float(a), float(p), float(b), float(c)), name
        assert (m.m_min, m.window_days) == (RJ.m_min, RJ.window_days), name
    assert sorted(AFTERSHOCK_MODELS) == sorted(["rj1989"] + ["page2016-" + r[0].strip().lower() for r in rows])
    assert AFTERSHOCK_MODELS["rj1989"] == RJ


def test_a_mw_6_5_mainshocks_year_under_sz_generic():
    """N(M >= 5 within 365.25 d | Mm 6.5) under SZ-GENERIC (a = -2.09, b = 1, p = 0.88, c = 0.018 d): the closed
    form against scipy's quadrature of the rate itself (rel 1e-9: the quadrature's error; split at 1 day where
    the rate turns from steep to flat), and against the hand computation (rel 1e-4: its 5 digits):
    10^(-2.09 + 1.5) = 10^-0.59 = 0.25704; 0.018^0.12 = e^(0.12 ln 0.018) = e^(-0.48209) = 0.61749;
    365.268^0.12 = e^(0.12 x 5.90063) = e^0.70808 = 2.03008; (2.03008 - 0.61749) / 0.12 = 11.7716;
    N = 0.25704 x 11.7716 = 3.0258 (RJ1989 gives 4.0: docs/sequences.md, "Aftershocks")."""
    rate = lambda t: 10 ** (-2.09 + 1.0 * (6.5 - 5.0)) * (t + 0.018) ** -0.88  # noqa: E731
    quad = sum(integrate.quad(rate, t1, t2, epsrel=1e-12, limit=200)[0] for t1, t2 in ((0.0, 1.0), (1.0, 365.25)))
    assert SZ.expected(6.5) == pytest.approx(quad, rel=1e-9)
    assert SZ.expected(6.5) == pytest.approx(3.0258, rel=1e-4)


@pytest.mark.parametrize("p", [1.08, 1.0])
def test_the_expected_count_is_the_omori_laws_integral(p):
    """N(M >= 5.5 in [1, 10] d | Mm 6.5) = 10^(a + b) integral (t + c)^-p dt: the closed form against scipy's
    quadrature of the rate itself (rel 1e-9: the quadrature's error), p = 1 by its logarithm."""
    m = Aftershocks(p=p)
    rate = lambda t: 10 ** (m.a + m.b * (6.5 - 5.5)) * (t + m.c_days) ** -p  # noqa: E731
    assert m.expected(6.5, 1.0, 10.0, m=5.5) == pytest.approx(integrate.quad(rate, 1.0, 10.0, epsrel=1e-12)[0],
                                                              rel=1e-9)


@pytest.mark.parametrize("name", ["rj1989", "page2016-sz-generic"])
def test_the_draws_hold_the_closed_form(name):
    """20 000 mainshocks of Mw 6.2: the mean count within the year, the counts in [0, 0.2], [1, 10] and [100, 365.25]
    days, and the share of aftershocks of M >= 6 (Gutenberg-Richter: 10^-(b (6 - 5)), 0.123 for rj1989's b = 0.91,
    0.1 for Page's b = 1) each within 4 standard errors of the closed form (Poisson counts: the variance of the
    mean count is its mean / 20 000); rj1989's p > 1 and SZ-GENERIC's p < 1 take the sampler's two sides of 1."""
    model = aftershock_model(name)
    rng = np.random.default_rng(3)
    n = 20000
    draws = [model.sample(6.2, rng) for _ in range(n)]
    counts = np.array([t.size for t, _ in draws])
    mu = model.expected(6.2)
    assert abs(counts.mean() - mu) < 4 * math.sqrt(mu / n), (counts.mean(), mu)
    for t1, t2 in ((0.0, 0.2), (1.0, 10.0), (100.0, 365.25)):    # the first hours (where c acts), days, months
        k = np.array([np.count_nonzero((t >= t1) & (t <= t2)) for t, _ in draws])
        mu_w = model.expected(6.2, t1, t2)
        assert abs(k.mean() - mu_w) < 4 * math.sqrt(mu_w / n), ((t1, t2), k.mean(), mu_w)
    mags = np.concatenate([m for _, m in draws])
    share, want = float(np.mean(mags >= 6.0)), 10 ** -model.b
    assert abs(share - want) < 4 * math.sqrt(want * (1 - want) / mags.size), (share, want)
    assert all(np.all(np.diff(t) >= 0) and np.all((t >= 0) & (t <= model.window_days)) for t, _ in draws)


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


def test_an_unknown_model_is_refused_naming_it_and_the_known():
    with pytest.raises(ParameterError, match=r"'page2016-greece'.*rj1989.*page2016-sz-generic"):
        aftershock_model("page2016-greece")


def test_the_bare_flag_is_rj1989_and_a_name_picks_the_model():
    """``--aftershocks`` alone keeps meaning rj1989 (the runs and docs before Page et al. used it bare)."""
    from pycolfrag.risk.sequences_run import parser
    args = lambda *more: parser().parse_args(["site.toml", "out", *more]).aftershocks  # noqa: E731
    assert (args(), args("--aftershocks"), args("--aftershocks", "page2016-sz-onshore")) == (
        None, "rj1989", "page2016-sz-onshore")


def test_a_word_after_the_bare_flag_that_names_no_model_is_the_site_or_the_folder():
    """argparse's optional value takes any word: ``--aftershocks site.toml out`` read the site file as the model
    (then lacked ``out``). The word is the model where it names one; else the site or folder, with rj1989; a
    misspelt name with no other place is still the model (refused by name: tests/test_sequences_run.py)."""
    from pycolfrag.risk.sequences_run import parse_args
    got = lambda *argv: (lambda a: (a.site, a.out, a.aftershocks))(parse_args(list(argv)))  # noqa: E731
    assert got("--aftershocks", "site.toml", "out") == ("site.toml", "out", "rj1989")
    assert got("site.toml", "--aftershocks", "out", "--rare") == ("site.toml", "out", "rj1989")
    assert got("--aftershocks", "page2016-sz-generic", "site.toml", "out") == (
        "site.toml", "out", "page2016-sz-generic")
    assert got("site.toml", "out", "--aftershocks", "page2016-greece")[2] == "page2016-greece"
    assert got("site.toml", "out")[2] is None


def test_an_unknown_option_beside_the_bare_flag_is_named(capsys):
    """``--aftershocks site.toml out --bogus``: the error is the unknown option, not a positional said missing
    (the fallback to argparse's own reading of the word as the model would lose ``out``)."""
    from pycolfrag.risk.sequences_run import parse_args
    with pytest.raises(SystemExit):
        parse_args(["--aftershocks", "site.toml", "out", "--bogus"])
    err = capsys.readouterr().err
    assert "unrecognized arguments: --bogus" in err and "required" not in err


def test_the_rare_sequences_take_aftershocks():
    """Once refused by name; now taken (tests/test_sequences_rare_aftershocks.py holds them to the exact answer)."""
    from pycolfrag.risk import sequences_rare as R
    assert R.RareSequenceSettings(sequences=sq.SequenceSettings(aftershocks=RJ)).sequences.aftershocks == RJ
