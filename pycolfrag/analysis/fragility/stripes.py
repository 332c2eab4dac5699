"""Stripe-method fragility curves (paper Fig. 3, Fig. 16): Eq. (4) inside each IM stripe."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pycolfrag.analysis.fragility.bootstrap import as_rng, boot_settings, bootstrap_interval
from pycolfrag.analysis.fragility.eq4 import _eq4_why, _exceedance, empirical_exceedance
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import float_array, integer
from pycolfrag.damage import _as_inputs


@dataclass
class StripeCurve:
    """Fragility curve P(EDP >= threshold | IM) by the stripe method (paper Fig. 3, Fig. 16).

    Attributes
    ----------
    edges : ndarray (n_stripes + 1,)
        Stripe limits on the IM axis (IM units).
    im : ndarray (n_stripes,)
        IM value of each stripe (mid-point for equal-width stripes, median IM for equal-count).
    n, n_collapsed : ndarray of int
    p, p_empirical, low, high : ndarray
        Eq. (4) inside each stripe, the empirical ratio, and the bootstrap interval of Eq. (4);
        NaN where a stripe holds fewer than ``min_count`` samples.
    degenerate : ndarray of bool
        Stripes whose Eq. (4) value is not an estimate (:func:`eq4_degenerate`: with a ``min_count``
        below :data:`MIN_FIT_POINTS`, or too few standing runs with EDP > 0).
    """

    edges: np.ndarray
    im: np.ndarray
    n: np.ndarray
    n_collapsed: np.ndarray
    p: np.ndarray
    p_empirical: np.ndarray
    low: np.ndarray
    high: np.ndarray
    threshold: float
    stripes: str
    degenerate: np.ndarray | None = None


def stripe_edges(im, n_stripes=12, stripes="equal-width", im_range=None) -> np.ndarray:
    """Stripe limits: ``n_stripes`` equal-width intervals (paper: 12) or equal-count quantiles."""
    im = float_array(im, "im", ndim=None, allow_empty=True, finite=False)
    n_stripes = integer(n_stripes, "n_stripes", 1)
    if im.size == 0:
        raise ParameterError("empty IM array")
    if stripes == "equal-width":
        lo, hi = (np.min(im), np.max(im)) if im_range is None else map(float, im_range)
        if not hi > lo:
            raise ParameterError(f"IM range must be increasing, got {lo}..{hi}")
        return np.linspace(lo, hi, int(n_stripes) + 1)
    if stripes == "equal-count":
        return np.quantile(im, np.linspace(0, 1, int(n_stripes) + 1))
    raise ParameterError(f"stripes must be 'equal-width' or 'equal-count', got {stripes!r}")


def stripe_curve(im, edp, collapsed, threshold, *, n_stripes=12, stripes="equal-width",
                 im_range=None, min_count=5, n_boot=1000, confidence=0.90, rng=None) -> StripeCurve:
    """Stripe-method fragility curve (paper Fig. 3): Eq. (4) using only the data in each IM stripe.

    Parameters
    ----------
    im : array_like
        Intensity measure of each sample (PGA in g, PGV in cm/s, SA(T) in g, SV(T) in cm/s), > 0.
    edp, collapsed : array_like
        EDP and collapse flag of each sample (EDPs of collapsed samples are ignored, may be NaN).
    threshold : float
        Performance-level threshold (> 0).
    n_stripes : int
        Number of stripes (paper: 12).
    stripes : {"equal-width", "equal-count"}
    im_range : (float, float), optional
        IM interval split into equal-width stripes (default: data min..max).
    min_count : int
        Stripes with fewer samples are reported as NaN.
    n_boot, confidence, rng
        Bootstrap within each stripe.
    """
    edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
    boot_settings(n_boot, confidence)
    im = float_array(im, "im", ndim=None, finite=False)
    if im.shape != edp.shape:
        raise ParameterError(f"im has length {im.size}, edp has {edp.size}")
    if not np.all(np.isfinite(im)):
        raise ParameterError("IM values must be finite")
    edges = stripe_edges(im, n_stripes, stripes, im_range)
    k = edges.size - 1
    # stripe index; the last stripe is closed on the right
    idx = np.clip(np.searchsorted(edges, im, side="right") - 1, 0, k - 1)
    inside = (im >= edges[0]) & (im <= edges[-1])
    g = as_rng(rng)
    out = {name: np.full(k, np.nan) for name in ("im", "p", "pe", "lo", "hi")}
    n = np.zeros(k, dtype=int)
    nc = np.zeros(k, dtype=int)
    degenerate = np.zeros(k, dtype=bool)
    for s in range(k):
        sel = inside & (idx == s)
        n[s] = sel.sum()
        nc[s] = collapsed[sel].sum()
        out["im"][s] = 0.5 * (edges[s] + edges[s + 1]) if stripes == "equal-width" else (
            np.median(im[sel]) if n[s] else np.nan)
        if n[s] < max(int(min_count), 1):
            continue
        out["p"][s] = _exceedance(edp[sel], collapsed[sel], threshold)
        degenerate[s] = bool(_eq4_why(edp[sel], collapsed[sel]))
        out["pe"][s] = empirical_exceedance(edp[sel], collapsed[sel], threshold)
        out["lo"][s], out["hi"][s] = bootstrap_interval(edp[sel], collapsed[sel], threshold, n_boot=n_boot,
                                                        confidence=confidence, rng=g)
    return StripeCurve(edges, out["im"], n, nc, out["p"], out["pe"], out["lo"], out["hi"], threshold, stripes,
                       degenerate)


