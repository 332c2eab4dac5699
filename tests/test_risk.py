"""Site risk by the Mw-R route (pycolfrag.risk.site_risk, pycolfrag.site.sources) and the pulse-occurrence model of
Shahi & Baker (2014).

Every expected number is computed here from a closed form (the truncated Gutenberg-Richter pdf,
bilinear interpolation, binomial and beta quantiles and the Dirichlet covariance from scipy or by
hand), from scipy.integrate.quad of the closed-form pdfs, or from the cells of a small results file
written by the test itself; tolerances are stated where they are not exact.
"""
import json
import math
from types import MappingProxyType

import h5py
import numpy as np
import pytest
from scipy import stats

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.data import read_results
from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import shahi_baker_2014 as sb14
from pycolfrag.risk import site_risk as risk
from pycolfrag.site import models
from pycolfrag.site import sources as site_file

# --------------------------------------------------------------------------- helpers

def write_cells(path, cells, pulse=None, seed=0):
    """A results file in the documented layout with the given cells.

    cells: {(mw, r_km): (n, n_collapsed, median_u_top)}; u_top lognormal (beta 0.6) about the median,
    u_d = u_top / 50; collapsed rows hold NaN EDPs. ``pulse`` is written as the root attribute.
    """
    rng = np.random.default_rng(seed)
    cols = {k: [] for k in ("mw", "dist_km", "u_top", "u_d", "collapsed", "scenario", "sample")}
    for sc, ((m, r), (n, k, med)) in enumerate(sorted(cells.items())):
        u = med * np.exp(0.6 * rng.standard_normal(n))
        c = np.zeros(n, dtype=bool)
        c[:k] = True
        u[c] = np.nan
        cols["mw"] += [m] * n
        cols["dist_km"] += [r] * n
        cols["u_top"] += list(u)
        cols["u_d"] += list(u / 50)
        cols["collapsed"] += list(c)
        cols["scenario"] += [sc] * n
        cols["sample"] += list(range(n))
    rows = len(cols["mw"])
    with h5py.File(path, "w") as f:
        g = f.create_group("samples")
        for key, v in cols.items():
            g[key] = np.asarray(v, dtype="u1" if key == "collapsed" else ("i4" if key in ("scenario", "sample")
                                                                          else float))
        g["status"] = np.zeros(rows, dtype="i4")
        g["message"] = np.array([b""] * rows, dtype="S64")
        f.attrs["column"] = json.dumps({"name": "test column"})
        f.attrs["grid_signature"] = json.dumps({"synthetic": True})
        f.attrs["complete"] = True
        if pulse is not None:
            f.attrs["pulse"] = pulse
    return str(path)


#: site()'s default pulse model: read-only, and each site gets its own copy
_PULSE_ONLY = MappingProxyType({"model": "pulse-only"})


def site(sources, pulse=_PULSE_ONLY, **kw):
    d = {"name": "test site", "sources": sources, **kw}
    if pulse is not None:
        d["pulse"] = dict(pulse)
    return site_file.site_from_dict(d)


def char_source(mw, r_km, rate=0.002, **kw):
    return {"name": "fault", "rate": rate, "magnitude": {"type": "characteristic", "mw": mw},
            "distance": {"type": "fixed", "r_km": r_km}, **kw}


def _cell(path, mw, r):
    d = read_results(path)
    sel = (d["mw"] == mw) & (d["dist_km"] == r)
    return d["u_top"][sel], d["u_d"][sel], d["collapsed"][sel]


# --------------------------------------------------------------------------- exact reference cases

def test_single_source_on_a_grid_point_gives_nu_times_p_exactly(tmp_path):
    """One source, one magnitude, one distance on a grid scenario: lambda = nu P (no interpolation,
    no quadrature: the weight of that scenario is nu times 1), P(T) = 1 - exp(-lambda T)."""
    h5 = write_cells(tmp_path / "p.h5", {(6.5, 5.0): (40, 3, 0.1), (6.5, 10.0): (40, 1, 0.05),
                                         (7.5, 5.0): (40, 9, 0.3), (7.5, 10.0): (40, 4, 0.2)})
    nu = 0.0021
    s = site([char_source(7.5, 10.0, rate=nu)])
    res = risk.site_risk(s, h5, n_draws=50, curves=False, estimator="eq4")
    u_top, u_d, c = _cell(h5, 7.5, 10.0)
    for q in risk.QUANTITIES:
        if q.level is None:
            expected = nu * (4 / 40)
        else:
            expected = nu * fr.exceedance({"u_top": u_top, "u_d": u_d}[q.edp], c, q.level.threshold)
        assert res.rate[q.label][0] == expected, q.label
        for t in (50.0, 100.0, 475.0):
            assert res.prob[t][q.label][0] == 1 - math.exp(-expected * t)
    assert res.deagg["collapse"][1, 1] == 1.0            # all of it from (7.5, 10)
    assert res.pulse_only and "PULSE-ONLY" in risk.report_section(res)


def test_truncated_gutenberg_richter_against_closed_form():
    """A surface piecewise linear in Mw (nodes 5.5, 6.5, 7.5 with P = 0, 0.2, 1) integrated against
    the doubly truncated exponential pdf f(m) = beta e^{-beta (m - m0)} / (1 - e^{-beta (m1 - m0)}).

    Closed form on each segment [a, b] with P = alpha + gamma m:
    int (alpha + gamma m) f dm = [ -(alpha + gamma m + gamma / beta) e^{-beta (m - m0)} ]_a^b / C.
    Gauss-Legendre with 12 points per segment integrates exp x linear to round-off: rel 1e-12."""
    b, m0, m1, nu = 1.1, 5.5, 7.5, 0.03
    beta = b * math.log(10)
    C = 1 - math.exp(-beta * (m1 - m0))
    mws, ds = np.array([5.5, 6.5, 7.5]), np.array([10.0])
    P = np.array([[0.0], [0.2], [1.0]])

    def seg(a, bb, pa, pb):
        g = (pb - pa) / (bb - a)
        al = pa - g * a
        F = lambda m: -(al + g * m + g / beta) * math.exp(-beta * (m - m0))
        return (F(bb) - F(a)) / C

    expected = nu * (seg(5.5, 6.5, 0.0, 0.2) + seg(6.5, 7.5, 0.2, 1.0))
    src = site_file.MagnitudeDistanceSource("gr", nu, models.GutenbergRichter(b, m0, m1),
                                            models.FixedDistance(10.0), models.PulseOnly())
    W, _, rep = risk.node_weights([src], mws, ds)
    assert np.sum(W * P) == pytest.approx(expected, rel=1e-12)
    assert np.sum(W) == pytest.approx(nu, rel=1e-12)          # the pdf integrates to 1
    # the share of the rate on the 5.5 node is int (1 - (m - 5.5)) f over [5.5, 6.5] (closed form too)
    assert W[0, 0] == pytest.approx(nu * seg(5.5, 6.5, 1.0, 0.0), rel=1e-12)
    assert rep[0].outside == 0.0


def test_interpolation_is_bilinear_in_mw_and_ln_r():
    """A surface a + b Mw + c ln R + d Mw ln R is reproduced exactly between the nodes (bilinear in
    (Mw, ln R)); a surface that is not (Mw^2) gives at a cell's centre the mean of its 4 corners."""
    mws, ds = np.array([5.5, 6.0, 7.0, 7.5]), np.array([5.0, 7.5, 12.5, 20.0])
    M, R = np.meshgrid(mws, ds, indexing="ij")
    f = lambda m, r: 0.1 + 0.05 * m - 0.02 * np.log(r) + 0.01 * m * np.log(r)
    rng = np.random.default_rng(3)
    m = rng.uniform(5.5, 7.5, 200)
    r = np.exp(rng.uniform(np.log(5), np.log(20), 200))
    assert np.allclose(risk.interpolate(f(M, R), mws, ds, m, r), f(m, r), rtol=0, atol=1e-14)
    g = (M / 7.5) ** 2 * np.log(R) / np.log(20)
    mc, rc = 6.5, math.sqrt(7.5 * 12.5)                       # centre in (Mw, ln R) of cell (6-7, 7.5-12.5)
    corners = g[1:3, 1:3].mean()
    assert risk.interpolate(g, mws, ds, mc, rc) == pytest.approx(corners, rel=1e-14)
    assert risk.interpolate(g, mws, ds, mc, rc) != pytest.approx((mc / 7.5) ** 2 * math.log(rc) / math.log(20),
                                                                rel=1e-3)
    with pytest.raises(ParameterError, match=r"1 of 2 points outside the grid Mw 5\.5-7\.5, R 5-20 km, "
                                             r"the first at Mw 6, R 25 km"):
        risk.interpolate(g, mws, ds, [7.0, 6.0], [10.0, 25.0])


def test_uniform_distance_integral_against_closed_form():
    """Uniform R on [5, 20] km over a surface linear in ln R (exact under the interpolation):
    lambda = nu (a + c E[ln R]), E[ln R] = [r ln r - r]_5^20 / 15."""
    mws, ds = np.array([6.0, 7.0]), np.array([5.0, 10.0, 20.0])
    a, c, nu = 0.4, -0.1, 0.01
    P = np.tile(a + c * np.log(ds), (2, 1))
    src = site_file.MagnitudeDistanceSource("u", nu, models.Characteristic(6.0),
                                            models.UniformDistance(5.0, 20.0), models.PulseOnly())
    W, _, _ = risk.node_weights([src], mws, ds)
    e_ln = ((20 * math.log(20) - 20) - (5 * math.log(5) - 5)) / 15
    assert np.sum(W * P) == pytest.approx(nu * (a + c * e_ln), rel=1e-12)
    assert np.all(W[1] == 0)                                   # Mw 6 events weigh only on the Mw 6 row


def test_outside_range_is_reported_and_treated_as_asked():
    """G-R from Mw 5.0 on a grid starting at 5.5 and area distances 5-30 km on a grid ending at 20 km.
    Reported fractions (closed forms): F(5.5) = (1 - e^{-beta 0.5}) / (1 - e^{-beta 2.5}) below in Mw;
    (30^2 - 20^2) / (30^2 - 5^2) beyond 20 km for f(r) = 2 r / (30^2 - 5^2)."""
    b = 1.0
    beta = b * math.log(10)
    spec = {"name": "bg", "rate": 0.02,
            "magnitude": {"type": "gutenberg-richter", "b": b, "m_min": 5.0, "m_max": 7.5},
            "distance": {"type": "area", "min_km": 5.0, "max_km": 30.0}}
    mws, ds = np.array([5.5, 6.5, 7.5]), np.array([5.0, 10.0, 20.0])
    below = (1 - math.exp(-beta * 0.5)) / (1 - math.exp(-beta * 2.5))
    above = (30 ** 2 - 20 ** 2) / (30 ** 2 - 5 ** 2)
    with pytest.raises(ParameterError, match=r"bg.*Mw below 0\.68.*R below 0.*above 0\.571.*outside = 'clamp'"):
        risk.node_weights(site([spec]).sources, mws, ds)
    P = np.full((3, 3), 0.5)
    for how in ("clamp", "zero"):
        W, _, rep = risk.node_weights(site([spec]).sources, mws, ds, outside=how)
        o = rep[0]
        assert o.mw_below == pytest.approx(below, rel=1e-12) and o.mw_above == 0.0
        assert o.r_above == pytest.approx(above, rel=1e-12) and o.r_below == 0.0
        # independent M and R: outside in either = 1 - (1 - below)(1 - above)
        assert o.outside == pytest.approx(1 - (1 - below) * (1 - above), rel=1e-12)
        assert o.treatment == how
        inside = 0.02 * 0.5 * (1 - below) * (1 - above)
        assert np.sum(W * P) == pytest.approx(0.02 * 0.5 if how == "clamp" else inside, rel=1e-12)


def test_clamp_gives_the_outside_part_to_the_edge_scenarios():
    """Under clamp the part of a source below the grid's first Mw (or beyond its last R) takes the
    probability of the edge scenarios. Rate weight on the Mw 5.5 row = nu [F(5.5) + int_5.5^6.5
    (6.5 - m) f(m) dm] and on the R 20 km column = nu [P(R > 20) + int_10^20 (ln r - ln 10) /
    ln 2 f(r) dr], both integrated here by scipy.integrate.quad on the closed-form pdfs (tolerance
    1e-9 relative: quad's own error is below 1e-12, the module's Gauss-Legendre is exact to round-off
    for these smooth integrands)."""
    from scipy import integrate
    b, m0, m1, nu = 1.0, 5.0, 7.5, 0.02
    beta = b * math.log(10)
    f_m = lambda m: beta * math.exp(-beta * (m - m0)) / (1 - math.exp(-beta * (m1 - m0)))
    f_r = lambda r: 2 * r / (30 ** 2 - 5 ** 2)
    spec = {"name": "bg", "rate": nu, "magnitude": {"type": "gutenberg-richter", "b": b, "m_min": m0, "m_max": m1},
            "distance": {"type": "area", "min_km": 5.0, "max_km": 30.0}}
    mws, ds = np.array([5.5, 6.5, 7.5]), np.array([5.0, 10.0, 20.0])
    W, _, _ = risk.node_weights(site([spec]).sources, mws, ds, outside="clamp")
    row = integrate.quad(f_m, m0, 5.5)[0] + integrate.quad(lambda m: (6.5 - m) * f_m(m), 5.5, 6.5)[0]
    col = (integrate.quad(f_r, 20, 30)[0]
           + integrate.quad(lambda r: math.log(r / 10) / math.log(2) * f_r(r), 10, 20)[0])
    assert W[0].sum() == pytest.approx(nu * row, rel=1e-9)
    assert W[:, 2].sum() == pytest.approx(nu * col, rel=1e-9)
    assert W.sum() == pytest.approx(nu, rel=1e-12)                    # nothing dropped under clamp


# --------------------------------------------------------------------------- sampling error

def test_bootstrap_interval_of_a_proportion_is_the_binomial_one(tmp_path):
    """Collapse in one cell, k = 8 of n = 40: resampling the runs makes the count Binomial(n, k/n),
    so the 90 % interval of lambda is nu times the binomial 5 % and 95 % quantiles over n
    (scipy.stats.binom.ppf); with 20 000 draws the sample percentile falls on those counts or between
    neighbours: tolerance one count (nu / n)."""
    n, k, nu = 40, 8, 0.003
    h5 = write_cells(tmp_path / "p.h5", {(7.0, 10.0): (n, k, 0.2)})
    res = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)]), h5, n_draws=20000, curves=False, rng=1,
                         uncertainty="bootstrap")
    lam, lo, hi = res.rate["collapse"]
    assert lam == nu * k / n
    q = stats.binom(n, k / n).ppf([0.05, 0.95]) / n
    assert lo == pytest.approx(nu * q[0], abs=nu / n)
    assert hi == pytest.approx(nu * q[1], abs=nu / n)
    assert lo < lam < hi


def test_beta_interval_of_a_proportion_is_the_jeffreys_one(tmp_path):
    """uncertainty='beta': the draws of a cell with k of n are Beta(k + 1/2, n - k + 1/2), so the limits
    of the interval of nu P over nu sit at scipy's beta CDF 0.05 and 0.95. With N = 40 000 draws a
    sample quantile's CDF value has standard error sqrt(0.05 * 0.95 / N) = 0.0011: tolerance 3 of
    them (0.0033). 0 of n keeps a positive upper bound (near 0.046 for n = 40)."""
    n, nu, N = 40, 0.003, 40000
    tol = 3 * math.sqrt(0.05 * 0.95 / N)
    for k in (8, 0):
        h5 = write_cells(tmp_path / f"p{k}.h5", {(7.0, 10.0): (n, k, 0.2)})
        res = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)]), h5, n_draws=N, curves=False,
                             uncertainty="beta", rng=2)
        _, lo, hi = res.rate["collapse"]
        post = stats.beta(k + 0.5, n - k + 0.5)
        assert post.cdf(lo / nu) == pytest.approx(0.05, abs=tol)
        assert post.cdf(hi / nu) == pytest.approx(0.95, abs=tol)
    assert hi / nu == pytest.approx(stats.beta(0.5, 40.5).ppf(0.95), rel=0.03)


def test_intervals_of_independent_cells_add_up(tmp_path):
    """Two cells with equal weights (a magnitude half-way between two nodes): lambda's draws are the
    weighted sum of independent cell draws, so with the beta draws lambda's variance is
    (nu/2)^2 (var1 + var2) of the two beta posteriors (within 5 %: 40 000 draws)."""
    cells = {(6.0, 10.0): (50, 5, 0.1), (7.0, 10.0): (50, 20, 0.3)}
    h5 = write_cells(tmp_path / "p.h5", cells)
    nu = 0.01
    res = risk.site_risk(site([char_source(6.5, 10.0, rate=nu)]), h5, n_draws=40000, curves=False,
                         uncertainty="beta", rng=4)
    var = sum(stats.beta(k + 0.5, n - k + 0.5).var() for n, k, _ in cells.values())
    sd = (nu / 2) * math.sqrt(var)
    _, lo, hi = res.rate["collapse"]
    assert (hi - lo) / (2 * stats.norm.ppf(0.95)) == pytest.approx(sd, rel=0.05)
    assert res.rate["collapse"][0] == pytest.approx(nu * 0.5 * (5 / 50 + 20 / 50), rel=1e-15)
    # deaggregation: W_ij P_ij / lambda = (1/2 * 5/50, 1/2 * 20/50) / (1/2 * 25/50) = 0.2, 0.8
    assert res.deagg["collapse"][:, 0] == pytest.approx([0.2, 0.8], rel=1e-14)


def test_paired_branches_are_resampled_together(tmp_path):
    """The no-pulse grid reuses the pulse grid's seeds, so row k of a cell in one branch and row k in
    the other are paired. Two branches with the same outcome in every pair (k = 20 of n = 100
    collapses, samples 0-19 in both; the no-pulse file's rows in reverse order) mixed with p = 1/2 have P_mix = P in every joint resample: the 90 %
    interval of lambda is nu times the binomial one, as for one branch (scipy.stats.binom: counts 14
    and 27; tolerance one count, as above). Drawn independently, the two halves would narrow it by
    about 1/sqrt(2), to about counts 15.3 and 24.7: 2.3 counts off at the top."""
    n, k, nu = 100, 20, 0.003
    pulse = write_cells(tmp_path / "p.h5", {(7.0, 10.0): (n, k, 0.2)})
    nopulse = write_cells(tmp_path / "n.h5", {(7.0, 10.0): (n, k, 0.2)}, pulse="none")
    with h5py.File(nopulse, "r+") as f:              # rows in another order: pairs are found by sample number
        for key in list(f["samples"]):
            v = f["samples"][key][...][::-1]
            del f["samples"][key]
            f["samples"][key] = v
    res = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)], pulse={"probability": 0.5}), pulse, nopulse,
                         n_draws=20000, curves=False, rng=1, uncertainty="bootstrap")
    lam, lo, hi = res.rate["collapse"]
    assert lam == pytest.approx(nu * k / n, rel=1e-15)
    q = stats.binom(n, k / n).ppf([0.05, 0.95]) / n
    assert lo == pytest.approx(nu * q[0], abs=nu / n)
    assert hi == pytest.approx(nu * q[1], abs=nu / n)
    assert res.unpaired_cells == 0


def test_paired_beta_draws_keep_jeffreys_margins_and_correlation(tmp_path):
    """uncertainty='beta' with two paired branches: the joint outcomes (both, pulse only, no-pulse only,
    neither) of the n pairs are drawn from Dirichlet(counts + 1/4), whose margins are the Jeffreys
    Beta(k + 1/2, n - k + 1/2) of each branch. Pulse collapses in rows 0-9, no-pulse in rows 0-3:
    counts (4, 6, 0, 30). With p = 0.3, lambda / nu = 0.3 P_p + 0.7 P_n has the variance
    w' Sigma w of the Dirichlet's covariance (closed form); 40 000 draws: the interval's width
    over 2 z_0.95 matches its square root within 5 %, while independent margins would give a
    variance 0.3^2 var_p + 0.7^2 var_n, its sd 18 % smaller (0.0393 against 0.0480)."""
    n, nu, p = 40, 0.003, 0.3
    pulse = write_cells(tmp_path / "p.h5", {(7.0, 10.0): (n, 10, 0.2)})
    nopulse = write_cells(tmp_path / "n.h5", {(7.0, 10.0): (n, 4, 0.2)}, pulse="none")
    res = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)], pulse={"probability": p}), pulse, nopulse,
                         n_draws=40000, curves=False, uncertainty="beta", rng=5)
    alpha = np.array([4, 6, 0, 30]) + 0.25
    a0 = alpha.sum()
    cov = (np.diag(alpha) * a0 - np.outer(alpha, alpha)) / (a0 ** 2 * (a0 + 1))
    w = np.array([p + (1 - p), p, 1 - p, 0.0])           # lambda / nu = w . (D11, D10, D01, D00)
    sd = nu * math.sqrt(w @ cov @ w)
    _, lo, hi = res.rate["collapse"]
    assert (hi - lo) / (2 * stats.norm.ppf(0.95)) == pytest.approx(sd, rel=0.05)
    indep = nu * math.sqrt(p ** 2 * stats.beta(10.5, 30.5).var() + (1 - p) ** 2 * stats.beta(4.5, 36.5).var())
    assert sd > 1.15 * indep


# --------------------------------------------------------------------------- pulse branches

def _two_branches(tmp_path):
    pulse = write_cells(tmp_path / "p.h5", {(7.0, 10.0): (40, 10, 0.3), (7.0, 20.0): (40, 2, 0.1)})
    nopulse = write_cells(tmp_path / "n.h5", {(7.0, 10.0): (40, 1, 0.05), (7.0, 20.0): (40, 0, 0.02)},
                          pulse="none", seed=1)
    return pulse, nopulse


def test_branches_combine_with_the_given_probability(tmp_path):
    """lambda = nu [p P_pulse + (1 - p) P_nopulse] at a grid scenario, for every level."""
    pulse, nopulse = _two_branches(tmp_path)
    nu, p = 0.004, 0.3
    res = risk.site_risk(site([char_source(7.0, 10.0, rate=nu)], pulse={"probability": p}), pulse, nopulse,
                         n_draws=50, curves=False, estimator="eq4", eq4_misfit="warn")
    up, dp, cp = _cell(pulse, 7.0, 10.0)
    un, dn, cn = _cell(nopulse, 7.0, 10.0)
    for q in risk.QUANTITIES:
        if q.level is None:
            e_p, e_n = 10 / 40, 1 / 40
        else:
            e_p = fr.exceedance({"u_top": up, "u_d": dp}[q.edp], cp, q.level.threshold)
            e_n = fr.exceedance({"u_top": un, "u_d": dn}[q.edp], cn, q.level.threshold)
        assert res.rate[q.label][0] == pytest.approx(nu * (p * e_p + (1 - p) * e_n), rel=1e-14), q.label
    assert not res.pulse_only and "PULSE-ONLY" not in risk.report_section(res)


def test_branches_with_shahi_baker_probability(tmp_path):
    """With the Shahi & Baker (2014) model the pulse weight is p(r) at the event's distance: two
    distances on the grid, each weighted by its own p(r)."""
    pulse, nopulse = _two_branches(tmp_path)
    nu = 0.004
    pm = {"model": "shahi_baker_2014", "mechanism": "strike-slip", "s_km": 10.0, "angle_deg": 10.0}
    src = {"name": "f", "rate": nu, "magnitude": {"type": "characteristic", "mw": 7.0},
           "distance": {"type": "discrete", "r_km": [10.0, 20.0], "weights": [0.25, 0.75]}}
    res = risk.site_risk(site([src], pulse=pm), pulse, nopulse, n_draws=50, curves=False)
    p10, p20 = sb14.pulse_probability([10.0, 20.0], 10.0, 10.0, "strike-slip")
    expected = nu * (0.25 * (p10 * 10 / 40 + (1 - p10) * 1 / 40) + 0.75 * (p20 * 2 / 40 + (1 - p20) * 0))
    assert res.rate["collapse"][0] == pytest.approx(expected, rel=1e-14)
    assert res.pulse_share["f"] == pytest.approx(0.25 * p10 + 0.75 * p20, rel=1e-14)


def test_one_branch_is_refused_unless_pulse_only_is_asked(tmp_path):
    pulse, nopulse = _two_branches(tmp_path)
    s = site([char_source(7.0, 10.0)], pulse={"probability": 0.5})
    with pytest.raises(ParameterError, match="only the pulse branch was given.*--no-pulse"):
        risk.site_risk(s, pulse, curves=False)
    res = risk.site_risk(s, pulse, pulse_only=True, n_draws=20, curves=False)   # explicit: allowed, stated
    assert res.pulse_only and "PULSE-ONLY" in risk.report_section(res)
    with pytest.raises(ParameterError, match="declares pulse = 'none'"):
        risk.site_risk(s, nopulse, pulse, curves=False)                     # branches swapped
    with pytest.raises(ParameterError, match="does not declare pulse = 'none'"):
        risk.site_risk(s, pulse, pulse, curves=False)
    with h5py.File(nopulse, "r+") as f:                                       # another solver set-up
        f.attrs["grid_signature"] = json.dumps({"synthetic": True, "solver": {"dt_s": 2e-4}, "pulse": "none"})
    with h5py.File(pulse, "r+") as f:
        f.attrs["grid_signature"] = json.dumps({"synthetic": True, "solver": {"dt_s": 1e-4}})
    with pytest.raises(ParameterError, match=r"differ in solver \(solver: \{'dt_s': 0\.0001\} against "
                                             r"\{'dt_s': 0\.0002\}\)"):
        risk.site_risk(s, pulse, nopulse, curves=False)
    with pytest.raises(ParameterError, match="every source is pulse-only"):
        risk.site_risk(site([char_source(7.0, 10.0)]), pulse, nopulse, curves=False)
    with pytest.raises(ParameterError, match="no pulse model"):
        site([char_source(7.0, 10.0)], pulse=None)


def test_shahi_baker_2014_values():
    """P(pulse) = 1 / (1 + exp(c0 + c1 r - c2 sqrt(s) + c3 angle)); the expected values are that
    formula with the coefficients of SimCenter smelt's implementation (strike-slip 0.457, 0.126,
    0.244, 0.013; non-strike-slip 0.304, 0.072, 0.208, 0.021), evaluated by hand here:
    strike-slip r = 0, s = 0, theta = 0: 1 / (1 + e^0.457) = 0.387698...;
    strike-slip r = 5, s = 16, theta = 10: exponent 0.457 + 0.63 - 0.976 + 0.13 = 0.241 -> 0.440040...;
    non-strike-slip r = 10, d = 9, phi = 45: exponent 0.304 + 0.72 - 0.624 + 0.945 = 1.345 -> 0.206689...
    (The paper's own figures could not be read here; see the module docstring.)"""
    assert sb14.pulse_probability(0, 0, 0) == pytest.approx(1 / (1 + math.exp(0.457)), rel=1e-15)
    assert sb14.pulse_probability(0, 0, 0) == pytest.approx(0.3876977, abs=5e-7)
    assert sb14.pulse_probability(5, 16, 10, "strike-slip") == pytest.approx(0.4400399, abs=5e-7)
    assert sb14.pulse_probability(10, 9, 45, "non-strike-slip") == pytest.approx(0.2066890, abs=5e-7)
    p = sb14.pulse_probability(np.array([0.0, 5, 10, 20, 30]), 10.0, 20.0)
    assert np.all(np.diff(p) < 0)                               # fewer pulses farther away
    with pytest.raises(ParameterError, match="angle_deg"):
        sb14.pulse_probability(5, 5, 95)
    with pytest.raises(ParameterError, match="mechanism"):
        sb14.pulse_probability(5, 5, 5, "normal")


# --------------------------------------------------------------------------- site files

GOOD = {"name": "f", "rate": 0.01, "magnitude": {"type": "gutenberg-richter", "b": 1.0, "m_min": 5.5, "m_max": 7.0},
        "distance": {"type": "uniform", "min_km": 5.0, "max_km": 20.0}}


def _with(path, value):
    d = json.loads(json.dumps(GOOD))
    node = d
    for k in path[:-1]:
        node = node[k]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return d


@pytest.mark.parametrize("src, match", [
    (_with(["rate"], -0.1), r"sources\[0\]\.rate must be >= 0, got -0\.1"),
    (_with(["magnitude", "m_max"], 5.0), r"m_max = 5 must be > m_min = 5\.5"),
    (_with(["magnitude", "b"], 0.0), r"magnitude\.b must be in \(0, 5\], got 0"),
    (_with(["magnitude", "type"], "GR"), r"magnitude\.type must be .* got 'GR'"),
    (_with(["magnitud"], {}), r"unknown key\(s\) 'magnitud'"),
    (_with(["distance", "max_km"], 4.0), r"max_km = 4 must be > min_km = 5"),
    (_with(["distance"], {"type": "discrete", "r_km": [5, 10], "weights": [0.5, 0.4]}), r"weights must sum to 1.*0\.9"),
    (_with(["distance"], {"type": "fixed", "r_km": -3}), r"r_km must be in \(0, 20000\], got -3"),
    (_with(["distance"], KeyError), r"missing 'distance'"),
    (_with(["pulse"], {"probability": 1.5}), r"pulse\.probability must be in \[0, 1\], got 1\.5"),
    (_with(["pulse"], {"model": "shahi_baker_2014", "mechanism": "strike-slip", "s_km": 5, "angle_deg": 120}),
     r"angle_deg must be in \[0, 90\], got 120"),
    (_with(["rate"], "often"), r"rate must be a finite number, got 'often'"),
    (_with(["pulse"], {"model": "shahi_baker_2014", "mechanism": "strike-slip", "s_km": 5, "angle_deg": 10,
                       "probability": 0.3}), r"pulse: unknown key\(s\) 'probability'"),
])
def test_bad_source_is_refused_naming_the_value(src, match):
    with pytest.raises(ParameterError, match=match):
        site([src])


def test_bad_site_level_values_and_file_name(tmp_path):
    with pytest.raises(ParameterError, match=r"outside must be one of refuse, clamp, zero, got 'drop'"):
        site([GOOD], outside="drop")
    with pytest.raises(ParameterError, match=r"unknown key\(s\) 'sites'"):
        site_file.site_from_dict({"sites": [], "pulse": {"probability": 0.5}})
    with pytest.raises(ParameterError, match=r"years must be > 0, got -50"):
        site([GOOD], years=[-50])
    with pytest.raises(ParameterError, match=r"sources\[1\]\.name 'f' is the name of an earlier source"):
        site([GOOD, GOOD])                     # the outputs are keyed by source name: one would vanish
    p = tmp_path / "bad_site.toml"
    p.write_text('[pulse]\nprobability = 0.5\n[[sources]]\nname = "x"\nrate = -1\n'
                 'magnitude = { type = "characteristic", mw = 6.0 }\ndistance = { type = "fixed", r_km = 10 }\n')
    with pytest.raises(ParameterError, match=r"bad_site\.toml: sources\[0\]\.rate must be >= 0, got -1"):
        site_file.load_site(p)


def test_example_site_file_reads():
    from pathlib import Path
    s = site_file.load_site(Path(__file__).resolve().parents[1] / "examples" / "site_athens.toml")
    assert len(s.sources) >= 2 and all(src.rate > 0 for src in s.sources)


# --------------------------------------------------------------------------- command

def test_command_writes_markdown_json_and_figures(tmp_path):
    pulse, nopulse = _two_branches(tmp_path)
    sf = tmp_path / "site.toml"
    sf.write_text('name = "cmd"\nyears = [30]\n[pulse]\nprobability = 0.4\n[[sources]]\nname = "f"\nrate = 0.01\n'
                  'magnitude = { type = "characteristic", mw = 7.0 }\n'
                  'distance = { type = "uniform", min_km = 10, max_km = 20 }\n')
    out = tmp_path / "out"
    assert risk.main([str(sf), pulse, str(out), "--no-pulse", nopulse, "--draws", "50", "--years", "200"]) == 0
    md = (out / "risk.md").read_text()
    assert "P in 30 yr" in md and "P in 200 yr" in md and "P in 475 yr" in md and "risk_curves.png" in md
    js = json.loads((out / "risk.json").read_text())
    assert js["branches"] == ["pulse", "no-pulse"] and not js["pulse_only"]
    lam = js["rate_per_year"]["collapse"][0]
    assert js["probability"]["50"]["collapse"][0] == pytest.approx(1 - math.exp(-50 * lam), rel=1e-14)
    for edp in ("u_top", "u_d"):                                    # a rate of exceeding x falls with x
        assert np.all(np.diff(js["curves"][edp]["rate"]) <= 0)
    for stem in ("risk_curves", "risk_deaggregation", "risk_probability"):
        assert (out / f"{stem}.png").stat().st_size > 10_000


def test_command_refuses_a_bad_site_file_with_its_message(tmp_path, capsys):
    """A bad value ends the command with exit status 2 and the message naming it, not a traceback."""
    pulse, _ = _two_branches(tmp_path)
    sf = tmp_path / "bad.toml"
    sf.write_text('[pulse]\nprobability = 0.4\n[[sources]]\nname = "f"\nrate = -0.01\n'
                  'magnitude = { type = "characteristic", mw = 7.0 }\ndistance = { type = "fixed", r_km = 10 }\n')
    assert risk.main([str(sf), pulse, str(tmp_path / "out"), "--draws", "20", "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "bad.toml: sources[0].rate must be >= 0, got -0.01" in err
    assert not (tmp_path / "out").exists()


def test_command_says_what_lies_outside_the_grid(tmp_path, capsys):
    """The part of a source outside the simulated range is printed, not only written to the files:
    R uniform on [5, 20] km over a grid of R 10-20 km leaves (10 - 5) / 15 = 33.3 % below it."""
    pulse, nopulse = _two_branches(tmp_path)
    sf = tmp_path / "site.toml"
    sf.write_text('outside = "zero"\n[pulse]\nprobability = 0.4\n[[sources]]\nname = "near"\nrate = 0.01\n'
                  'magnitude = { type = "characteristic", mw = 7.0 }\n'
                  'distance = { type = "uniform", min_km = 5, max_km = 20 }\n')
    assert risk.main([str(sf), pulse, str(tmp_path / "out"), "--no-pulse", nopulse, "--draws", "20",
                      "--no-figures"]) == 0
    out = capsys.readouterr().out
    assert "near: 33.3 % of its rate lies outside the simulated range" in out and "R below 33.3 %" in out
    assert "treated as 'zero'" in out


def test_report_carries_the_risk_section(tmp_path):
    from pycolfrag.analysis import report
    from test_figures import write_results
    h5 = write_results(tmp_path / "g.h5")
    with h5py.File(h5, "r+") as f:                   # a finished grid's file (the risk refuses others)
        f.attrs["complete"] = True
    res = risk.site_risk(site([char_source(7.0, 10.0)]), h5, n_draws=20, curves=False)
    text = open(report.write_report(h5, tmp_path / "r.md", n_boot=20, risk=res)).read()
    assert "## Site risk: test site" in text and "PULSE-ONLY" in text
    assert text.index("## Site risk") < text.index("## Figures")
