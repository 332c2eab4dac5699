"""BLAS threads of a ``pycolfrag`` command: one per process unless the user says otherwise.

The analysis commands (report, risk, figures, ...) run many small fits (``scipy.optimize`` on a few
hundred runs, bootstrap resamples): OpenBLAS's default of a thread per core makes each tiny matrix
operation wake and join every thread, and on a loaded or shared machine they wait for each other
(``pycolfrag report`` of a full grid took 3 min 53 s of wall time for 104 s of CPU; 40 s with one thread,
the same output). The grid's ranks want one thread each too (docs/grid.md). ``pycolfrag`` loads numpy (and
its OpenBLAS) before any command runs, so setting ``OMP_NUM_THREADS`` then is too late for numpy's
library: :func:`limit_blas_threads` sets the variables for what loads later (scipy's own OpenBLAS,
child processes, MPI ranks started from here) and sets the thread count of the BLAS libraries already
loaded, through threadpoolctl when it is installed, else through the libraries' own
``*_set_num_threads`` (OpenBLAS in numpy's and scipy's wheels, MKL, BLIS). :func:`pycolfrag.cli.main.main`
calls it for every command. A user's own ``OPENBLAS_NUM_THREADS`` or ``OMP_NUM_THREADS`` is kept and
applied.
"""
from __future__ import annotations

import ctypes
import os
import re

__all__ = ["ENV_VARS", "limit_blas_threads", "blas_threads", "threads_asked"]

#: The variables BLAS and OpenMP runtimes read when they load (all set, unless already set).
ENV_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
            "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")

#: (getter, setter) of the thread count of each BLAS library, by the names their builds export.
_API = (("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
        ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
        ("openblas_get_num_threads64_", "openblas_set_num_threads64_"),
        ("openblas_get_num_threads", "openblas_set_num_threads"),
        ("MKL_Get_Max_Threads", "MKL_Set_Num_Threads"),
        ("bli_thread_get_num_threads", "bli_thread_set_num_threads"))
_LIB = re.compile(r"(/\S*(?:openblas|mkl_rt|blis)\S*\.(?:so|dylib)[.\d]*)")


def threads_asked() -> int:
    """The threads the user asked for (``OPENBLAS_NUM_THREADS``, else ``OMP_NUM_THREADS``: a positive
    integer), else 1."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
        text = os.environ.get(var, "").split(",")[0].strip()
        if text.isdigit() and int(text) > 0:
            return int(text)
    return 1


def _loaded_libraries() -> list[str]:
    """Paths of the BLAS libraries this process has loaded (``/proc/self/maps``; [] where there is none)."""
    try:
        with open("/proc/self/maps") as fh:
            return sorted(set(_LIB.findall(fh.read())))
    except OSError:
        return []


def _api(path):
    try:
        lib = ctypes.CDLL(path)   # already loaded: the same handle, nothing new runs
    except OSError:
        return None
    for get, put in _API:
        if hasattr(lib, get) and hasattr(lib, put):
            return getattr(lib, get), getattr(lib, put)
    return None


def blas_threads() -> dict:
    """``{library path: its thread count now}`` for every BLAS library loaded."""
    out = {}
    for path in _loaded_libraries():
        api = _api(path)
        if api is not None:
            out[path] = int(api[0]())
    return out


def limit_blas_threads(n: int | None = None) -> dict:
    """Set every variable of :data:`ENV_VARS` not already set to ``n`` (default :func:`threads_asked`),
    and the thread count of every BLAS library already loaded to ``n``; returns :func:`blas_threads`."""
    n = threads_asked() if n is None else int(n)
    for var in ENV_VARS:
        os.environ.setdefault(var, str(n))
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        threadpool_limits = None
    if threadpool_limits is not None:
        threadpool_limits(limits=n, user_api="blas")
    else:
        for path in _loaded_libraries():
            api = _api(path)
            if api is not None:
                api[1](ctypes.c_int(n))
    return blas_threads()
