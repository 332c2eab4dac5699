"""Reading the small text files a user names: column and site files, hazard-curve CSVs, NRML models.

One policy for all of them, so that a wrong path answers with a clear exception instead of a hang or
a memory error:

* the path is a ``str`` or an ``os.PathLike`` (``None``, a number or ``bytes`` are refused, naming
  what was given);
* it names a **regular file**: a folder, a FIFO, a socket or a device (``/dev/zero``) is refused
  before it is opened for reading (a FIFO would block the reader forever), and the file is opened
  with ``O_NONBLOCK`` so that one swapped in between the check and the open cannot block either;
* it holds at most ``max_bytes`` bytes (the limits are :data:`LIMITS`, documented in
  ``docs/column_format.md`` and ``docs/risk.md``); the read stops one byte past the limit whatever
  the file's size claims, so a file that grows while it is read is bounded too;
* text is UTF-8 (a BOM is accepted); a file that is not is refused with the offset of the first bad
  byte, instead of a ``UnicodeDecodeError`` traceback;
* JSON (:func:`json_loads`) with a key twice in one object is refused naming the key: :func:`json.loads`
  keeps the last one silently (TOML refuses a duplicate key itself).

Every refusal is ``error`` (a :class:`~pycolfrag.core.errors.PycolfragError` subclass chosen by the caller,
e.g. :class:`~pycolfrag.core.errors.HazardFileError`); a missing file is that error and
``FileNotFoundError`` at once (:func:`missing_file_error`).
"""
from __future__ import annotations

import errno
import functools
import json
import os
import stat
from pathlib import Path

from pycolfrag.core.errors import ParameterError

#: The largest file of each kind read, bytes. A column or site file is a few kB; an OpenQuake
#: hazard-curve CSV of a large site model a few MB (100 000 sites x 20 levels is about 20 MB);
#: an NRML fragility model of a few hundred taxonomies well under 1 MB.
LIMITS = {
    "column file": 16 << 20,
    "scene file": 16 << 20,
    "site file": 16 << 20,
    "hazard-curve file": 256 << 20,
    "fragility model file": 64 << 20,
}


def _file_type(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device")):
        if test(mode):
            return name
    return "not a regular file"


@functools.lru_cache(maxsize=None)
def _missing_class(error: type) -> type:
    return type(f"Missing{error.__name__}", (error, FileNotFoundError), {"__module__": error.__module__})


def missing_file_error(error: type, message: str) -> Exception:
    """An instance of ``error`` that is also a :class:`FileNotFoundError` (``except FileNotFoundError``
    keeps working for a missing file); one class per ``error``."""
    return _missing_class(error)(message)


def as_path(path, what: str) -> Path:
    """``path`` as a :class:`Path`, or :class:`ParameterError` naming ``what`` and the value."""
    if isinstance(path, (str, os.PathLike)) and not isinstance(path, bytes):
        p = os.fspath(path)
        if isinstance(p, str) and p:
            return Path(p)
    raise ParameterError(f"{what} must be a path (str or os.PathLike), got {path!r}")


def read_bytes(path, what: str, *, error: type = ParameterError, max_bytes: int | None = None) -> bytes:
    """The bytes of the regular file ``path`` (at most ``max_bytes``, default ``LIMITS[what]``)."""
    p = as_path(path, what)
    limit = LIMITS[what] if max_bytes is None else int(max_bytes)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise missing_file_error(error, f"{what} {p} does not exist") from None
    except OSError as exc:
        raise error(f"{what} {p} cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{what} {p} is {_file_type(st.st_mode)}, not a regular file")
    if st.st_size > limit:
        raise error(f"{what} {p} has {st.st_size} bytes, more than the {limit} a {what} may have")
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise error(f"{what} {p} cannot be read: {exc.strerror or exc}") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):   # swapped for something else since the stat
            raise error(f"{what} {p} is {_file_type(os.fstat(fd).st_mode)}, not a regular file")
        chunks, n = [], 0
        while n <= limit:
            try:
                chunk = os.read(fd, min(1 << 20, limit + 1 - n))
            except OSError as exc:
                if exc.errno == errno.EAGAIN:
                    raise error(f"{what} {p} would block: not a regular file") from None
                raise error(f"{what} {p} cannot be read: {exc.strerror or exc}") from None
            if not chunk:
                break
            chunks.append(chunk)
            n += len(chunk)
        if n > limit:
            raise error(f"{what} {p} has more than the {limit} bytes a {what} may have")
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_text(path, what: str, *, error: type = ParameterError, max_bytes: int | None = None) -> str:
    """The UTF-8 text of the regular file ``path`` (see :func:`read_bytes`), BOM removed."""
    data = read_bytes(path, what, error=error, max_bytes=max_bytes)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{what} {as_path(path, what)} is not UTF-8 text (byte {exc.start} is "
                    f"0x{data[exc.start]:02x}); save it as UTF-8") from None


class DuplicateKeyError(ValueError):
    """A JSON object with a key twice (a ValueError, as :class:`json.JSONDecodeError` is: callers that turn
    a parse error into their own message name the key too)."""


def _unique_keys(pairs: list) -> dict:
    seen: dict = {}
    for key, value in pairs:
        if key in seen:
            keys = ", ".join(repr(k) for k, _ in pairs[:8]) + (", ..." if len(pairs) > 8 else "")
            raise DuplicateKeyError(f"duplicate key {key!r} in one object (its keys: {keys}): JSON would keep the "
                                    "last value silently; give each key once")
        seen[key] = value
    return seen


def json_loads(text: str):
    """:func:`json.loads` that refuses an object with a key twice (:class:`DuplicateKeyError`, naming it)."""
    return json.loads(text, object_pairs_hook=_unique_keys)
