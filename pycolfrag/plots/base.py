"""The drawing helpers every plotting module shares (:mod:`pycolfrag.plots.response`, :mod:`pycolfrag.plots.scene`):
a response's history checked, new or given Axes, a collapse marked. A leaf: it imports nothing of the
plotting modules, so they import it without a circle."""
from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from pycolfrag.core.errors import ParameterError

__all__ = ["_history", "_axes", "_mark_collapse"]


def _history(res):
    h = getattr(res, "history", None)
    if h is None:
        raise ParameterError("the response has no history: run simulate(..., history=True)")
    if np.size(h.t) == 0:
        raise ParameterError("the response's history is empty (no samples)")
    return h


def _axes(ax, n=1, projection=None, figsize=(8.0, 4.0)):
    """``n`` axes: new ones stacked in a new Figure, or the given Axes (one, or a sequence of ``n``)."""
    if ax is None:
        fig = Figure(figsize=figsize, layout="constrained")
        kw = {"projection": projection} if projection else {}
        axes = [fig.add_subplot(n, 1, i + 1, **kw) for i in range(n)]
        if n > 1 and projection is None:
            for a in axes[1:]:
                a.sharex(axes[0])
        return fig, axes
    axes = list(ax) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
    if len(axes) != n:
        raise ParameterError(f"expected {n} Axes, got {len(axes)}")
    return axes[0].figure, axes


def _mark_collapse(ax, res):
    if getattr(res, "collapsed", False):
        tc = getattr(res, "collapse_time", float("nan"))
        if tc is not None and math.isfinite(tc):
            blk = getattr(res, "collapse_block", None)
            ax.axvline(tc, color="k", ls="--", lw=1.0,
                       label=f"collapse (block {blk})" if blk is not None else "collapse")
