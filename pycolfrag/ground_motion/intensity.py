"""Intensity measures of an acceleration record (docs/ground_motion.md).

All numbers come from the C kernels in ``csrc/spectra.c``:

* ``pga_g``: max |a| / g.
* ``pgv_cm_s``, ``pgd_cm``: peaks of the trapezoidal velocity and displacement from rest
  (v(0) = d(0) = 0). No baseline correction: the peaks of the record as given (a synthetic
  record ends at rest by construction; a natural record's processing is its provider's).
* ``sa_g``: 5 %-damped (any ``damping``) **pseudo**-spectral acceleration ω² SD / g, the
  convention of GMPEs such as BSSA14, so the two can be compared.
* ``sv_cm_s``: the **relative** velocity spectrum max |x'| (not the pseudo-velocity ω SD):
  the quantity the paper's velocity spectra show (the pulse's bump near T = 1/fp); at long
  periods it tends to PGV where ω SD tends to 0. ``psv_cm_s`` = ω SD is also returned, as are
  ``sd_cm`` and ``sa_abs_g`` (absolute acceleration max |x'' + a_g| / g).
* The SDOF response x'' + 2ζωx' + ω²x = -a_g is stepped by the exact recurrence for
  piecewise-linear input (Nigam & Jennings 1969) over the record only (no free tail).
* ``arias_m_s``: π/(2g) ∫a² dt (trapezoidal), m/s.
* ``d5_95_s``: time between 5 % and 95 % of the Husid integral, interpolated linearly
  between samples, s.

``g`` = :data:`pycolfrag.core.names.G` (9.81 m/s², the solver's default).

Arguments are checked where they enter: :func:`measures`, :func:`response_spectrum`,
:func:`integrate` and :func:`sdof_displacement` check theirs; :class:`SpectralOptions` checks the
periods and damping once when it is made, and :func:`record_measures` trusts a
:class:`~pycolfrag.ground_motion.Record` (checked when it was made) and a SpectralOptions, so that
a grid row's record is not checked again here.
"""
from __future__ import annotations

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import check, ffi, lib, ptr
from pycolfrag.core.names import G
from pycolfrag.core.validate import finite_float, float_array, positive_float

__all__ = ["G", "DEFAULT_PERIODS_S", "SpectralOptions", "measures", "record_measures", "response_spectrum",
           "integrate", "sdof_displacement"]

#: Periods of :func:`measures` by default, s (the paper's).
DEFAULT_PERIODS_S = (0.2, 0.5, 1.0, 2.0, 3.0)


def _record(acc, dt):
    a = float_array(acc, "acc")
    d = positive_float(dt, "dt")
    if a.size > 2**31 - 1:
        raise ParameterError(f"acc has {a.size} samples, more than the C kernels take (2^31 - 1)")
    return a, d


def _periods(periods):
    p = np.atleast_1d(float_array(periods, "periods (s)", ndim=None))
    if p.ndim != 1:
        raise ParameterError(f"periods must be a number or a 1-D array of numbers, got shape {p.shape}")
    bad = np.flatnonzero(p <= 0)
    if bad.size:
        raise ParameterError(f"periods must be > 0 s, got {p[bad[0]]!r} at index {int(bad[0])}")
    return p


def _damping(damping):
    z = finite_float(damping, "damping")
    if not 0.0 <= z < 1.0:
        raise ParameterError(f"damping must be a ratio in [0, 1), got {damping!r}")
    return z


class SpectralOptions:
    """The spectral periods (s, > 0) and damping ratio (in [0, 1)) of the IMs, checked once when made.

    Attributes: ``periods_s`` (read-only float64 array), ``damping`` (float).
    """

    __slots__ = ("periods_s", "damping")

    def __init__(self, periods=DEFAULT_PERIODS_S, damping=0.05):
        p = np.array(_periods(periods), copy=True)   # a copy: the caller's array stays writable
        p.flags.writeable = False
        self.periods_s = p
        self.damping = _damping(damping)

    def __repr__(self) -> str:
        return f"SpectralOptions(periods_s={self.periods_s.tolist()}, damping={self.damping!r})"


def integrate(acc, dt):
    """Trapezoidal velocity (m/s) and displacement (m) of ``acc`` (m/s²) from rest.

    Returns ``(vel, disp)``, arrays of the record's length.
    """
    return _integrated(*_record(acc, dt))


def _integrated(a, d):
    """:func:`integrate` of checked arguments (``a`` a finite C-contiguous float64 1-D array, ``d`` > 0
    s): a synthetic record's own arrays (:mod:`pycolfrag.ground_motion.synthesis`) are not checked again."""
    vel = np.empty_like(a)
    disp = np.empty_like(a)
    check(lib.cf_spectra_integrate(ptr(a), a.size, d, ptr(vel), ptr(disp)), what="integrate")
    return vel, disp


def response_spectrum(acc, dt, periods, damping=0.05):
    """Elastic SDOF response spectra of ``acc`` (m/s², sampled at ``dt`` s).

    Parameters
    ----------
    acc : array_like, 1-D, m/s²
    dt : float, s
    periods : array_like of float, s (> 0)
    damping : float, ratio of critical in [0, 1)

    Returns
    -------
    dict with ``periods_s``; ``sd_m`` (max |x|, m); ``sv_m_s`` (max |x'|, m/s);
    ``sa_abs_m_s2`` (max |x'' + a_g|, m/s²); ``psv_m_s`` = ω SD; ``psa_m_s2`` = ω² SD.
    """
    a, d = _record(acc, dt)
    p = _periods(periods)
    sd, sv, sa = _sdof_peaks(a, d, p, _damping(damping), "response_spectrum")
    w = 2.0 * np.pi / p
    return {"periods_s": p, "sd_m": sd, "sv_m_s": sv, "sa_abs_m_s2": sa, "psv_m_s": w * sd,
            "psa_m_s2": w * w * sd}


def _sdof_peaks(a, d, p, z, what):
    """(max |x|, max |x'|, max |x'' + a_g|) per period, SI, for arguments already checked."""
    sd = np.empty_like(p)
    sv = np.empty_like(p)
    sa = np.empty_like(p)
    check(lib.cf_spectra_response(ptr(a), a.size, d, ptr(p), p.size, z, ptr(sd), ptr(sv), ptr(sa)), what=what)
    return sd, sv, sa


def measures(acc, dt, periods=DEFAULT_PERIODS_S, damping=0.05):
    """Intensity measures of one record (see the module docstring for the definitions).

    Parameters
    ----------
    acc : array_like, 1-D, m/s²
        Finite samples; a :class:`~pycolfrag.ground_motion.Record` works via ``rec.acc``.
    dt : float, s (> 0)
    periods : array_like of float, s (> 0)
    damping : float, ratio of critical in [0, 1); 0.05 by default

    Returns
    -------
    dict
        ``pga_g``, ``pgv_cm_s``, ``pgd_cm``, ``arias_m_s``, ``d5_95_s``, ``t5_s``, ``t95_s``
        (floats) and, over ``periods_s``: ``sa_g`` (pseudo-acceleration), ``sv_cm_s``
        (relative velocity), ``psv_cm_s``, ``sd_cm``, ``sa_abs_g`` (arrays).
    """
    a, d = _record(acc, dt)
    return _measures(a, d, SpectralOptions(periods, damping))


def record_measures(record, spectral: SpectralOptions) -> dict:
    """:func:`measures` of a :class:`~pycolfrag.ground_motion.Record`'s ``acc`` (its first horizontal
    component) for ``spectral``: nothing is checked again (both were checked when they were made)."""
    return _measures(record.acc, record.dt, spectral)


def _measures(a, d, spectral: SpectralOptions) -> dict:
    """The IMs of checked arguments: ``a`` a finite C-contiguous float64 1-D array, ``d`` > 0 s."""
    p, z = spectral.periods_s, spectral.damping
    out = ffi.new("cf_spectra_ims *")
    check(lib.cf_spectra_peaks(ptr(a), a.size, d, G, out), what="measures")
    sd, sv, sa = _sdof_peaks(a, d, p, z, "measures")
    w = 2.0 * np.pi / p
    return {
        "pga_g": out.pga / G, "pgv_cm_s": 100.0 * out.pgv, "pgd_cm": 100.0 * out.pgd,
        "arias_m_s": out.arias, "d5_95_s": out.d5_95, "t5_s": out.t5, "t95_s": out.t95,
        "periods_s": p.copy(), "damping": z,
        "sa_g": w * w * sd / G, "sv_cm_s": 100.0 * sv, "psv_cm_s": 100.0 * w * sd,
        "sd_cm": 100.0 * sd, "sa_abs_g": sa / G,
    }


def sdof_displacement(acc, dt, period, damping=0.05) -> np.ndarray:
    """Relative displacement history x(t) (m) of the damped oscillator of ``period`` (s) under ``acc``
    (m/s², sampled at ``dt`` s), from rest: the recurrence of the spectra (``cf_spectra_displacement``,
    the same steps as :func:`response_spectrum`), so ``max |x|`` is its ``sd_m`` bit for bit. An array
    of the record's length (``x[0] = 0``); what RotD of SA rotates
    (:func:`pycolfrag.ground_motion.rotation.rotd`)."""
    a, d = _record(acc, dt)
    T = positive_float(period, "period (s)")
    z = _damping(damping)
    x = np.empty_like(a)
    check(lib.cf_spectra_displacement(ptr(a), a.size, d, T, z, ptr(x)), what="sdof_displacement")
    return x
