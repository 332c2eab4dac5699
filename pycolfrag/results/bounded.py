"""Reading a results file without trusting it: in a forked child, with a deadline, checksums verified.

Some damage (e.g. zeroed bytes in an HDF5 B-tree) makes the HDF5 library loop forever while holding
the GIL, and a failed write can crash the process: in a child, this process survives both.
"""
from __future__ import annotations

import os
import pickle
import select
import signal
import time
from pathlib import Path

import numpy as np

from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results.checksums import ResultsDamagedError, all_attrs, verify_checksums
from pycolfrag.results.layout import ROW_CRC, h5open

#: Seconds a results file may take to open and read fully before it is called damaged (a damaged
#: HDF5 file can make the HDF5 library loop forever; the read runs in a forked child that is killed
#: at the deadline). Environment variable ``PYCOLFRAG_OPEN_TIMEOUT_S`` overrides it; 1 s is added
#: per 50 MB of file.
OPEN_TIMEOUT_S = 30.0


def _read_h5(path: Path, any_layout: bool = False, verify: bool = True) -> dict:
    """Read every dataset and attribute; verify the stored checksums (:func:`.checksums.verify_checksums`).
    Raises on any damage.

    ``any_layout``: also read a file in the documented layout that ``run_grid.py`` did not write
    (a ``/samples`` group, no ``grid_signature``; ``/spectra`` optional)."""
    with h5open(path, "r") as f:
        if "samples" not in f or ("grid_signature" not in f.attrs and not any_layout):
            raise ResultsFileError(f"{path} is not a pycolfrag grid results file (no grid_signature attribute); "
                                   "use --overwrite to replace it or --out for another file")
        samples = {name: f["samples"][name][...] for name in f["samples"]}
        spectra = {name: f["spectra"][name][...] for name in f["spectra"]} if "spectra" in f else {}
        periods = (np.asarray(f["spectra"].attrs["periods_s"], dtype=float)
                   if "spectra" in f and "periods_s" in f["spectra"].attrs else np.zeros(0))
        row_crc = f[ROW_CRC][...] if ROW_CRC in f else None
        every = all_attrs(f)
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in every["/"].items()}
    raw = {"samples": samples, "spectra": spectra, "periods": periods, "attrs": attrs}
    if verify:
        verify_checksums(path, dict(raw, row_crc=row_crc), every)
    return raw


def _open_timeout(path: Path, timeout_s) -> float:
    if timeout_s is None:
        timeout_s = float(os.environ.get("PYCOLFRAG_OPEN_TIMEOUT_S", OPEN_TIMEOUT_S))
        try:
            timeout_s += os.path.getsize(path) / 50e6
        except OSError:
            pass
    return float(timeout_s)


def read_h5_bounded(path: Path, timeout_s=None, any_layout: bool = False, verify: bool = True) -> dict:
    """:func:`_read_h5` in a forked child (:func:`in_child`), killed after ``timeout_s`` s.

    Some damage (e.g. zeroed bytes in an HDF5 B-tree) makes the HDF5 library loop forever while
    holding the GIL: neither a thread nor a signal can stop it in this process, but a child can be
    killed. Raises :class:`ResultsDamagedError` for a file that errors, fails its checksums or does
    not answer in time; ``FileNotFoundError`` if absent; other :class:`ResultsFileError` as is.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"results file not found: {path}")
    timeout_s = _open_timeout(path, timeout_s)
    try:
        return in_child(_read_h5, path, any_layout, verify, timeout_s=timeout_s)
    except ChildLost as lost:
        if lost.timed_out:
            raise ResultsDamagedError(f"{path} did not open within {timeout_s:.0f} s (the HDF5 library stalled on "
                                      "it: the file is damaged)", path=path) from None
        raise ResultsDamagedError(f"{path}: reading it crashed the reading process (the file is damaged)",
                                  path=path) from None
    except ResultsFileError:
        raise
    except Exception as exc:  # noqa: BLE001 -- whatever the HDF5 library raised: the file cannot be read
        raise ResultsDamagedError(f"{path} cannot be read ({type(exc).__name__}: {exc}): the file is "
                                  "damaged", path=path) from None


class ChildLost(Exception):
    """The child of :func:`in_child` sent no answer: it died (``status``) or ran out of time."""

    def __init__(self, status=None, timed_out: bool = False):
        super().__init__(f"child ended without an answer (status {status}, timed out {timed_out})")
        self.status, self.timed_out = status, timed_out


def in_child(fn, *args, timeout_s: float | None = None, quiet: bool = False):
    """``fn(*args)`` in a forked child; return what it returned, or raise what it raised (both pickled
    back through a pipe). :class:`ChildLost` when the child died without a word (a crash of the
    HDF5 library) or, with ``timeout_s``, did not answer in time (it is killed then).

    The HDF5 library can hang on a damaged file holding the GIL, or crash the process when a write
    fails (a full disk); in a child, this process survives both. ``quiet``: the child's stderr goes
    to /dev/null (the HDF5 library's clean-up noise after a failed write)."""
    return start_child(fn, *args, quiet=quiet).result(timeout_s)


def start_child(fn, *args, quiet: bool = False) -> "Child":
    """:func:`in_child` started and not waited for: this process goes on while the child works (rank 0
    hands out rows while a child creates the results file); :meth:`Child.result` waits for it."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: run, send the result (or the error) back, exit without clean-up handlers
        code = 0
        try:
            os.close(r)
            if quiet:
                os.dup2(os.open(os.devnull, os.O_WRONLY), 2)
            try:
                out = ("ok", fn(*args))
            except BaseException as exc:  # noqa: BLE001 -- every failure goes to the parent
                try:
                    pickle.dumps(exc)
                    out = ("err", exc)
                except Exception:
                    out = ("err", RuntimeError(f"{type(exc).__name__}: {exc}"))
            view = memoryview(pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL))
            while view:
                view = view[os.write(w, view):]
        except BaseException:
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    return Child(pid, r)


class Child:
    """A child of :func:`start_child`: its process id and the pipe its answer comes through."""

    def __init__(self, pid: int, fd: int):
        self.pid, self._fd = pid, fd

    def result(self, timeout_s: float | None = None):
        """Wait for the child (killed after ``timeout_s``); what ``fn`` returned, or raise what it raised,
        or :class:`ChildLost`."""
        r, pid = self._fd, self.pid
        chunks, timed_out = [], False
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        try:
            while True:
                left = 1.0 if deadline is None else deadline - time.monotonic()
                if left <= 0:
                    timed_out = True
                    break
                ready, _, _ = select.select([r], [], [], min(left, 1.0))
                if ready:
                    b = os.read(r, 1 << 20)
                    if not b:
                        break
                    chunks.append(b)
        finally:
            os.close(r)
            if timed_out:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            _, status = os.waitpid(pid, 0)
        if timed_out:
            raise ChildLost(status, timed_out=True)
        try:
            kind, val = pickle.loads(b"".join(chunks))
        except Exception:
            raise ChildLost(status) from None
        if kind == "err":
            raise val
        return val
