"""The one import site of the compiled library (``ffi``, ``lib``) and the one
place where C status codes become Python exceptions.

:func:`segment_arrays` is the one text of a column's geometry as C reads it (``cf_geometry_segment``),
read by the one set-up of every structure (:mod:`pycolfrag.solver.scene_setup`, a plain column as a one-column scene).

Arrays reach C through :func:`pycolfrag.core.validate.float_array` (type, shape and finiteness checks, a
C-contiguous float64 array) and :func:`ptr`, which gives the ``double *`` for it (``ffi.from_buffer``
does not check dtype, so never skip the conversion).
"""
from __future__ import annotations

import numpy as np

from pycolfrag.core.errors import ModelRangeError, ParameterError, PycolfragError, SolverError
from pycolfrag.core.version import __version__

try:
    from pycolfrag._libcolfrag import ffi, lib
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


def segment_arrays(blocks):
    """The ``cf_geometry_segment[]`` of ``blocks``' segments, block by block, and the ``int[]`` of
    each block's segment count (what ``cf_solver_setup_joints`` and ``cf_solver_scene`` read)."""
    segs = [s for b in blocks for s in b.segments]
    arr = ffi.new("cf_geometry_segment[]", len(segs))
    for i, s in enumerate(segs):
        arr[i].height = s.height
        arr[i].r_bottom = s.r_bottom
        arr[i].r_top = s.r_top
        arr[i].phase_rad = s.phase_rad
        arr[i].n_sides = int(s.n_sides)
        arr[i].aspect = s.aspect
    nseg = ffi.new("int[]", [len(b.segments) for b in blocks])
    return arr, nseg
