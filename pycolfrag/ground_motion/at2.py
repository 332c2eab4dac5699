"""PEER NGA ``.AT2`` acceleration files (natural records) -> :class:`Record`.

The format (PEER NGA-West/West2 flatfile downloads): four header lines, then the samples in g,
whitespace separated, several per line::

    PEER NGA STRONG MOTION DATABASE RECORD
    IMPERIAL VALLEY 10/15/79 2316, EL CENTRO ARRAY #6, 230
    ACCELERATION TIME SERIES IN UNITS OF G
    NPTS=  3930, DT=   .0100 SEC
      .1234E-02  .2345E-02 ...

The fourth line holds NPTS and DT, either as ``NPTS= 3930, DT= .0100 SEC`` (NGA-West2) or in the
older form ``3930   .0100   NPTS, DT`` (two leading numbers). Values are converted from g to m/s^2
with g = 9.81 m/s^2 (the package's g, :data:`pycolfrag.intensity.G`).

Errors: :class:`~pycolfrag.errors.RecordFileError` (a ``ValueError``) naming the file and line
for a malformed header, a value that is not a number or not finite, or a sample count that
differs from NPTS; ``FileNotFoundError`` (an ``OSError``) for a missing file.
"""
from __future__ import annotations

import math
import os
import re

import numpy as np

from ..errors import RecordFileError
from ..intensity import G   # m/s^2, the package's g (re-exported: at2.G)
from .record import Record

__all__ = ["read_at2", "G"]


_NEW = re.compile(r"NPTS\s*=\s*([^\s,]+)\s*,?\s*DT\s*=\s*([^\s,]+)", re.I)
_OLD = re.compile(r"^\s*([^\s,]+)[\s,]+([^\s,]+)")


def _header(path, line):
    m = _NEW.search(line) or _OLD.match(line)
    if not m:
        raise RecordFileError(f"{path}, line 4: expected NPTS and DT (e.g. 'NPTS= 4000, DT= .0050 SEC'), "
                              f"got {line.strip()!r}")
    try:
        npts = int(m.group(1))
    except ValueError:
        raise RecordFileError(f"{path}, line 4: NPTS {m.group(1)!r} is not an integer") from None
    try:
        dt = float(m.group(2))
    except ValueError:
        raise RecordFileError(f"{path}, line 4: DT {m.group(2)!r} is not a number") from None
    if npts < 1:
        raise RecordFileError(f"{path}, line 4: NPTS must be >= 1, got {npts}")
    if not (math.isfinite(dt) and dt > 0):
        raise RecordFileError(f"{path}, line 4: DT must be finite and > 0 s, got {m.group(2)!r}")
    return npts, dt


def read_at2(path) -> Record:
    """Read a PEER NGA ``.AT2`` file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Record
        ``acc`` in m/s^2; ``meta``: ``source`` ("AT2"), ``path``, ``header`` (the four lines),
        ``title`` (line 2), ``npts``, ``dt_s``.
    """
    path = os.fspath(path)
    with open(path, encoding="utf-8", errors="replace") as fh:   # FileNotFoundError if missing
        lines = fh.read().splitlines()
    if len(lines) < 4:
        raise RecordFileError(f"{path}: {len(lines)} lines, an AT2 file has a 4-line header")
    units = lines[2].upper()
    if "UNITS" in units and not re.search(r"\bG\b", units):
        raise RecordFileError(f"{path}, line 3: expected acceleration in units of g, got {lines[2].strip()!r}")
    npts, dt = _header(path, lines[3])
    values = []
    for lineno, line in enumerate(lines[4:], start=5):
        for tok in line.split():
            try:
                v = float(tok)
            except ValueError:
                raise RecordFileError(f"{path}, line {lineno}: {tok!r} is not a number") from None
            if not math.isfinite(v):
                raise RecordFileError(f"{path}, line {lineno}: non-finite value {tok!r}")
            values.append(v)
            if len(values) > npts:
                raise RecordFileError(f"{path}, line {lineno}: more values than NPTS = {npts}")
    if len(values) != npts:
        raise RecordFileError(f"{path}, line {len(lines)}: {len(values)} values, the header (line 4) "
                              f"says NPTS = {npts}")
    acc = np.asarray(values, dtype=np.float64) * G
    meta = {"source": "AT2", "path": path, "header": lines[:4], "title": lines[1].strip(),
            "npts": npts, "dt_s": dt, "units": f"converted from g with g = {G} m/s^2"}
    return Record(acc, dt, meta=meta)
