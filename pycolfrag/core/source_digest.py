"""The digest of the C library's build inputs, in one place for the build and the package.

``pycolfrag/_build.py`` computes it when it compiles the extension and compiles it in (the macro
``CF_SOURCE_DIGEST``, returned by ``cf_common_source_digest()``), so the library says which sources
it was built from; :mod:`pycolfrag.grid.signing` signs results by that digest of the *loaded*
library and, in a checkout, compares it with the digest of the sources on disk (a stale build is
refused). Standard library only: ``_build.py`` loads this file by its path, before the package (and
its extension) can be imported.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

#: The first line hashed; change it with the rule (which files, how) so old and new digests never meet.
HEADER = "pycolfrag C library build inputs v1\n"
#: What a library built outside ``_build.py`` (the C tests, scripts/check_result_hashes.sh) returns.
UNSIGNED = "none"


def build_inputs(root) -> list[tuple[str, Path]]:
    """(name relative to ``root``, path) of every file the extension's build reads, in a fixed order:
    the C sources, headers and flags (``csrc/*.c``, ``*.h``, ``flags.mk``), the build script
    (``pycolfrag/_build.py``: the cdef, the flags it reads) and the constants it compiles in
    (``pycolfrag/data/constants.json``: gravity). A file that is missing is left out (so a tree that
    lacks one digests otherwise than the build that had it)."""
    root = Path(root)
    csrc = root / "csrc"
    files = [p for p in sorted(csrc.iterdir()) if p.is_file() and p.suffix in (".c", ".h", ".mk")]
    files += [root / "pycolfrag" / "_build.py", root / "pycolfrag" / "data" / "constants.json"]
    return [(p.relative_to(root).as_posix(), p) for p in files if p.is_file()]


def source_digest(root) -> str:
    """SHA-256 (64 hex digits) of :func:`build_inputs`: names and contents, not paths or times, so the
    same sources in another checkout digest alike."""
    h = hashlib.sha256(HEADER.encode())
    for name, path in build_inputs(root):
        data = path.read_bytes()
        h.update(f"{name}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()
