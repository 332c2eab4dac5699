"""Damage: the performance levels of the paper's Tables III and IV, what a run's outcome exceeds
(:func:`exceeded`, :func:`exceedance_score`: the one text of Eq. (1)'s event), and the checks every
statistic applies to its inputs (EDPs, collapse flags, a threshold). Below every driver: the fragility
statistics (:mod:`pycolfrag.analysis.fragility`) and the rare-event estimator (:mod:`pycolfrag.rare`) both
read it, so neither reaches the other."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import float_array, positive_float


@dataclass(frozen=True)
class PerformanceLevel:
    """One performance level of paper Tables III and IV.

    Attributes
    ----------
    edp : str
        ``"u_top"`` (max capital displacement / base diameter) or ``"u_d"`` (max residual drum
        dislocation / joint diameter); both dimensionless.
    threshold : float
        Exceedance threshold ``edp`` of Eq. (1) (dimensionless).
    name : str
        The paper's name of the level.
    """

    edp: str
    threshold: float
    name: str

    @property
    def label(self) -> str:
        """Plot/table label, e.g. ``u_top > 0.35``."""
        return f"{self.edp} > {self.threshold:g}"


#: Table III (risk of collapse).
U_TOP_LEVELS = (
    PerformanceLevel("u_top", 0.15, "Damage limitation"),
    PerformanceLevel("u_top", 0.35, "Significant damage"),
    PerformanceLevel("u_top", 1.0, "Near collapse"),
)
#: Table IV (residual drum dislocations).
U_D_LEVELS = (
    PerformanceLevel("u_d", 0.005, "Limited deformation"),
    PerformanceLevel("u_d", 0.01, "Light deformation"),
    PerformanceLevel("u_d", 0.02, "Significant deformation"),
)
PERFORMANCE_LEVELS = U_TOP_LEVELS + U_D_LEVELS


# --------------------------------------------------------------------------- input checks

def _as_flags(collapsed) -> np.ndarray:
    """Collapse flags as a bool array; 0/1 integers accepted, anything else refused."""
    collapsed = np.asarray(collapsed)
    if collapsed.dtype != bool:
        if collapsed.dtype.kind not in "iuf" or not np.all(np.isin(collapsed, (0, 1))):
            bad = collapsed.ravel()[~np.isin(collapsed.ravel(), (0, 1))] if collapsed.dtype.kind in "iuf" \
                else collapsed.ravel()
            raise ParameterError(f"collapsed must hold booleans (or 0/1), got {bad[0]!r}" if bad.size
                                 else "collapsed must hold booleans (or 0/1)")
        collapsed = collapsed.astype(bool)
    return collapsed


#: ``_as_inputs``'s "no threshold asked for" (None is a bad threshold, refused with its name).
_NO_THRESHOLD = object()


def _as_inputs(edp, collapsed, threshold=_NO_THRESHOLD):
    """Validate (edp, collapsed[, threshold]) and return float/bool arrays (and the threshold)."""
    edp = float_array(edp, "edp", ndim=None, allow_empty=True, finite=False)
    collapsed = np.asarray(collapsed)
    if edp.ndim != 1 or collapsed.ndim != 1:
        raise ParameterError(f"edp and collapsed must be 1-D, got shapes {edp.shape} and {collapsed.shape}")
    if edp.shape != collapsed.shape:
        raise ParameterError(
            f"edp and collapsed have mismatched lengths {edp.size} and {collapsed.size}")
    if edp.size == 0:
        raise ParameterError("empty group: no samples to compute a probability from")
    collapsed = _as_flags(collapsed)
    ok = edp[~collapsed]
    if not np.all(np.isfinite(ok)):
        raise ParameterError("non-collapsed EDPs must be finite (NaN/inf found)")
    if np.any(ok < 0):
        raise ParameterError(f"EDPs must be non-negative, got min {ok.min()!r}")
    if threshold is _NO_THRESHOLD:
        return edp, collapsed
    return edp, collapsed, positive_float(threshold, "threshold")


def exceedance_score(edp, collapsed) -> np.ndarray:
    """Each simulation's value on the EDP's scale, the one text of what exceeds a level (Eq. (1)): a
    level t is exceeded where it is >= t. +inf where the column collapsed (a collapse exceeds every
    level), -inf where the EDP is NaN (no value: it exceeds none), the EDP otherwise. Unchecked (callers
    check): :func:`exceeded` and the subset simulation's score (:func:`pycolfrag.rare.subset.score`)."""
    edp = np.asarray(edp, dtype=float)
    return np.where(collapsed, np.inf, np.where(np.isnan(edp), -np.inf, edp))


def exceeded(edp, collapsed, threshold) -> np.ndarray:
    """Bernoulli outcome of each simulation: collapsed or EDP >= threshold (bool array)."""
    edp = float_array(edp, "edp", ndim=None, allow_empty=True, finite=False)
    collapsed = _as_flags(collapsed)
    threshold = positive_float(threshold, "threshold")
    return exceedance_score(edp, collapsed) >= threshold
