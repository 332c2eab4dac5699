"""Aftershocks of a sequence's mainshocks: the Reasenberg & Jones (1989) model (docs/sequences.md, "Aftershocks").

Reasenberg, P. A. & Jones, L. M. (1989), "Earthquake hazard after a mainshock in California", Science 243
(4895): 1173-1176, doi:10.1126/science.243.4895.1173. The rate of aftershocks of magnitude M or larger t days
after a mainshock of magnitude Mm is the modified Omori law (Utsu 1961) times the Gutenberg-Richter law::

    lambda(t, M) = 10 ** (a + b (Mm - M)) (t + c) ** -p

with the paper's *generic California* parameters a = -1.67, b = 0.91, p = 1.08, c = 0.05 days (the values the
USGS's aftershock forecasts used for three decades; their provenance is restated by Hardebeck et al. 2018,
"Updated California aftershock parameters", Seismol. Res. Lett. 90(1): 262-270, doi:10.1785/0220180240, whose
abstract says the generic productivity is higher than the sequences since 1980 give: these parameters are, if
anything, productive). No Greek parametrisation of the same form was found (the search is in docs/sequences.md);
the generic Californian one is used as the published default, and every parameter is a field.

The expected number of aftershocks of magnitude >= M in [t1, t2] days is the closed form

    N = 10 ** (a + b (Mm - M)) [ (t1 + c) ** (1 - p) - (t2 + c) ** (1 - p) ] / (p - 1)     (p != 1)

(``ln((t2 + c) / (t1 + c))`` at p = 1). A mainshock's aftershocks are drawn as that Poisson process over
``window_days`` with magnitudes >= ``m_min``: their count Poisson(N), their times by the inverse of the Omori
law's distribution over the window, their magnitudes by Gutenberg-Richter's exponential of slope b above
``m_min`` (no upper bound: the model does not bound an aftershock by its mainshock; one larger than the
mainshock occurs with the paper's probability, and the ground-motion models' range drops what lies beyond it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pycolfrag.core.errors import ParameterError

#: Days in a (Julian) year: the aftershocks' clock (days) against the sequences' (years).
DAYS_PER_YEAR = 365.25

__all__ = ["Aftershocks", "REASENBERG_JONES_1989", "DAYS_PER_YEAR"]


@dataclass(frozen=True)
class Aftershocks:
    """The Reasenberg & Jones (1989) aftershock rate (see the module's text): ``a``, ``b``, ``p``, ``c_days``, the
    smallest aftershock drawn ``m_min`` and the window after each mainshock ``window_days``."""

    a: float = -1.67
    b: float = 0.91
    p: float = 1.08
    c_days: float = 0.05
    m_min: float = 5.0
    window_days: float = DAYS_PER_YEAR

    def __post_init__(self):
        for name in ("a", "b", "p", "c_days", "m_min", "window_days"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(f"aftershocks: {name} must be a finite number, got {v!r}")
        for name in ("b", "p", "c_days", "window_days"):
            if getattr(self, name) <= 0:
                raise ParameterError(f"aftershocks: {name} must be > 0, got {getattr(self, name)!r}")

    def _omori(self, t1: float, t2: float) -> float:
        """The integral of (t + c) ** -p over [t1, t2] days."""
        c, p = self.c_days, self.p
        if p == 1.0:
            return math.log((t2 + c) / (t1 + c))
        return ((t1 + c) ** (1.0 - p) - (t2 + c) ** (1.0 - p)) / (p - 1.0)

    def expected(self, mw_main: float, t1_days: float = 0.0, t2_days: float | None = None,
                 m: float | None = None) -> float:
        """The expected number of aftershocks of magnitude >= ``m`` (default ``m_min``) in [t1, t2] days (default:
        the window) after a mainshock of ``mw_main``: the closed form of the module's text."""
        t2 = self.window_days if t2_days is None else t2_days
        if not 0.0 <= t1_days <= t2:
            raise ParameterError(f"aftershocks: the window [{t1_days!r}, {t2!r}] days is not 0 <= t1 <= t2")
        m = self.m_min if m is None else m
        return 10.0 ** (self.a + self.b * (mw_main - m)) * self._omori(t1_days, t2)

    def sample(self, mw_main: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(times in days after the mainshock, sorted; magnitudes) of one mainshock's aftershocks >= ``m_min``."""
        n = int(rng.poisson(self.expected(mw_main)))
        u, v = rng.uniform(size=n), rng.uniform(size=n)
        c, p, w = self.c_days, self.p, self.window_days
        if p == 1.0:
            t = c * ((w + c) / c) ** u - c
        else:
            lo, hi = c ** (1.0 - p), (w + c) ** (1.0 - p)
            t = (lo + u * (hi - lo)) ** (1.0 / (1.0 - p)) - c
        mags = self.m_min - np.log10(1.0 - v) / self.b
        order = np.argsort(t, kind="stable")
        return np.clip(t[order], 0.0, w), mags[order]


#: The paper's generic California parameters, aftershocks of Mw >= 5 within a year.
REASENBERG_JONES_1989 = Aftershocks()
