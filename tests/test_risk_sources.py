"""Site sources as classes (pycolfrag.site.sources, pycolfrag.site.models): joint (Mw, R) events, random draws,
the pulse-occurrence branches, and the site file's reading and range checks.

Expected numbers come from closed forms and from scipy.integrate.quad/dblquad of the closed-form
densities; tolerances are stated where they are not exact.
"""
import math
import os

import numpy as np
import pytest
from scipy import integrate

import toy_sources
from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import shahi_baker_2014 as sb14
from pycolfrag.ground_motion import shahi_baker_earlier as sbe
from pycolfrag.risk import site_risk as risk
from pycolfrag.site import models
from pycolfrag.site import sources as site_file

GOOD = {"name": "f", "rate": 0.01, "magnitude": {"type": "gutenberg-richter", "b": 1.0, "m_min": 5.5, "m_max": 7.0},
        "distance": {"type": "uniform", "min_km": 5.0, "max_km": 20.0}}


def _site(sources, pulse=None, **kw):
    return site_file.site_from_dict({"sources": sources, "pulse": pulse or {"model": "pulse-only"}, **kw})


# --------------------------------------------------------------------------- a source whose R depends on Mw

@pytest.fixture
def toy_type():
    with toy_sources.registered() as toy:
        yield toy


def test_a_source_whose_distance_depends_on_magnitude_is_one_class(toy_type):
    """lambda = nu int P(m, r(m)) f(m) dm for P = a + b Mw + c ln R + d Mw ln R (reproduced exactly by
    the bilinear interpolation), r(m) = 18 - 6 (m - 5.5): scipy.integrate.quad of the closed-form
    G-R pdf, rel 1e-9 (the module's breaks put nodes at the grid's Mw, but r(m) crosses the R nodes
    between them: a kink inside a segment, which 12 Gauss-Legendre points integrate to about 1e-10).
    Taking Mw and R independent with the same marginals gives another number (7 % off): the risk
    uses the joint events."""
    s = _site([{"type": toy_type, "name": "fault", "rate": 0.02, "r0_km": 18.0, "k": 6.0}])
    mws, ds = np.array([5.5, 6.0, 6.5, 7.0, 7.5]), np.array([5.0, 10.0, 15.0, 20.0])
    M, R = np.meshgrid(mws, ds, indexing="ij")
    P = lambda m, r: 0.01 + 0.05 * (m - 5.5) - 0.03 * np.log(r / 5) + 0.02 * (m - 5.5) * np.log(r / 5)
    W, _, rep = risk.node_weights(s.sources, mws, ds)
    gr, nu = models.GutenbergRichter(1.0, 5.5, 7.5), 0.02
    expected = nu * integrate.quad(lambda m: P(m, 18 - 6 * (m - 5.5)) * gr.pdf(m), 5.5, 7.5, limit=200,
                                   epsabs=1e-15, epsrel=1e-13)[0]
    assert np.sum(W * P(M, R)) == pytest.approx(expected, rel=1e-9)
    assert rep[0].outside == 0.0
    indep = nu * integrate.dblquad(lambda r, m: P(m, r) * gr.pdf(m) * gr.pdf(5.5 + (18 - r) / 6) / 6,
                                   5.5, 7.5, 6.0, 18.0)[0]
    assert abs(indep / expected - 1) > 0.05


def test_random_events_agree_with_the_quadrature(toy_type):
    """The same integral from 200 000 random events of each source (weights rate/n): within 4 standard
    errors of the mean (their standard deviation over the events, estimated from the draws)."""
    rng = np.random.default_rng(7)
    mws, ds = np.array([5.5, 6.5, 7.5]), np.array([5.0, 10.0, 20.0])
    P = lambda m, r: 0.01 + 0.05 * (m - 5.5) - 0.03 * np.log(r / 5)
    for spec in (GOOD, {"type": toy_type, "name": "t", "rate": 0.02, "r0_km": 18.0, "k": 6.0}):
        src = _site([spec]).sources[0]
        W, _, _ = risk.node_weights([src], mws, ds)
        M, R = np.meshgrid(mws, ds, indexing="ij")
        ev = src.sample(200_000, rng)
        vals = ev.weight * P(ev.mw, ev.r_km)
        assert np.all(ev.weight == src.rate / 200_000) and len(ev) == 200_000
        assert np.sum(vals) == pytest.approx(np.sum(W * P(M, R)), abs=4 * np.std(vals) * math.sqrt(len(ev)))


def test_gutenberg_richter_draws_follow_the_truncated_density():
    """The inverse CDF: the draws' mean against the closed-form mean of the truncated exponential,
    m0 + 1/beta - D e^{-beta D} / (1 - e^{-beta D}) (D = m1 - m0); 4 standard errors."""
    gr = models.GutenbergRichter(1.2, 5.0, 7.5)
    m = gr.sample(100_000, np.random.default_rng(3))
    beta, D = gr.beta, 2.5
    mean = 5.0 + 1 / beta - D * math.exp(-beta * D) / (1 - math.exp(-beta * D))
    assert m.min() >= 5.0 and m.max() <= 7.5
    assert m.mean() == pytest.approx(mean, abs=4 * m.std() / math.sqrt(m.size))


def test_a_tiny_b_value_is_the_uniform_limit_not_infinity():
    """b = 1e-18: 1 - e^{-beta D} rounds to 0 in floating point (the old density was inf); with expm1
    the density is the uniform 1/D it tends to. On P linear in Mw (exact under interpolation) lambda =
    nu P(mean Mw) = nu (0.1 + 0.2 (6.5 - 5.5))."""
    s = _site([{**GOOD, "magnitude": {"type": "gutenberg-richter", "b": 1e-18, "m_min": 5.5, "m_max": 7.5},
                "distance": {"type": "fixed", "r_km": 10.0}}])
    mws, ds = np.array([5.5, 7.5]), np.array([10.0])
    W, _, _ = risk.node_weights(s.sources, mws, ds)
    P = np.array([[0.1], [0.5]])
    assert np.sum(W * P) == pytest.approx(0.01 * (0.1 + 0.2 * 1.0), rel=1e-12)


def test_b_value_of_5_is_integrated_to_round_off():
    """The largest b accepted: on one segment of two magnitude units (grid Mw 5.5 and 7.5), where the
    density falls by 1e10, the G-R integral of a linear P against its closed form (test_risk's
    formula), rel 1e-12 (12 points on the whole segment, without the pieces, are 5e-9 off)."""
    b, m0, m1 = 5.0, 5.5, 7.5
    beta = b * math.log(10)
    C = -math.expm1(-beta * (m1 - m0))
    F = lambda m, al, g: -(al + g * m + g / beta) * math.exp(-beta * (m - m0))
    g = 0.4 / 2.0
    expected = (F(m1, 0.1 - g * 5.5, g) - F(m0, 0.1 - g * 5.5, g)) / C
    W, _, _ = risk.node_weights(_site([{**GOOD, "magnitude": {"type": "gutenberg-richter", "b": b, "m_min": m0,
                                                              "m_max": m1}}]).sources,
                                np.array([5.5, 7.5]), np.array([5.0, 20.0]))
    assert np.sum(W.sum(axis=1) * np.array([0.1, 0.5])) == pytest.approx(0.01 * expected, rel=1e-12)


@pytest.mark.parametrize("path, value, match", [
    (["magnitude", "b"], 5.5, r"magnitude\.b must be in \(0, 5\], got 5\.5"),
    (["magnitude", "m_max"], 11.0, r"magnitude\.m_max must be in \[0, 10\], got 11"),
    (["distance", "max_km"], 1e200, r"distance\.max_km must be in \(0, 20000\], got 1e\+200"),
    (["distance", "min_km"], float("nan"), r"distance\.min_km must be a finite number, got nan"),
])
def test_absurd_values_are_refused_naming_them(path, value, match):
    spec = {k: (dict(v) if isinstance(v, dict) else v) for k, v in GOOD.items()}
    spec[path[0]][path[1]] = value
    with pytest.raises(ParameterError, match=match):
        _site([spec])


# --------------------------------------------------------------------------- pulse occurrence

def test_pulse_geometry_drawn_per_event_is_averaged_for_the_grid():
    """d uniform on [0, 10] km and phi on [0, 90] degrees per event: the grid's p(r) is the mean of
    the 2014 model over them (scipy dblquad, 1e-12 absolute: 12 Gauss-Legendre points in sqrt(d) and
    in phi are exact to round-off for this smooth integrand); random events' p average to it
    (100 000 draws, 4 standard errors)."""
    s = _site([{**GOOD, "distance": {"type": "fixed", "r_km": 17.5}}],
              pulse={"model": "shahi_baker_2014", "mechanism": "non-strike-slip",
                     "s_km": {"min": 0.0, "max": 10.0}, "angle_deg": {"min": 0.0, "max": 90.0}})
    src = s.sources[0]
    ref = integrate.dblquad(lambda a, d: sb14.pulse_probability(17.5, d, a, "non-strike-slip"), 0, 10, 0, 90,
                            epsabs=1e-14, epsrel=1e-13)[0] / 900
    assert src.quadrature([5.5, 7.0], [5.0, 20.0]).p_pulse == pytest.approx(ref, abs=1e-12)
    ev = src.sample(100_000, np.random.default_rng(1))
    assert set(ev.geometry) == {"s_km", "angle_deg"} and 0 <= ev.geometry["angle_deg"].min()
    assert ev.p_pulse.mean() == pytest.approx(ref, abs=4 * ev.p_pulse.std() / math.sqrt(len(ev)))
    fixed = sb14.pulse_probability(17.5, 5.0, 30.0, "non-strike-slip")
    assert ref < fixed                          # phi beyond 30 degrees half the time: fewer pulses
    assert "drawn per event" in src.pulse.describe()


def test_earlier_shahi_baker_model_values_and_branch():
    """The earlier model's logistic with (1.483, 0.124, 0.688, 0.022), by hand: r 17.5, d 5, phi 30:
    exponent 1.483 + 2.17 - 0.688 sqrt(5) + 0.66 = 2.7745852 -> 0.058713; the 2014 model gives 0.150729
    there. It knows no strike-slip fit and says so."""
    assert sbe.pulse_probability(17.5, 5.0, 30.0) == pytest.approx(1 / (1 + math.exp(2.7745852)), rel=1e-7)
    assert sbe.pulse_probability(17.5, 5.0, 30.0) == pytest.approx(0.058713, abs=5e-7)
    assert sb14.pulse_probability(17.5, 5.0, 30.0, "non-strike-slip") == pytest.approx(0.150729, abs=5e-7)
    with pytest.raises(ParameterError, match="strike-slip coefficients are not known"):
        sbe.pulse_probability(17.5, 5.0, 30.0, "strike-slip")
    s = _site([GOOD], pulse={"model": "shahi_baker_earlier", "mechanism": "non-strike-slip", "s_km": 5.0,
                             "angle_deg": 30.0})
    assert "earlier Shahi & Baker" in s.sources[0].pulse.describe()
    with pytest.raises(ParameterError, match=r"mechanism must be one of non-strike-slip for shahi_baker_earlier"):
        _site([GOOD], pulse={"model": "shahi_baker_earlier", "mechanism": "strike-slip", "s_km": 5.0,
                             "angle_deg": 30.0})


def test_registries_name_every_model():
    assert set(models.MAGNITUDE_MODELS) == {"gutenberg-richter", "characteristic"}
    assert set(models.DISTANCE_MODELS) == {"fixed", "uniform", "area", "discrete"}
    assert {"probability", "pulse-only", "shahi_baker_2014", "shahi_baker_earlier"} <= set(models.PULSE_MODELS)
    assert site_file.SOURCE_TYPES[site_file.DEFAULT_SOURCE_TYPE] is site_file.MagnitudeDistanceSource
    with pytest.raises(ParameterError,
                       match=r"sources\[0\]\.type must be one of .*'magnitude-distance'.*, got 'fault'"):
        _site([{**GOOD, "type": "fault"}])
    with pytest.raises(ParameterError, match=r"pulse\.model must be one of .*'shahi_baker_earlier'.* got 'sb'"):
        _site([GOOD], pulse={"model": "sb"})


# --------------------------------------------------------------------------- reading the file

def test_site_file_is_read_by_the_input_file_policy(tmp_path):
    """A FIFO (which would block a plain open), a folder and non-UTF-8 bytes are refused with what
    they are; the reader never opens the FIFO for reading."""
    fifo = tmp_path / "site.fifo"
    os.mkfifo(fifo)
    with pytest.raises(ParameterError, match=r"site file .*site\.fifo is a FIFO"):
        site_file.load_site(fifo)
    with pytest.raises(ParameterError, match=r"site file .* is a folder"):
        site_file.load_site(tmp_path)
    bad = tmp_path / "latin1.toml"
    bad.write_bytes('name = "Akr\u00f3polis"\n'.encode("latin-1"))
    with pytest.raises(ParameterError, match=r"latin1\.toml is not UTF-8 text \(byte 11 is 0xf3\)"):
        site_file.load_site(bad)
    with pytest.raises(ParameterError, match=r"site file .*none\.toml does not exist"):
        site_file.load_site(tmp_path / "none.toml")
