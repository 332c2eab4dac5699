"""Mavroeidis & Papageorgiou (2003) near-fault velocity pulse (the paper's Eq. 5),
and the Latin-hypercube sampling of its parameters per scenario: the pulse shape "mp03"
(the interface of :mod:`pycolfrag.ground_motion.pulse_shape`).

Eq. (5), with tau = t - t0 and support |tau| <= gamma / (2 fp)::

    V(t) = A/2 [1 + cos(2 pi fp tau / gamma)] cos(2 pi fp tau + nu)

A (envelope amplitude), fp (Hz), nu (phase, rad), gamma (number of half cycles), t0 (epoch
of the envelope peak, s). Acceleration (the analytic derivative) and displacement (the
analytic integral: zero before the pulse, constant after it) come from the C kernel
``csrc/pulse.c`` -- never from numerical differencing.

The peak velocity Vp of the pulse is not A in general: ``envelope_amplitude`` returns the A
for which max_t |V| = Vp given nu and gamma (the maximum of the unit pulse found on a grid of
2001 points over the support, then polished by a bounded Brent search to 1e-12 in fp*tau).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.names import G, Parameter
from pycolfrag.core.validate import finite_float, float_array, integer, positive_float
from pycolfrag.ground_motion import rupakhety_2011 as _r11
from pycolfrag.ground_motion.pulse_shape import PreparedPulse
from pycolfrag.ground_motion.sampling import latin_hypercube, minimize_bounded

__all__ = ["NAME", "KIND", "SHAPE", "PARAMETERS", "INPUTS", "prepare", "GAMMA_MEAN", "GAMMA_SD", "GAMMA_MIN", "NU_RANGE_RAD", "pulse", "velocity",
           "acceleration", "displacement", "support", "envelope_amplitude", "peak_velocity_time",
           "sample_parameters", "NORMALS", "parameters_from_normals"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`).
NAME = "mavroeidis_papageorgiou_2003"
#: The velocity pulse of a near-fault record: its parameters are the pulse fields of a sample row.
KIND = "pulse"
#: The pulse shape's short name (the grid's ``--pulse``, ``synthesize(shape=...)``): the paper's records.
SHAPE = "mp03"

#: gamma ~ N(1.8, 0.4) left-truncated at 1 (the paper, after MP03's data).
GAMMA_MEAN, GAMMA_SD, GAMMA_MIN = 1.8, 0.4, 1.0
#: nu ~ U[-pi/2, pi/2] (the paper).
NU_RANGE_RAD = (-math.pi / 2, math.pi / 2)

#: The pulse's parameters as a record carries them (``Record.meta`` key) and a sample row stores them
#: (``/samples`` field), in the order of the results layout. The first four are the inputs of
#: :func:`pycolfrag.ground_motion.synthesize` (``pulse=`` rows, checked against these ranges: any
#: finite phase, positive amplitude, frequency and gamma, which the C kernel needs; the sampling keeps
#: gamma >= GAMMA_MIN and nu in NU_RANGE_RAD); the others are derived from them for each record.
PARAMETERS = (
    Parameter("Vp", "cm/s", (0.0, math.inf), "pulse amplitude Vp", "Vp_cm_s", "vp_cm_s", low_open=True),
    Parameter("fp", "Hz", (0.0, math.inf), "pulse frequency fp", "fp_hz", "fp_hz", low_open=True),
    Parameter("nu", "rad", (-math.inf, math.inf), "pulse phase nu", "nu_rad", "nu_rad"),
    Parameter("gamma", "-", (0.0, math.inf), "pulse oscillatory character gamma", "gamma", "gamma", low_open=True),
    Parameter("t0", "s", (-math.inf, math.inf), "time of the pulse peak", "t0_s", "t0_s"),
    Parameter("Tp", "s", (0.0, math.inf), "pulse period Tp = 1/fp", "Tp_s", "tp_s", low_open=True),
    Parameter("A", "cm/s", (0.0, math.inf), "envelope amplitude A of the pulse model", "A_cm_s", "a_cm_s",
              low_open=True),
    Parameter("Ap", "g", (0.0, math.inf), "peak acceleration of the pulse alone", "Ap_g", "ap_g"),
)
_VP, _FP, _NU, _GAMMA, _T0, _TP, _A, _AP = PARAMETERS
#: The parameters a pulse row must give (:func:`pycolfrag.ground_motion.synthesize`); the rest are derived.
INPUTS = (_VP, _FP, _NU, _GAMMA)
#: The standard normals (quantiles) the inputs are made from, in order (:func:`parameters_from_normals`):
#: each input is the inverse CDF of its distribution at Phi(z) of its own normal.
NORMALS = ("z_vp", "z_fp", "z_nu", "z_gamma")


def _c():
    """The compiled library's module (``ffi``, ``lib``, ``check``, ``ptr``), loaded on first use rather
    than at import: the declarations above are read by the results layout, which must not need C."""
    from pycolfrag.core import ffi as _ffi  # loads C on first use (docstring)
    return _ffi


def _float(value, name, positive=False):
    return positive_float(value, name) if positive else finite_float(value, name)


def _params(A, fp, nu, gamma, t0):
    return _c_params(_float(A, "A"), _float(fp, "fp", positive=True), _float(nu, "nu"),
                     _float(gamma, "gamma", positive=True), _float(t0, "t0"))


def _c_params(A, fp, nu, gamma, t0):
    """The ``cf_pulse_params`` of checked values (floats; fp and gamma > 0)."""
    p = _c().ffi.new("cf_pulse_params *")
    p.amplitude, p.fp, p.nu, p.gamma, p.t0 = A, fp, nu, gamma, t0
    return p


def _evaluate(p, tt):
    """(vel, acc, disp) of the pulse ``p`` (:func:`_c_params`) at the times ``tt`` (a C-contiguous
    float64 1-D array, s)."""
    vel, acc, disp = np.empty_like(tt), np.empty_like(tt), np.empty_like(tt)
    c = _c()
    c.check(c.lib.cf_pulse_eval(p, c.ptr(tt), tt.size, c.ptr(vel), c.ptr(acc), c.ptr(disp)), what="pulse")
    return vel, acc, disp


def pulse(t, A, fp, nu, gamma, t0=0.0):
    """Velocity, acceleration and displacement of the pulse at times ``t`` (s).

    Parameters
    ----------
    t : array_like, s
    A : float, envelope amplitude (any velocity unit; the outputs follow it: m/s -> m/s^2, m)
    fp : float, Hz (> 0)
    nu : float, rad
    gamma : float (> 0; the model uses > 1)
    t0 : float, s (epoch of the envelope's peak)

    Returns
    -------
    (vel, acc, disp) : arrays shaped like ``t``
    """
    p = _params(A, fp, nu, gamma, t0)
    vel, acc, disp = _evaluate(p, np.ravel(float_array(t, "t", ndim=None, allow_empty=True)))
    shape = np.shape(t)
    return vel.reshape(shape), acc.reshape(shape), disp.reshape(shape)


def velocity(t, A, fp, nu, gamma, t0=0.0):
    """Eq. (5) velocity at ``t`` (unit of ``A``)."""
    return pulse(t, A, fp, nu, gamma, t0)[0]


def acceleration(t, A, fp, nu, gamma, t0=0.0):
    """Closed-form dV/dt at ``t`` (unit of ``A`` per s); zero outside the support."""
    return pulse(t, A, fp, nu, gamma, t0)[1]


def displacement(t, A, fp, nu, gamma, t0=0.0):
    """Closed-form integral of V from the start of the support (unit of ``A`` times s)."""
    return pulse(t, A, fp, nu, gamma, t0)[2]


def support(fp, gamma, t0=0.0):
    """First and last instant of the pulse, s: ``t0 -/+ gamma / (2 fp)``."""
    fp = _float(fp, "fp", positive=True)
    gamma = _float(gamma, "gamma", positive=True)
    half = gamma / (2.0 * fp)
    return t0 - half, t0 + half


@functools.lru_cache(maxsize=4096)
def _unit_peak(nu, gamma):
    """(u*, g(u*)) for g(u) = 0.5 (1 + cos(2 pi u / gamma)) cos(2 pi u + nu), u = fp tau in
    [-gamma/2, gamma/2]: where the unit-amplitude pulse peaks in |g| (independent of fp), and
    its signed value there (the sign is that of the pulse's peak velocity for A > 0).

    Cached on (nu, gamma) (floats; a pure function): a grid asks for the same pulse's peak when it
    draws a scenario's pulse parameters and again when it synthesises each of its records."""
    u = np.linspace(-gamma / 2, gamma / 2, 2001)
    c = _c()

    def g(x):
        # C (csrc/pulse.c, cf_math cos): the same bits on every CPU, unlike numpy's cos loops
        xs = np.ascontiguousarray(np.atleast_1d(x), dtype=np.float64)
        out = np.empty_like(xs)
        c.check(c.lib.cf_pulse_unit_shape(nu, gamma, c.ptr(xs), xs.size, c.ptr(out)), what="unit pulse")
        return out if np.ndim(x) else float(out[0])

    k = int(np.argmax(np.abs(g(u))))
    lo, hi = u[max(k - 1, 0)], u[min(k + 1, u.size - 1)]
    x, fx = minimize_bounded(lambda x: -abs(g(x)), lo, hi, xatol=1e-12)   # scipy's bounded Brent, bitwise
    ub = float(x) if -fx >= abs(g(u[k])) else float(u[k])
    return ub, float(g(ub))


def envelope_amplitude(Vp, fp, nu, gamma):
    """Envelope amplitude A such that max_t |V(t)| = Vp for this nu and gamma.

    Scalars or broadcastable arrays; the unit of A is that of Vp. ``fp`` only enters the
    check (the peak of the unit pulse does not depend on fp).
    """
    Vp, fp, nu, gamma = np.broadcast_arrays(*(float_array(x, name, ndim=None, finite=False)
                                             for x, name in ((Vp, "Vp"), (fp, "fp"), (nu, "nu"), (gamma, "gamma"))))
    out = np.empty(Vp.shape)
    for idx in np.ndindex(Vp.shape):
        _float(fp[idx], "fp", positive=True)
        g = _float(gamma[idx], "gamma", positive=True)
        _, peak = _unit_peak(_float(nu[idx], "nu"), g)
        out[idx] = _float(Vp[idx], "Vp") / abs(peak)
    return out if out.ndim else float(out)


def peak_velocity_time(fp, nu, gamma, t0=0.0):
    """Time of the peak |V| of the pulse, s (``t0`` + the offset of the unit pulse's peak)."""
    fp = _float(fp, "fp", positive=True)
    u, _ = _unit_peak(_float(nu, "nu"), _float(gamma, "gamma", positive=True))
    return _float(t0, "t0") + u / fp


def prepare(Vp_cm_s, fp_hz, nu_rad, gamma) -> PreparedPulse:
    """The pulse of peak velocity ``Vp_cm_s`` (cm/s), frequency ``fp_hz``, phase ``nu_rad`` and
    ``gamma`` (the values of :data:`INPUTS`), ready to be placed on a record
    (:class:`~pycolfrag.ground_motion.pulse_shape.PreparedPulse`). One search for the unit pulse's
    peak gives the envelope amplitude A (peak |V| = Vp), the peak's offset from the envelope epoch
    and the sign of the peak velocity (A > 0); the support is ``t0 -/+ gamma / (2 fp)``; the
    acceleration is the closed form of ``csrc/pulse.c``; the meta values are those of
    :data:`PARAMETERS`: Vp, fp, nu, gamma, t0, Tp = 1/fp, A and the peak |acceleration| in g."""
    vp, fp, nu, gamma = Vp_cm_s, fp_hz, nu_rad, gamma
    u_peak, g_peak = _unit_peak(nu, gamma)
    A = vp / abs(g_peak)
    half = gamma / (2.0 * fp)
    return PreparedPulse(
        peak_offset_s=u_peak / fp, peak_sign=math.copysign(1.0, g_peak), before_s=half, after_s=half,
        acceleration=lambda t, t0: _evaluate(_c_params(A / 100.0, fp, nu, gamma, t0), t)[1],   # m/s^2, closed form
        # (t: the record's times, a float64 array; the inputs were checked where they entered: INPUTS)
        meta=lambda t0, acc: (vp, fp, nu, gamma, t0, 1.0 / fp, A, float(np.abs(acc).max()) / G))


def _int_seed(seed):
    return integer(seed, "seed", 0)


def _distribution(log10_vp_mean, log10_fp_mean, log10_fp_sd):
    d = _c().ffi.new("cf_pulse_dist *")
    d.log10_vp_mean, d.log10_vp_sd = log10_vp_mean, _r11.SIGMA_LOG10_VP
    d.log10_fp_mean, d.log10_fp_sd = log10_fp_mean, log10_fp_sd
    d.nu_min, d.nu_max = NU_RANGE_RAD
    d.gamma_mean, d.gamma_sd, d.gamma_min = GAMMA_MEAN, GAMMA_SD, GAMMA_MIN
    return d


def sample_parameters(Mw, dist_km, n, seed, vp_scale=1.0, tp_model=_r11, amplitude=True, vp_model=_r11):
    """Latin-hypercube sample of ``n`` pulses for the scenario (Mw, dist_km km).

    One LHS of the unit 4-cube (:func:`~pycolfrag.ground_motion.sampling.latin_hypercube`, the numbers of
    ``scipy.stats.qmc.LatinHypercube(d=4)`` seeded with ``numpy.random.default_rng(seed)``; every one of
    the ``n`` strata of every dimension holds exactly one point), mapped by inverse CDFs in C (``cf_pulse_sample_map``, with the
    library's own log, pow and inverse normal CDF, so the same seed gives the same bits on
    every CPU; scipy's ``norm.ppf``/``truncnorm.ppf`` and numpy's ``power`` depend on the
    CPU's SIMD features in their last bits):

    * column 0: log10 Vp ~ N(log10 of the Eq. (6) mean -- or of another pulse-amplitude relation's
      (``vp_model``) -- times ``vp_scale``, 0.16);
    * column 1: log10 fp ~ N(log10 of the Eq. (7) mean, 0.18), or the mean and scatter of another
      pulse-period relation (``tp_model``, one of :data:`pycolfrag.ground_motion.registry.TP_MODELS`)
      on the same uniform column;
    * column 2: nu ~ U[-pi/2, pi/2];
    * column 3: gamma ~ N(1.8, 0.4) left-truncated at 1: ``ndtri(Phi(a) + u (1 - Phi(a)))``,
      a = (1 - 1.8) / 0.4 (equal to ``scipy.stats.truncnorm.ppf`` to about 1e-15).

    Vp and fp are log-normal, hence always > 0: the paper's truncation at 0 in linear units
    is no truncation at all in log space, and none is applied.

    Parameters
    ----------
    Mw : float
    dist_km : float, km
    n : int (>= 1), samples
    seed : int (>= 0), e.g. a 32-bit integer from ``numpy.random.SeedSequence``
    vp_scale : float (> 0), multiplies the Eq. (6) mean
    tp_model : module, a pulse-period relation (``log10_fp_mean(Mw)``, ``SIGMA_LOG10_FP``; default the
        paper's Eq. 7, :mod:`~pycolfrag.ground_motion.rupakhety_2011`). Callers with a name take
        :func:`pycolfrag.ground_motion.sample_pulse_parameters`, which looks it up in the registry.
    amplitude : bool, default True
        False: leave out ``A_cm_s`` (a peak search per sample, 90 % of the time of a 1000-sample draw);
        the other keys keep their bits, and a record made from a row finds its own A (the grid's rows).
    vp_model : module, a pulse-amplitude relation (``mean_vp_cm_s(Mw, dist_km, vp_scale)``; default the
        paper's Eq. (6), :mod:`~pycolfrag.ground_motion.rupakhety_2011`; one of
        :data:`pycolfrag.ground_motion.registry.VP_MODELS`): the median of Vp (the scatter stays Eq. (6)'s)

    Returns
    -------
    dict of 1-D float arrays of length n: ``Vp_cm_s``, ``fp_hz``, ``nu_rad``, ``gamma``,
    ``A_cm_s`` (envelope amplitude giving peak |V| = Vp; only with ``amplitude``), ``Tp_s`` (= 1/fp).
    """
    model = tp_model
    c = _c()
    log_vp = c.lib.cf_math_log10(vp_model.mean_vp_cm_s(Mw, dist_km, vp_scale))
    log_fp = model.log10_fp_mean(Mw)
    n_ = integer(n, "n", 1)
    u = np.ascontiguousarray(latin_hypercube(4, n_, _int_seed(seed)), dtype=np.float64)
    vp, fp, nu, gamma = (np.empty(n_) for _ in range(4))
    dist = _distribution(log_vp, log_fp, model.SIGMA_LOG10_FP)
    c.check(c.lib.cf_pulse_sample_map(dist, c.ptr(u), n_, c.ptr(vp), c.ptr(fp), c.ptr(nu), c.ptr(gamma)),
            what="pulse parameter sampling")
    out = {_VP.meta_key: vp, _FP.meta_key: fp, _NU.meta_key: nu, _GAMMA.meta_key: gamma}
    if amplitude:
        out[_A.meta_key] = np.asarray(envelope_amplitude(vp, fp, nu, gamma), dtype=float).reshape(n_)
    out[_TP.meta_key] = 1.0 / fp
    return out


def parameters_from_normals(Mw, dist_km, z, vp_scale=1.0, tp_model=_r11, vp_model=_r11) -> dict:
    """The pulse inputs (:data:`INPUTS`) of the scenario from four standard normals ``z`` (the quantiles
    named by :data:`NORMALS`): the distributions of :func:`sample_parameters` by inverse CDF at
    ``Phi(z)``, so that independent N(0, 1) normals give pulses of exactly those distributions and a
    pulse is a pure function of its normals (what subset simulation and importance sampling move in).

    * log10 Vp = log10 of the Eq. (6) (or ``vp_model``) mean times ``vp_scale`` + 0.16 z_vp (z_vp > 0: a
      stronger pulse);
    * log10 fp = the ``tp_model`` mean + its sd times z_fp (z_fp > 0: a higher fp, a *shorter* Tp);
    * nu = -pi/2 + pi Phi(z_nu);
    * gamma = 1.8 + 0.4 t, t the inverse CDF of the standard normal left-truncated at a = (1 - 1.8)/0.4
      at Phi(z_gamma): ``ndtri(Phi(a) + Phi(z_gamma) (1 - Phi(a)))`` below the truncated median,
      ``-ndtri(Phi(-z_gamma) (1 - Phi(a)))`` above it (accurate in the upper tail), and never below 1.

    With ``z = ndtri(u)`` of a Latin-hypercube row ``u`` the result is the row of
    :func:`sample_parameters` (the same ``cf_pulse_sample_map`` formulas through the same library
    functions): Vp and fp bit for bit (both compute ``10^(mean + sd ndtri(u))``); nu and gamma to
    rounding (about 1e-15 relative), since ``Phi(ndtri(u))`` is ``u`` only to rounding. Conversely
    ``cf_pulse_sample_map`` at ``u = Phi(z)`` gives bitwise this nu, and this gamma below the
    truncated median (tests/test_normals.py).

    Parameters
    ----------
    Mw, dist_km : float -- the scenario (the pulse model's range)
    z : array_like of 4 finite floats
    vp_scale : float (> 0), multiplies the Eq. (6) mean
    tp_model : module, a pulse-period relation (default the paper's Eq. 7)
    vp_model : module, a pulse-amplitude relation (default the paper's Eq. (6)), as in :func:`sample_parameters`

    Returns
    -------
    dict ``{Vp_cm_s, fp_hz, nu_rad, gamma}`` of floats.
    """
    z = float_array(z, "pulse normals")
    if z.size != len(NORMALS):
        raise ParameterError(f"pulse normals has {z.size} values; the pulse takes {len(NORMALS)} "
                             f"({', '.join(NORMALS)})")
    lib = _c().lib
    log_vp = lib.cf_math_log10(vp_model.mean_vp_cm_s(Mw, dist_km, vp_scale))
    log_fp = tp_model.log10_fp_mean(Mw)
    z_vp, z_fp, z_nu, z_gamma = (float(x) for x in z)
    vp = lib.cf_math_pow(10.0, log_vp + _r11.SIGMA_LOG10_VP * z_vp)
    fp = lib.cf_math_pow(10.0, log_fp + tp_model.SIGMA_LOG10_FP * z_fp)
    nu = NU_RANGE_RAD[0] + (NU_RANGE_RAD[1] - NU_RANGE_RAD[0]) * lib.cf_math_norm_cdf(z_nu)
    a = (GAMMA_MIN - GAMMA_MEAN) / GAMMA_SD
    phi_a, q_a = lib.cf_math_norm_cdf(a), lib.cf_math_norm_cdf(-a)
    p = phi_a + lib.cf_math_norm_cdf(z_gamma) * q_a
    t = lib.cf_math_ndtri(p) if p <= 0.5 else -lib.cf_math_ndtri(lib.cf_math_norm_cdf(-z_gamma) * q_a)
    gamma = max(GAMMA_MEAN + GAMMA_SD * t, GAMMA_MIN)
    return {_VP.meta_key: vp, _FP.meta_key: fp, _NU.meta_key: nu, _GAMMA.meta_key: gamma}
