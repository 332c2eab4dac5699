"""The entry-type policy of the public API, in one place: a bad argument raises ParameterError naming it.

* A number is a real number: ``int``, ``float``, a numpy integer or floating scalar (or a 0-d array of
  one). Strings are refused even when ``float()`` would read them (``"0.01"`` means the input was written
  wrong, e.g. a quoted number in a file), and so are ``bool`` and ``numpy.bool_`` (``True`` would
  silently become 1), complex numbers and None.
* An integer (a seed, a count) is an ``int`` or numpy integer: not a bool, not ``10.0``.
* A flag is ``True`` or ``False`` (Python's or numpy's bool) and nothing else: an integer where a
  yes/no is asked (``history=1``) is as likely a misplaced count as a flag.
* An array of numbers holds integers or floats (numpy dtype kinds ``i``, ``u``, ``f``, or Python
  numbers in a list): string, bool, complex, object and masked arrays are refused, then the values must
  be finite (unless a caller allows NaN, e.g. for the EDPs of collapsed runs).
"""
from __future__ import annotations

import math
import numbers
import operator

import numpy as np

from pycolfrag.core.errors import ParameterError

__all__ = ["real", "finite_float", "positive_float", "integer", "flag", "float_array"]


def _is_bool(value) -> bool:
    return isinstance(value, (bool, np.bool_))


def real(value, name: str) -> float:
    """``value`` as a float if it is a real number (see the module docstring), else ParameterError naming it."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise ParameterError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    return float(value)


def finite_float(value, name: str) -> float:
    """``value`` as a finite float, else :class:`ParameterError` naming it."""
    v = real(value, name)
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    return v


def positive_float(value, name: str, allow_zero: bool = False) -> float:
    """``value`` as a finite float > 0 (or >= 0 with ``allow_zero``), else :class:`ParameterError`."""
    v = real(value, name)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ParameterError(f"{name} must be finite and {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return v


def integer(value, name: str, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` as an int if it is an integer (not a bool, not a float) in [minimum, maximum]."""
    if _is_bool(value):
        raise ParameterError(f"{name} must be an integer, got the bool {value!r}")
    try:
        v = operator.index(value)
    except TypeError:
        raise ParameterError(f"{name} must be an integer, got {type(value).__name__} {value!r}") from None
    if minimum is not None and v < minimum:
        raise ParameterError(f"{name} must be >= {minimum}, got {value!r}")
    if maximum is not None and v > maximum:
        raise ParameterError(f"{name} must be <= {maximum}, got {value!r}")
    return int(v)


def flag(value, name: str) -> bool:
    """``value`` as a bool if it is True or False (Python's or numpy's)."""
    if _is_bool(value):
        return bool(value)
    raise ParameterError(f"{name} must be True or False, got {type(value).__name__} {value!r}")


def float_array(x, name: str, ndim: int | None = 1, allow_empty: bool = False, finite: bool = True) -> np.ndarray:
    """``x`` as a C-contiguous float64 array after the checks of the module docstring.

    ``ndim``: required number of dimensions (None: any). ``finite=False`` lets NaN and inf through.
    The message names ``name`` and, for a non-finite value, its index.
    """
    if x is None or isinstance(x, (str, bytes)):
        raise ParameterError(f"{name} must be an array of numbers, got {type(x).__name__} {x!r}")
    if isinstance(x, np.ma.MaskedArray):
        raise ParameterError(f"{name} is a masked array: fill or drop the masked samples first "
                             "(e.g. x.filled(0.0)); a mask would be silently lost")
    try:
        raw = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be an array of numbers ({exc})") from None
    kind = raw.dtype.kind
    if kind == "c":
        raise ParameterError(f"{name} has complex values: it must hold real numbers")
    if kind not in "iuf":
        what = {"b": "booleans", "U": "strings", "S": "bytes", "O": "Python objects"}.get(kind, f"dtype {raw.dtype}")
        raise ParameterError(f"{name} must be an array of numbers (integers or floats), got an array of {what}"
                             f"{': ' + repr(raw.ravel()[0]) if raw.size else ''}")
    arr = np.ascontiguousarray(raw, dtype=np.float64)
    if ndim is not None and arr.ndim != ndim:
        raise ParameterError(f"{name} must be {ndim}-D, got shape {arr.shape}")
    if arr.size == 0 and not allow_empty:
        raise ParameterError(f"{name} is empty")
    if finite:
        bad = ~np.isfinite(arr)
        if bad.any():
            idx = np.argwhere(bad)[0]
            raise ParameterError(
                f"{name} has a non-finite value {float(arr[tuple(idx)])!r} at index {tuple(int(i) for i in idx)}")
    return arr
