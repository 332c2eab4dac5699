"""A horizontal pair turned about the vertical: rotation, fault-normal / fault-parallel components and
the orientation-independent RotDnn (Boore 2010) of PGA, PGV and SA.

Azimuths are in degrees clockwise from north; H2 is taken 90 degrees clockwise from H1 (the NGA
convention; if a station's H2 points the other way, give its negative). The SDOF histories behind
RotD of SA come from the spectra's own recurrence (:func:`pycolfrag.ground_motion.intensity.sdof_displacement`,
``csrc/spectra.c``), so RotD100 of a pair (a, 0) is the spectrum's SA of a to the last bit.
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.names import CM_PER_M, G
from pycolfrag.core.validate import finite_float, float_array
from pycolfrag.ground_motion.intensity import integrate, sdof_displacement

__all__ = ["rotate_pair", "component_at", "fault_normal_parallel", "rotd"]


def _pair(a1, a2) -> tuple[np.ndarray, np.ndarray]:
    a1 = float_array(a1, "a1")
    a2 = float_array(a2, "a2")
    if a1.shape != a2.shape:
        raise ParameterError(f"a pair must share one time axis, got {a1.shape} and {a2.shape}")
    return a1, a2


def rotate_pair(a1, a2, theta_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotate a horizontal pair by ``theta_deg`` (clockwise seen from above, azimuth convention).

    With H1 along azimuth ``az`` and H2 along ``az + 90``, the returned pair points along
    ``az + theta`` and ``az + theta + 90``::

        a1' =  cos(theta) a1 + sin(theta) a2
        a2' = -sin(theta) a1 + cos(theta) a2

    Rotating by ``theta`` and then by ``-theta`` returns the pair (to rounding).
    """
    a1, a2 = _pair(a1, a2)
    t = math.radians(finite_float(theta_deg, "theta_deg"))
    c, s = math.cos(t), math.sin(t)
    return c * a1 + s * a2, -s * a1 + c * a2


def component_at(a1, a2, azimuth_deg: float, azimuth_h1_deg: float = 0.0) -> np.ndarray:
    """The horizontal motion along ``azimuth_deg`` of a pair whose H1 points along ``azimuth_h1_deg``."""
    return rotate_pair(a1, a2, finite_float(azimuth_deg, "azimuth_deg") - finite_float(azimuth_h1_deg,
                                                                                         "azimuth_h1_deg"))[0]


def fault_normal_parallel(a1, a2, strike_deg: float, azimuth_h1_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(fault-normal, fault-parallel) components: the motion along ``strike + 90`` and along ``strike``."""
    strike = finite_float(strike_deg, "strike_deg")
    fn = component_at(a1, a2, strike + 90.0, azimuth_h1_deg)
    fp = component_at(a1, a2, strike, azimuth_h1_deg)
    return fn, fp


def _rotated_peaks(x1, x2, angles_deg):
    """max_t |cos(t) x1 + sin(t) x2| for each angle (chunks of angles keep memory small)."""
    ang = np.radians(np.asarray(angles_deg, dtype=float))
    peaks = np.empty(ang.size)
    step = max(1, int(4_000_000 // max(x1.size, 1)))
    for k in range(0, ang.size, step):
        a = ang[k:k + step, None]
        peaks[k:k + step] = np.max(np.abs(np.cos(a) * x1[None, :] + np.sin(a) * x2[None, :]), axis=1)
    return peaks


def _histories(a1, a2, dt, measure, damping):
    """The pair of histories whose rotated peaks RotD takes, the factor to the unit, and the unit."""
    if isinstance(measure, str) and measure.lower() == "pga":
        return a1, a2, 1.0 / G, "g"
    if isinstance(measure, str) and measure.lower() == "pgv":
        return integrate(a1, dt)[0], integrate(a2, dt)[0], CM_PER_M, "cm/s"
    if isinstance(measure, str):
        raise ParameterError(f"measure must be 'pga', 'pgv' or a period in s, got {measure!r}")
    T = finite_float(measure, "measure (a period, s)")
    if not T > 0:
        raise ParameterError(f"period must be finite and > 0 s, got {measure!r}")
    x1 = sdof_displacement(a1, dt, T, damping)
    x2 = sdof_displacement(a2, dt, T, damping)
    return x1, x2, (2.0 * math.pi / T) ** 2 / G, "g"


def rotd(a1, a2, dt, measure="pga", percentiles=(50.0, 100.0), damping=0.05, angles_deg=None) -> dict:
    """Orientation-independent RotDnn of a horizontal pair (Boore 2010).

    For every rotation angle in ``angles_deg`` (default 0, 1, ..., 179 degrees) the peak of the
    rotated motion is taken; RotDnn is the nn-th percentile over the angles (RotD50 the median,
    RotD100 the largest, i.e. the peak in the most severe direction).

    Parameters
    ----------
    a1, a2 : array (n,), m/s^2
    dt : float, s
    measure : "pga", "pgv" or a period in s (float)
        Peak acceleration (g), peak velocity (cm/s; trapezoidal, from rest) or the pseudo-spectral
        acceleration omega^2 SD (g) at that period and ``damping``.
    percentiles : sequence of float in [0, 100]

    Returns
    -------
    dict: ``rotd50``, ``rotd100``, ... (one key per percentile, ``rotd{p:g}``), ``angles_deg``,
    ``peaks`` (per angle), ``angle_max_deg``, ``unit``.
    """
    a1, a2 = _pair(a1, a2)
    angles = np.arange(0.0, 180.0, 1.0) if angles_deg is None else float_array(angles_deg, "angles_deg")
    pct = [finite_float(p, "percentile") for p in percentiles]
    bad = [p for p in pct if not 0.0 <= p <= 100.0]
    if bad:
        raise ParameterError(f"percentile must be in [0, 100], got {bad[0]!r}")
    x1, x2, factor, unit = _histories(a1, a2, dt, measure, damping)
    peaks = _rotated_peaks(x1, x2, angles) * factor
    out = {"angles_deg": angles, "peaks": peaks, "angle_max_deg": float(angles[int(np.argmax(peaks))]), "unit": unit}
    for p in pct:
        out[f"rotd{p:g}"] = float(np.percentile(peaks, p))
    return out
