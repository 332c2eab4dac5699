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
with g = 9.81 m/s^2 (the package's g, :data:`pycolfrag.ground_motion.intensity.G`).

Errors: :class:`~pycolfrag.core.errors.RecordFileError` (a ``ValueError``) naming the file and line
for a malformed header, a value that is not a number or not finite, or a sample count that
differs from NPTS; ``FileNotFoundError`` (an ``OSError``) for a missing file. The file is read in
chunks and the reading stops at the first value beyond NPTS, so memory and time are bounded by the
header's NPTS, not by the file (a 1 GB file of values with NPTS = 1000 fails after 1001 values);
messages quote at most 40 characters of a bad token or header line.
"""
from __future__ import annotations

import array
import math
import os
import re

import numpy as np

from pycolfrag.core.errors import RecordFileError
from pycolfrag.ground_motion.intensity import G  # m/s^2, the package's g (re-exported: at2.G)
from pycolfrag.ground_motion.record import Record

__all__ = ["read_at2", "G"]


_NEW = re.compile(r"NPTS\s*=\s*([^\s,]+)\s*,?\s*DT\s*=\s*([^\s,]+)", re.I)
_OLD = re.compile(r"^\s*([^\s,]+)[\s,]+([^\s,]+)")


def _header(path, line):
    m = _NEW.search(line) or _OLD.match(line)
    if not m:
        raise RecordFileError(f"{path}, line 4: expected NPTS and DT (e.g. 'NPTS= 4000, DT= .0050 SEC'), "
                              f"got {_excerpt(line)}")
    try:
        npts = int(m.group(1))
    except ValueError:
        raise RecordFileError(f"{path}, line 4: NPTS {_excerpt(m.group(1))} is not an integer") from None
    try:
        dt = float(m.group(2))
    except ValueError:
        raise RecordFileError(f"{path}, line 4: DT {_excerpt(m.group(2))} is not a number") from None
    if npts < 1:
        raise RecordFileError(f"{path}, line 4: NPTS must be >= 1, got {npts}")
    if not (math.isfinite(dt) and dt > 0):
        raise RecordFileError(f"{path}, line 4: DT must be finite and > 0 s, got {_excerpt(m.group(2))}")
    return npts, dt


#: Longest header line read, characters; longest number token accepted, characters.
_MAX_HEADER_LINE = 4096
_MAX_TOKEN = 64
#: Characters of a bad token or header line quoted in an error message.
_EXCERPT = 40
_CHUNK = 1 << 16


def _excerpt(text: str) -> str:
    text = text.strip()
    return repr(text if len(text) <= _EXCERPT else text[:_EXCERPT] + "...")


def _tokens(fh, first_line: int):
    """``(line number, token)`` pairs, read in chunks of at most ``_CHUNK`` characters: a file
    without newlines costs no more memory than one chunk, a token is cut off at ``_MAX_TOKEN``."""
    lineno, carry = first_line, ""
    while True:
        chunk = fh.readline(_CHUNK)
        if not chunk:
            break
        text = carry + chunk
        ends = text.endswith("\n")
        toks = text.split()
        carry = ""
        if toks and not ends and not text[-1].isspace():  # the last token may go on in the next chunk
            carry = toks.pop()
            if len(carry) > _MAX_TOKEN:
                yield lineno, carry
                return
        for tok in toks:
            yield lineno, tok
        if ends:
            lineno += 1
    if carry:
        yield lineno, carry


def read_at2(path) -> Record:
    """Read a PEER NGA ``.AT2`` file.

    The file is streamed: at most NPTS + 1 values are read (the header's NPTS bounds the work and
    the memory), so a huge or runaway file fails fast; an error quotes at most a short excerpt of
    the offending token or line.

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
        lines = []
        for i in range(4):
            line = fh.readline(_MAX_HEADER_LINE)
            if not line:
                break
            if not line.endswith("\n") and len(line) >= _MAX_HEADER_LINE:
                raise RecordFileError(f"{path}, line {i + 1}: header line longer than {_MAX_HEADER_LINE} "
                                      f"characters (starts {_excerpt(line)})")
            lines.append(line.rstrip("\r\n"))
        if len(lines) < 4:
            raise RecordFileError(f"{path}: {len(lines)} lines, an AT2 file has a 4-line header")
        units = lines[2].upper()
        if "UNITS" in units and not re.search(r"\bG\b", units):
            raise RecordFileError(f"{path}, line 3: expected acceleration in units of g, got {_excerpt(lines[2])}")
        npts, dt = _header(path, lines[3])
        values = array.array("d")
        lineno = 4
        for lineno, tok in _tokens(fh, 5):
            if len(tok) > _MAX_TOKEN:
                raise RecordFileError(f"{path}, line {lineno}: {_excerpt(tok)} is not a number")
            try:
                v = float(tok)
            except ValueError:
                raise RecordFileError(f"{path}, line {lineno}: {_excerpt(tok)} is not a number") from None
            if not math.isfinite(v):
                raise RecordFileError(f"{path}, line {lineno}: non-finite value {_excerpt(tok)}")
            if len(values) == npts:
                raise RecordFileError(f"{path}, line {lineno}: more values than NPTS = {npts}")
            values.append(v)
    if len(values) != npts:
        raise RecordFileError(f"{path}, line {lineno}: {len(values)} values, the header (line 4) "
                              f"says NPTS = {npts}")
    acc = np.frombuffer(values, dtype=np.float64) * G
    meta = {"source": "AT2", "path": path, "header": lines[:4], "title": lines[1].strip(),
            "npts": npts, "dt_s": dt, "units": f"converted from g with g = {G} m/s^2"}
    return Record(acc, dt, meta=meta)
