"""Atkinson & Silva (2000) stochastic point-source model, simulated in the time
domain by Boore's SMSIM recipe (Boore 2003, PAGEOPH 160, 635-676).

The numbers of the model are in ``pycolfrag/data/as00.json`` (loaded here as
:data:`PARAMS`); the generator itself is C (``csrc/stochastic.c``): Gaussian white
noise from a seeded xoshiro256** stream, Saragoni-Hart window over ``t_eta = 2
T_gm``, FFT of the zero-padded power-of-two record, division by the RMS spectral
amplitude (DC and Nyquist excluded), multiplication by the target Fourier
amplitude ``A(f)``, inverse FFT and division by ``dt``. See ``docs/stochastic.md``
for every choice (padding, window length, trimming, FFT) and the checks.

A record is a pure function of its white noise, ``n_normals(Mw, dist_km, dt)`` standard normals:
``simulate(..., normals=z)`` makes it from given normals (what a sampler moving in the space of the
normals needs), and ``draw_normals(Mw, dist_km, seed)`` are the normals a seed draws, so
``simulate(..., normals=draw_normals(..., seed))`` is ``simulate(..., seed)`` bit for bit.

Accepted scenario range (the limits this project adopted for AS00; the paper's scenarios,
M 5.5-7.5 at 5-20 km, lie well inside): ``4.0 <= Mw <= 8.0`` and ``0 < dist_km <= 200``;
outside, or non-finite, :class:`~pycolfrag.core.errors.ModelRangeError` is raised.
"""
from __future__ import annotations

import json
import threading
from collections import OrderedDict
from importlib import resources

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import check, ffi, lib, ptr
from pycolfrag.core.names import Parameter
from pycolfrag.core.validate import float_array, integer, real

__all__ = ["NAME", "KIND", "PARAMETERS", "PARAMS", "check_scenario", "fourier_amplitude", "duration_s", "simulate",
           "n_normals", "draw_normals", "window"]

#: The model's parameters (a copy of ``reference/as00.json`` shipped with the package).
PARAMS: dict = json.loads(resources.files("pycolfrag").joinpath("data/as00.json").read_text("utf-8"))


def _limits():
    v = ffi.new("double[5]")
    lib.cf_stochastic_limits(v, v + 1, v + 2, v + 3, v + 4)
    return (v[0], v[1]), v[2], v[3], v[4]


#: Accepted ranges (defined in csrc/stochastic.h): Mw, max distance (km), dt (s).
MW_RANGE, DIST_MAX_KM, DT_MIN, DT_MAX = _limits()

#: Name of the model (not in :mod:`pycolfrag.ground_motion.registry`: its ranges are the C generator's,
#: read above when this module loads, and it adds no field to a sample row).
NAME = "atkinson_silva_2000"
#: The high-frequency part of a near-fault record.
KIND = "high_frequency"
#: The generator's inputs and the ranges it accepts (the C library's, so one text: csrc/stochastic.h).
PARAMETERS = (
    Parameter("Mw", "", MW_RANGE, "moment magnitude", "Mw"),
    Parameter("R", "km", (0.0, DIST_MAX_KM), "closest distance to the fault", "dist_km", low_open=True),
    Parameter("dt", "s", (DT_MIN, DT_MAX), "time step of the record", "dt_s"),
)
GENERATOR = "SMSIM time-domain recipe, Atkinson & Silva (2000), C (xoshiro256**, own radix-2 FFT)"


def check_scenario(Mw, dist_km) -> tuple[float, float]:
    """Return ``(Mw, dist_km)`` as floats after checking the model's range.

    Parameters
    ----------
    Mw : float
        Moment magnitude, in [4.0, 8.0].
    dist_km : float
        Closest distance to the fault, km, in (0, 200].

    Raises
    ------
    ModelRangeError
        For a value outside the range or non-finite (the message names it).
    """
    mw = real(Mw, "Mw")
    d = real(dist_km, "dist_km")
    msg = ffi.new("char[]", lib.CF_MSG_LEN)
    check(lib.cf_stochastic_check_scenario(mw, d, msg), msg)
    return mw, d


def _check_dt(dt) -> float:
    return PARAMETERS[2].check(dt, "dt", error=ParameterError)   # the declared range, one text


def _check_seed(seed) -> int:
    return integer(seed, "seed", 0, 2**64 - 1)


def fourier_amplitude(f_hz, Mw, dist_km) -> np.ndarray:
    """Target Fourier amplitude spectrum of acceleration, m/s (SI).

    ``A(f) = C M0 S(f) G(R) exp(-pi f R / (Q(f) cQ)) amp(f) exp(-pi kappa f) /
    sqrt(1 + (f/fmax)^8) (2 pi f)^2`` of ``as00.json`` (there in cm/s), with A(0) = 0.

    Parameters
    ----------
    f_hz : array_like
        Frequencies, Hz, finite and >= 0 (any shape).
    Mw, dist_km : float
        Scenario (see :func:`check_scenario`).
    """
    mw, d = check_scenario(Mw, dist_km)
    f = np.ascontiguousarray(f_hz, dtype=np.float64)
    flat = f.reshape(-1).copy()
    out = np.empty_like(flat)
    msg = ffi.new("char[]", lib.CF_MSG_LEN)
    check(lib.cf_stochastic_fas(mw, d, ptr(flat), flat.size, ptr(out), msg), msg)
    return out.reshape(f.shape)


def duration_s(Mw, dist_km) -> float:
    """Ground-motion duration ``T_gm = 0.5/fa + 0.05 R``, s (as00.json "duration")."""
    mw, d = check_scenario(Mw, dist_km)
    out = ffi.new("double *")
    msg = ffi.new("char[]", lib.CF_MSG_LEN)
    check(lib.cf_stochastic_duration(mw, d, out, msg), msg)
    return float(out[0])


def window(t_s, t_eta_s) -> np.ndarray:
    """Saragoni-Hart window (peak 1 at ``eps*t_eta``, ``eta`` at ``t_eta``) at times ``t_s``."""
    t = np.asarray(t_s, dtype=np.float64)
    return np.vectorize(lambda x: lib.cf_stochastic_window(float(x), float(t_eta_s)), otypes=[float])(t)


class _Generator:
    """A C generator set up for one (Mw, dist_km, dt); owns its buffers."""

    def __init__(self, mw: float, d: float, dt: float):
        self.ptr = ffi.gc(lib.cf_stochastic_create(), lib.cf_stochastic_free)
        if self.ptr == ffi.NULL:  # pragma: no cover
            raise MemoryError("cf_stochastic_create failed")
        self.lock = threading.Lock()
        df = ffi.new("cf_stochastic_def *")
        lib.cf_stochastic_def_default(df)
        df.mw, df.dist_km, df.dt = mw, d, dt
        check(lib.cf_stochastic_setup(self.ptr, df), lib.cf_stochastic_message(self.ptr))
        info = ffi.new("cf_stochastic_info *")
        check(lib.cf_stochastic_get_info(self.ptr, info))
        self.info = {k: getattr(info, k) for k in dir(info)}
        self.def_ = {"pre_s": df.pre_s, "tail_s": df.tail_s, "pad_min_s": df.pad_s}

    def run(self, seed: int) -> np.ndarray:
        acc = np.empty(self.info["n_out"], dtype=np.float64)
        with self.lock:
            check(lib.cf_stochastic_run(self.ptr, seed, ptr(acc), acc.size), lib.cf_stochastic_message(self.ptr))
        return acc

    def draw(self, seed: int) -> np.ndarray:
        z = np.empty(self.info["n_window"], dtype=np.float64)
        with self.lock:
            check(lib.cf_stochastic_draw_normals(self.ptr, seed, ptr(z), z.size), lib.cf_stochastic_message(self.ptr))
        return z

    def run_normals(self, z: np.ndarray) -> np.ndarray:
        acc = np.empty(self.info["n_out"], dtype=np.float64)
        with self.lock:
            check(lib.cf_stochastic_run_normals(self.ptr, ptr(z), z.size, ptr(acc), acc.size),
                  lib.cf_stochastic_message(self.ptr))
        return acc


_CACHE: OrderedDict = OrderedDict()
_CACHE_LOCK = threading.Lock()
_CACHE_SIZE = 8


def _generator(mw: float, d: float, dt: float) -> _Generator:
    key = (mw, d, dt)
    with _CACHE_LOCK:
        gen = _CACHE.get(key)
        if gen is not None:
            _CACHE.move_to_end(key)
            return gen
    gen = _Generator(mw, d, dt)
    with _CACHE_LOCK:
        _CACHE[key] = gen
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    return gen


def n_normals(Mw, dist_km, dt=0.005) -> int:
    """How many standard normals a record of the scenario is made from: the white-noise samples over
    the Saragoni-Hart window, ``floor(2 T_gm / dt) + 1`` (``n_window`` of :func:`simulate`'s info;
    about 2 400 at Mw 6.25, 10 km, dt 0.005 s)."""
    mw, d = check_scenario(Mw, dist_km)
    return int(_generator(mw, d, _check_dt(dt)).info["n_window"])


def draw_normals(Mw, dist_km, seed, dt=0.005) -> np.ndarray:
    """The :func:`n_normals` standard normals that :func:`simulate` draws for ``seed`` (xoshiro256**
    seeded by splitmix64, Marsaglia's polar method, in order: ``csrc/rng.h``), so that
    ``simulate(Mw, dist_km, normals=draw_normals(Mw, dist_km, seed))`` is ``simulate(Mw, dist_km, seed)``
    bit for bit. Arguments and errors as :func:`simulate`."""
    mw, d = check_scenario(Mw, dist_km)
    return _generator(mw, d, _check_dt(dt)).draw(_check_seed(seed))


def _exactly_one(seed, normals) -> None:
    """ParameterError unless exactly one of ``seed`` and ``normals`` is given (not None)."""
    if (seed is None) == (normals is None):
        raise ParameterError("give exactly one of seed and normals (the record's white noise: a seed draws it, "
                             f"normals give it), got seed={seed!r} and normals "
                             f"{'None' if normals is None else 'given'}")


def _noise_source(seed, normals, n_window: int):
    """The checked seed (int) or normals (float64 array of ``n_window`` finite values): exactly one."""
    _exactly_one(seed, normals)
    if normals is None:
        return _check_seed(seed)
    z = float_array(normals, "normals")
    if z.size != n_window:
        raise ParameterError(f"normals has {z.size} values; the scenario's white noise takes n_normals = {n_window} "
                             "(the samples of its window)")
    return z


def simulate(Mw, dist_km, seed=None, dt=0.005, normals=None):
    """One high-frequency acceleration record of the scenario (C generator).

    Parameters
    ----------
    Mw : float
        Moment magnitude, [4.0, 8.0].
    dist_km : float
        Closest distance to the fault, km, (0, 200].
    seed : int or None
        0 <= seed < 2**64: the noise drawn from it (:func:`draw_normals`); the record depends
        only on (Mw, dist_km, seed, dt), bit for bit, in any process.
    dt : float
        Time step, s, in [1e-4, 0.02] (default 0.005).
    normals : array_like or None
        Instead of ``seed``: the white noise itself, :func:`n_normals` finite standard normals
        (1-D); the record is a pure function of them (and unchanged by a positive factor on all of
        them, which its RMS normalisation removes).

    Returns
    -------
    acc : ndarray of float64
        Acceleration, m/s^2, from ``pre_s`` = 1 s before the window start to 3 s
        after the window end.
    info : dict
        ``duration_s`` (T_gm), ``window_s`` (t_eta = 2 T_gm), ``window_start_s`` (time
        of the window start in ``acc``), ``nfft``, ``n_window``, ``dt``, ``generator``, and the
        source/path quantities ``fa_hz``, ``fb_hz``, ``eps_source``, ``m0_dyne_cm``,
        ``h_km``, ``r_km``, ``pad_s``.

    Raises
    ------
    ModelRangeError
        Mw or dist_km outside the range or non-finite.
    ParameterError
        dt or seed invalid; both or neither of seed and normals; normals of the wrong length or
        not finite.
    """
    mw, d = check_scenario(Mw, dist_km)
    step = _check_dt(dt)
    gen = _generator(mw, d, step)
    noise = _noise_source(seed, normals, gen.info["n_window"])
    acc = gen.run(noise) if normals is None else gen.run_normals(noise)
    return acc, _info(gen, step)


def _info(gen: _Generator, step: float) -> dict:
    """The ``info`` of :func:`simulate` (the same for every record of a generator)."""
    i = gen.info
    return {
        "duration_s": i["duration_s"],
        "window_s": i["window_s"],
        "window_start_s": i["window_start_s"],
        "nfft": i["nfft"],
        "n_window": i["n_window"],
        "dt": step,
        "pad_s": i["pad_s"],
        "fa_hz": i["fa_hz"],
        "fb_hz": i["fb_hz"],
        "eps_source": i["eps_source"],
        "m0_dyne_cm": i["m0_dyne_cm"],
        "h_km": i["h_km"],
        "r_km": i["r_km"],
        "pre_s": gen.def_["pre_s"],
        "tail_s": gen.def_["tail_s"],
        "generator": GENERATOR,
    }
