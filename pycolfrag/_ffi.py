"""The one import site of the compiled library (``ffi``, ``lib``) and the one
place where C status codes become Python exceptions.

Helpers for passing arrays: :func:`as_double_array` checks shape and finiteness and
returns a C-contiguous float64 array; :func:`ptr` gives the ``double *`` for it
(``ffi.from_buffer`` does not check dtype, so never skip the conversion).
"""
from __future__ import annotations

import numpy as np

from . import __version__
from ._validate import positive_float  # noqa: F401  (re-exported: modules import it from here)
from .errors import ModelRangeError, ParameterError, PycolfragError, SolverError

try:
    from ._libcolfrag import ffi, lib
except ImportError as exc:  # pragma: no cover - only when the build is missing
    raise ImportError(
        "pycolfrag's C library is not built: run `pip install -e .` (or `make build`) "
        f"in the source tree ({exc})"
    ) from exc

_c_version = ffi.string(lib.cf_common_version()).decode()
if _c_version != __version__:  # pragma: no cover - stale build
    raise ImportError(
        f"pycolfrag {__version__} found C library {_c_version}: rebuild with `pip install -e .`"
    )

_EXCEPTIONS = {
    lib.CF_EINVAL: ParameterError,
    lib.CF_ERANGE: ModelRangeError,
    lib.CF_EUNSTABLE: SolverError,
    lib.CF_ENOMEM: MemoryError,
}


def check(status: int, message=None, what: str = "") -> None:
    """Raise the exception that matches a C status code (no-op for CF_OK).

    ``message`` may be a Python string or a cffi ``char[]`` (the message buffer of
    a C object).
    """
    if status == lib.CF_OK:
        return
    if message is not None and not isinstance(message, str):
        message = ffi.string(message).decode(errors="replace")
    name = ffi.string(lib.cf_common_status_name(status)).decode()
    text = message or name
    if what:
        text = f"{what}: {text}"
    exc = _EXCEPTIONS.get(status, PycolfragError)
    raise exc(f"{text} [{name}]")


def as_double_array(x, name: str, ndim: int = 1, allow_empty: bool = False) -> np.ndarray:
    """Return ``x`` as a C-contiguous float64 array after checking it.

    Raises :class:`ParameterError` naming ``name`` for None, a string, a masked array (its mask
    would be lost), complex values, a wrong number of dimensions, an empty array (unless allowed)
    or a non-finite value (with its index).
    """
    if x is None or isinstance(x, (str, bytes)):
        raise ParameterError(f"{name} must be an array of numbers, got {type(x).__name__}")
    if isinstance(x, np.ma.MaskedArray):
        raise ParameterError(f"{name} is a masked array: fill or drop the masked samples first "
                             "(e.g. x.filled(0.0)); a mask would be silently lost")
    if np.iscomplexobj(x):
        raise ParameterError(f"{name} has complex values: accelerations must be real")
    try:
        arr = np.ascontiguousarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be an array of numbers ({exc})") from None
    if arr.ndim != ndim:
        raise ParameterError(f"{name} must be {ndim}-D, got shape {arr.shape}")
    if arr.size == 0 and not allow_empty:
        raise ParameterError(f"{name} is empty")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        raise ParameterError(
            f"{name} has a non-finite value {float(arr[tuple(idx)])!r} at index {tuple(int(i) for i in idx)}"
        )
    return arr


def ptr(arr: np.ndarray):
    """``double *`` view of a float64 C-contiguous array (no copy)."""
    assert arr.dtype == np.float64 and arr.flags.c_contiguous
    return ffi.from_buffer("double[]", arr)
