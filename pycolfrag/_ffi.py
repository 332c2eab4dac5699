"""The one import site of the compiled library (``ffi``, ``lib``) and the one
place where C status codes become Python exceptions.

Arrays reach C through :func:`pycolfrag._validate.float_array` (type, shape and finiteness checks, a
C-contiguous float64 array) and :func:`ptr`, which gives the ``double *`` for it (``ffi.from_buffer``
does not check dtype, so never skip the conversion).
"""
from __future__ import annotations

import numpy as np

from . import __version__
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


def ptr(arr: np.ndarray):
    """``double *`` view of a float64 C-contiguous array (no copy)."""
    assert arr.dtype == np.float64 and arr.flags.c_contiguous
    return ffi.from_buffer("double[]", arr)
