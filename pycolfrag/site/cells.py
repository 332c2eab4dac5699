"""A site source's events cut into cells: what the rare route stratifies (:mod:`pycolfrag.rare.strata`).

A :class:`Cell` is the part of one source's events in a magnitude bin and a distance bin, with the
annual rate of its events with and without a velocity pulse (the source's rate times the quadrature
of its density times p(R) or 1 - p(R) over the cell), the cell's mean of p or 1 - p, and how an event
of the cell is placed from two standard normals (its Mw and R). A source gives its cells through the
one interface of :class:`pycolfrag.site.sources.SiteSource` (``cells``), in two ways:

* :func:`quadrature_cells`, every source's default: the source's own ``quadrature`` events (the
  nodes and weights the grid route sums) grouped by the bins; a cell's events are its nodes, drawn with
  probability proportional to their weights. The rare route then estimates the same discretised site
  as the grid route, for any joint (Mw, R) density, with no code of the source type's own;
* :func:`independent_cells`, for a source whose magnitude and distance are independent and whose
  models give bins (:mod:`pycolfrag.site.models`: atoms, or ``support`` / ``probability_between`` /
  ``draw_between``): exact bin probabilities, Mw and R drawn from the densities restricted to the bins
  (inverse CDFs of ``Phi(z)``), the distance integral by Gauss-Legendre.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from pycolfrag.site.models import QUAD_POINTS

__all__ = ["Cell", "phi", "independent_cells", "quadrature_cells", "gives_bins"]

#: Tolerance of "on an edge", in Mw and km.
_EDGE_TOL = 1e-9


def phi(z: float) -> float:
    """Standard normal CDF by the library's own function: the same bits on every CPU."""
    from pycolfrag.core.ffi import lib  # loads C on first use: reading this module needs no C library
    return float(lib.cf_math_norm_cdf(float(z)))


@dataclass(frozen=True)
class Cell:
    """The events of one source in a Mw bin and an R bin.

    ``mw`` and ``r_km``: (lo, hi) of its events (lo == hi: one value). ``rate``: ``{pulse: annual rate}``
    of its events with (True) and without (False) a pulse, 1/yr; ``mean_g``: ``{pulse: the cell's mean of
    p(R) (True) or 1 - p(R) (False)}`` over its events. ``place(z_mw, z_dist) -> (Mw, R km)``: an event of
    the cell from two standard normals."""

    mw: tuple
    r_km: tuple
    rate: dict
    mean_g: dict
    place: Callable = field(compare=False, repr=False)


def gives_bins(source) -> bool:
    """Whether a source has independent magnitude and distance models that give bins."""
    for part in ("magnitude", "distance"):
        model = getattr(source, part, None)
        if model is None or (getattr(model, "atoms", None) is None
                             and not all(hasattr(model, a) for a in ("support", "probability_between",
                                                                      "draw_between"))):
            return False
    return True


# ------------------------------------------------------------------ independent magnitude and distance

def _edges(lo: float, hi: float, inner) -> list:
    """The bin edges of [lo, hi]: its ends and the ``inner`` values strictly inside."""
    return [lo] + sorted({float(x) for x in inner if lo + _EDGE_TOL < x < hi - _EDGE_TOL}) + [hi]


def _bins(model, inner) -> list:
    """(lo, hi, probability) of each bin of a magnitude or distance model: its atoms, or the pieces of
    its support between the ``inner`` edges."""
    if getattr(model, "atoms", None) is not None:
        return [(float(x), float(x), float(p)) for x, p in model.atoms if p > 0]
    lo, hi = model.support
    e = _edges(lo, hi, inner)
    return [(a, b, model.probability_between(a, b)) for a, b in zip(e[:-1], e[1:])]


def _g_integral(distance, pulse_model, r_bin, branch: bool) -> tuple[float, float]:
    """(int_bin f(r) g(r) dr, int_bin f(r) dr) by the Gauss-Legendre rule of the site's quadrature
    (12 points; f is smooth on a bin and p a logistic curve of r), g = p or 1 - p."""
    a, b, prob = r_bin
    if a == b:
        p0 = float(np.asarray(pulse_model.mean_probability(np.array([a])))[0])
        return prob * (p0 if branch else 1.0 - p0), prob
    x0, w0 = np.polynomial.legendre.leggauss(QUAD_POINTS)
    r = 0.5 * (b - a) * x0 + 0.5 * (a + b)
    w = 0.5 * (b - a) * w0 * np.asarray(distance.pdf(r), dtype=float)
    p = np.asarray(pulse_model.mean_probability(r), dtype=float)
    g = p if branch else 1.0 - p
    return float(math.fsum(w * g)), float(math.fsum(w))


@dataclass(frozen=True)
class _BinPlacer:
    """Mw and R at CDF fractions Phi(z) of the densities restricted to the cell's bins."""

    magnitude: Any
    distance: Any
    mw: tuple
    r_km: tuple

    def __call__(self, z_mw: float, z_dist: float) -> tuple:
        m = self.mw[0] if self.mw[0] == self.mw[1] else self.magnitude.draw_between(phi(z_mw), *self.mw)
        r = self.r_km[0] if self.r_km[0] == self.r_km[1] else self.distance.draw_between(phi(z_dist), *self.r_km)
        return m, r


def independent_cells(source, mw_step: float, mw_inner, r_inner) -> list:
    """The cells of a source with independent magnitude and distance models that give bins
    (:func:`gives_bins`): magnitude edges at ``mw_inner`` and the multiples of ``mw_step``, distance
    edges at ``r_inner``, one bin per atom of a discrete model; Mw-major, then R."""
    mag, dist = source.magnitude, source.distance
    lo_m, hi_m = (mag.support if mag.atoms is None else (0.0, 0.0))
    mw_bins = _bins(mag, list(mw_inner) + [mw_step * i for i in range(int(lo_m // mw_step), int(hi_m // mw_step) + 2)])
    r_bins = _bins(dist, list(r_inner))
    cells = []
    for mb in mw_bins:
        for rb in r_bins:
            rate, mean_g = {}, {}
            for branch in (False, True):
                fg, f = _g_integral(dist, source.pulse, rb, branch)
                rate[branch] = source.rate * mb[2] * fg
                mean_g[branch] = fg / f if rate[branch] > 0.0 else 0.0
            cells.append(Cell(mb[:2], rb[:2], rate, mean_g, _BinPlacer(mag, dist, mb[:2], rb[:2])))
    return cells


# ------------------------------------------------------------------ any source: its quadrature's nodes

@dataclass(frozen=True, eq=False)
class _NodePlacer:
    """One of the cell's quadrature nodes, drawn with probability proportional to its weight: by Phi(z_mw),
    or Phi(z_dist) when the cell's magnitudes are one value."""

    mw: np.ndarray
    r_km: np.ndarray
    cdf: np.ndarray
    by_mw: bool

    def __call__(self, z_mw: float, z_dist: float) -> tuple:
        u = phi(z_mw if self.by_mw else z_dist)
        k = min(int(np.searchsorted(self.cdf, u, side="right")), len(self.cdf) - 1)
        return float(self.mw[k]), float(self.r_km[k])


def quadrature_cells(source, mw_step: float, mw_inner, r_inner) -> list:
    """The cells of any source from its ``quadrature`` (:class:`pycolfrag.site.sources.SiteSource`): the
    events of ``quadrature(mw_breaks, r_inner)`` -- the breaks ``mw_inner`` and the multiples of
    ``mw_step`` over the source's magnitudes -- grouped by those magnitude bins and the distance bins of
    ``r_inner``; a cell's rates are the sums of its nodes' weights times p(R) or 1 - p(R). Mw-major, then R."""
    first = source.quadrature(tuple(mw_inner), tuple(r_inner))
    lo, hi = float(np.min(first.mw)), float(np.max(first.mw))
    mw_edges = sorted({float(x) for x in mw_inner}
                      | {mw_step * i for i in range(int(lo // mw_step), int(hi // mw_step) + 2)})
    r_edges = sorted(float(x) for x in r_inner)
    ev = source.quadrature(tuple(mw_edges), tuple(r_edges))
    m, r = np.asarray(ev.mw, dtype=float), np.asarray(ev.r_km, dtype=float)
    w, p = np.asarray(ev.weight, dtype=float), np.asarray(ev.p_pulse, dtype=float)
    keep = w > 0.0
    im, ir = np.searchsorted(mw_edges, m, side="right"), np.searchsorted(r_edges, r, side="right")
    cells = []
    for key in sorted({(int(a), int(b)) for a, b in zip(im[keep], ir[keep])}):
        sel = keep & (im == key[0]) & (ir == key[1])
        mm, rr, ww, pp = m[sel], r[sel], w[sel], p[sel]
        total = math.fsum(ww)
        rate = {False: math.fsum(ww * (1.0 - pp)), True: math.fsum(ww * pp)}
        mean_g = {b: rate[b] / total for b in (False, True)}
        mw, r_km = (float(mm.min()), float(mm.max())), (float(rr.min()), float(rr.max()))
        cdf = np.cumsum(ww) / total
        cells.append(Cell(mw, r_km, rate, mean_g, _NodePlacer(mm, rr, cdf, mw[0] != mw[1])))
    return cells
