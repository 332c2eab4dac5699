"""A toy site source type for the tests of both risk routes (tests/test_risk_sources.py,
tests/test_rare_sources.py): G-R magnitudes 5.5-7.5 (b = 1) and a distance that falls with the
magnitude, R = r0 - k (Mw - 5.5), so that Mw and R are not independent. No package file names it: a
test registers it for its own duration (:func:`registered`)."""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from pycolfrag.site import models
from pycolfrag.site import sources as site_file

#: The type name the toy is registered under.
TYPE = "nearer-when-larger"


@dataclass(frozen=True)
class NearerWhenLarger(site_file.SiteSource):
    """G-R magnitudes 5.5-7.5 (b = 1), R = r0 - k (m - 5.5): larger ruptures come closer to the site."""

    name: str
    rate: float
    pulse: object
    gr: object
    r0: float
    k: float
    KEYS = ("r0_km", "k")

    @classmethod
    def from_table(cls, t, name, rate, pulse):
        return cls(name, rate, pulse, models.GutenbergRichter(1.0, 5.5, 7.5), t.number("r0_km"), t.number("k"))

    def r_of(self, m):
        return self.r0 - self.k * (np.asarray(m) - self.gr.m_min)

    def quadrature(self, mw_breaks=(), r_breaks=()):
        m, w = self.gr.points(mw_breaks)
        r = self.r_of(m)
        return site_file.Events(m, r, self.rate * w, self.pulse.mean_probability(r))

    def sample(self, n, rng):
        m = self.gr.sample(n, rng)
        r = self.r_of(m)
        p, geometry = self.pulse.draw(r, rng)
        return site_file.Events(m, r, np.full(n, self.rate / n), p, geometry)

    def describe(self):
        return f"toy: R = {self.r0:g} - {self.k:g} (Mw - 5.5) km"


@contextmanager
def registered():
    """The toy registered as :data:`TYPE` while the block runs (the type name is yielded)."""
    site_file.source_type(TYPE)(NearerWhenLarger)
    try:
        yield TYPE
    finally:
        del site_file.SOURCE_TYPES[TYPE]
