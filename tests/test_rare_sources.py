"""A new site source type serves both risk routes with its one class: the rare route stratifies any
:class:`pycolfrag.site.sources.SiteSource` through the interface (``cells``, from the source's own
``quadrature`` by default: :mod:`pycolfrag.site.cells`), assuming neither independent magnitude and
distance models nor anything else of the shipped type.

The toy type (tests/toy_sources.py) is registered from this test (no package file names it): G-R magnitudes and a distance
that falls with the magnitude, R = r0 - k (Mw - 5.5), so Mw and R are not independent. References:
scipy.integrate.quad of the closed-form G-R density times p(R(m)) (the pulse-occurrence model's own
curve), and the toy's own relation R(m) for the placed events.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

import toy_sources
from pycolfrag.grid import EventBatchSpec
from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL
from pycolfrag.rare.plans import PulseMap, interleave, plan_inputs
from pycolfrag.rare.proposal import PILOT_MIXTURE
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk import grid_route as risk
from pycolfrag.site import models
from pycolfrag.site import sources as site_file

PULSE = {"model": "shahi_baker_2014", "mechanism": "non-strike-slip", "s_km": 5.0, "angle_deg": 30.0}
NU, R0, K = 0.02, 18.0, 6.0


@pytest.fixture
def toy_site():
    with toy_sources.registered() as toy:
        yield site_file.site_from_dict({"pulse": PULSE, "sources": [
            {"type": toy, "name": "fault", "rate": NU, "r0_km": R0, "k": K}]}, "toy.toml")


def _reference(site, f, branch: bool) -> float:
    """nu int f(m, r(m)) g(r(m)) pdf(m) dm, g = p (pulse) or 1 - p, by scipy's adaptive quadrature."""
    src = site.sources[0]

    def g(m):
        r = src.r_of(m)
        p = float(np.asarray(src.pulse.mean_probability(np.array([r])))[0])
        return f(m, r) * (p if branch else 1.0 - p) * float(src.gr.pdf(m))
    return NU * integrate.quad(g, 5.5, 7.5, limit=200, epsabs=1e-15, epsrel=1e-12)[0]


def test_the_grid_routes_set_up_takes_the_toy(toy_site):
    mws, ds = np.array([5.5, 6.5, 7.5]), np.array([5.0, 10.0, 20.0])
    W, _, rep = risk.node_weights(toy_site.sources, mws, ds)
    assert W.sum() == pytest.approx(NU, rel=1e-12) and rep[0].outside == 0.0


def test_the_rare_routes_strata_are_the_toys_joint_events(toy_site):
    """Every stratum's events lie on the toy's curve R(m); the strata's rates per branch are the integrals
    of the joint density (rel 1e-9: the G-R quadrature, 12 Gauss-Legendre points per piece, is exact to
    about 1e-10 for the smooth p(R(m))); a stratified estimate of the rate-weighted mean of exp(-R / 5 km)
    per branch (2000 placements per stratum, occurrence-weighted) is within 4 standard errors of its
    integral (a smooth function: the cells' events are the quadrature's nodes, exact for it to ~1e-10)."""
    st = build_strata(toy_site, mw_step=0.25)
    assert len(st) > 0 and not any(o.outside for o in st.outside)
    for branch in (False, True):
        rates = sum(s.rate for s in st.strata if s.pulse == branch)
        assert rates == pytest.approx(_reference(toy_site, lambda m, r: 1.0, branch), rel=1e-9)
    rng = np.random.default_rng(11)
    est, var = {False: 0.0, True: 0.0}, {False: 0.0, True: 0.0}
    for h, s in enumerate(st.strata):
        mr = np.array([st.place(h, a, b) for a, b in rng.standard_normal((2000, 2))])
        assert np.allclose(mr[:, 1], R0 - K * (mr[:, 0] - 5.5), rtol=0, atol=1e-12)   # on the source's curve
        assert np.all((mr[:, 0] >= s.mw[0]) & (mr[:, 0] <= s.mw[1]))
        y = np.asarray(st.occurrence_weight(h, mr[:, 1])) * np.exp(-mr[:, 1] / 5.0)
        est[s.pulse] += s.rate * y.mean()
        var[s.pulse] += s.rate ** 2 * y.var() / y.size
    for branch in (False, True):
        ref = _reference(toy_site, lambda m, r: math.exp(-r / 5.0), branch)
        assert est[branch] == pytest.approx(ref, abs=4 * math.sqrt(var[branch]) + 1e-9 * ref)


def test_the_rare_routes_plans_run_the_toys_events(toy_site):
    """A pilot batch of two runs per stratum: inputs a batch of events takes (the grid's set-up of the
    rare route's runs), each event on the toy's curve, the pulse ones with the pulse shape's inputs."""
    st = build_strata(toy_site, mw_step=0.25)
    runs = interleave({h: 2 for h in range(len(st))}, {})
    inputs = plan_inputs(st, 5, 0, runs, PILOT_MIXTURE, PulseMap("mp03", 1.0, DEFAULT_TP_MODEL))
    assert len(inputs) == 2 * len(st)
    for x in inputs:
        assert x["dist_km"] == pytest.approx(R0 - K * (x["mw"] - 5.5), abs=1e-12)
        assert (x["pulse"] is not None) == bool(st[x["tags"]["stratum"]].pulse)
    spec = EventBatchSpec(inputs=inputs, purpose={"test": "toy source"})
    assert spec.n_rows == len(inputs)


class PlainFault(site_file.SiteSource):   # a SiteSource that is not a dataclass
    """The toy's events from a plain class: it says itself how it takes another pulse model."""

    KEYS = ("r0_km", "k")

    def __init__(self, name, rate, pulse, r0, k):
        self.name, self.rate, self.pulse, self._toy = name, rate, pulse, toy_sources.NearerWhenLarger(
            name, rate, pulse, models.GutenbergRichter(1.0, 5.5, 7.5), r0, k)

    @classmethod
    def from_table(cls, t, name, rate, pulse):
        return cls(name, rate, pulse, t.number("r0_km"), t.number("k"))

    def with_pulse(self, pulse):
        return PlainFault(self.name, self.rate, pulse, self._toy.r0, self._toy.k)

    def quadrature(self, mw_breaks=(), r_breaks=()):
        return self._toy.with_pulse(self.pulse).quadrature(mw_breaks, r_breaks)

    def sample(self, n, rng):
        return self._toy.with_pulse(self.pulse).sample(n, rng)

    def describe(self):
        return "plain " + self._toy.describe()


def test_both_routes_replace_the_pulse_model_through_the_interface(tmp_path):
    """``--pulse-only`` of the rare route (``risk.simulate.site_of``) and of the grid route
    (``risk.site_risk``'s reader) ask the source for itself with the other model: a source that is not a
    dataclass takes it too, and its strata are then the pulse branch alone."""
    from argparse import Namespace

    from pycolfrag.risk import simulate
    from pycolfrag.site.models import PulseOnly
    site_file.source_type("plain-fault")(PlainFault)
    try:
        path = tmp_path / "plain.toml"
        path.write_text('[pulse]\nprobability = 0.3\n[[sources]]\ntype = "plain-fault"\nname = "f"\nrate = 0.02\n'
                        'r0_km = 18.0\nk = 6.0\n')
        site = simulate.site_of(Namespace(site=str(path), pulse_model=None, pulse_only=True, outside=None))
        assert isinstance(site.sources[0], PlainFault) and isinstance(site.sources[0].pulse, PulseOnly)
        grid_site = risk._resolve_site(str(path), True, "{probability = 0.5}", None, ())
        assert isinstance(grid_site.sources[0].pulse, PulseOnly)
        st = build_strata(site, mw_step=0.25)
        assert all(s.pulse for s in st.strata) and sum(s.rate for s in st.strata) == pytest.approx(NU, rel=1e-12)
    finally:
        del site_file.SOURCE_TYPES["plain-fault"]
