"""Combination of the stochastic high-frequency record with the velocity pulse
(the paper's steps 3-6; C kernel ``csrc/combine.c``).

The pulse must already be aligned in time with the HF record (step 2 is the
caller's: :func:`pycolfrag.ground_motion.synthesize`).
"""
from __future__ import annotations

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import check, ffi, lib, ptr
from pycolfrag.core.validate import float_array

__all__ = ["combine"]


def combine(hf_acc, pulse_acc) -> np.ndarray:
    """Combine a high-frequency record with an aligned pulse (same length, same dt).

    Both records are zero padded to a power of two >= 2n and Fourier transformed;
    the result's Fourier amplitude is ``max(|HF| - |P|, 0)`` with the phase of HF
    (steps 3-5), transformed back, and the pulse is added (step 6).

    Parameters
    ----------
    hf_acc, pulse_acc : array_like, 1-D, same length
        Accelerations (any one unit, e.g. m/s^2) on the same time axis.

    Returns
    -------
    ndarray of float64, same length and unit.

    Raises
    ------
    ParameterError
        Mismatched lengths, wrong shape, empty or non-finite input.
    """
    hf = float_array(hf_acc, "hf_acc")
    p = float_array(pulse_acc, "pulse_acc")
    if hf.size != p.size:
        raise ParameterError(f"hf_acc has {hf.size} samples but pulse_acc has {p.size}: they must match")
    out = np.empty_like(hf)
    msg = ffi.new("char[]", lib.CF_MSG_LEN)
    check(lib.cf_combine_subtract_plan(_plan(hf.size), ptr(hf), ptr(p), hf.size, ptr(out), msg), msg)
    return out


_PLANS: dict = {}   # FFT length -> plan (read-only in C, so shared by threads); a handful of lengths


def _plan(n):
    """The FFT plan of the combination of ``n`` samples, built once per length (building one
    costs about a third of a combination: twiddles by cos/sin)."""
    nfft = lib.cf_combine_nfft(n)
    if nfft < 0:
        return ffi.NULL   # cf_combine_subtract_plan reports the bad n
    plan = _PLANS.get(nfft)
    if plan is None:
        box = ffi.new("cf_fft_plan **")
        check(lib.cf_fft_plan_create(nfft, box), what=f"FFT plan of length {nfft}")
        plan = _PLANS.setdefault(nfft, ffi.gc(box[0], lib.cf_fft_plan_free))
    return plan
