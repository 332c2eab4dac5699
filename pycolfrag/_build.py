"""cffi build script (API mode, out of line) for the pycolfrag C library.

Every C source in ``csrc/`` is compiled into one extension module,
``pycolfrag._libcolfrag``.  The declarations cffi sees are taken from the public
headers themselves: the text between the markers ``/* cffi:begin */`` and
``/* cffi:end */`` of each ``csrc/*.h`` file (``cf_common.h`` first).  So a header
and its cdef cannot drift apart, and API mode checks struct layouts against the
real headers at build time.

Built by ``pip install -e .`` through ``cffi_modules`` in ``setup.py``; there is no
other build path for the extension (a stale ``_libcolfrag.cpython-*.so`` left by
``ffibuilder.compile()`` would shadow the ``.abi3.so`` pip builds).

The extension depends on every build input (:func:`pycolfrag.core.source_digest.build_inputs`: the
headers, ``flags.mk``, this script, ``constants.json``, not only the ``.c`` files), so
``setup.py build_ext`` rebuilds after an edit of a header alone; and it carries the digest of those
inputs (``cf_common_source_digest()``), by which results are signed (docs/grid.md, "Signed by its
code").
"""
from __future__ import annotations

import glob
import importlib.util
import json
import os
import re

from cffi import FFI

HERE = os.path.dirname(os.path.abspath(__file__))
CSRC = os.path.normpath(os.path.join(HERE, "..", "csrc"))


def _flags_mk() -> list[str]:
    """The compiler flags of csrc/flags.mk (CSTD, CWARN, COPT): their one home.

    -ffp-contract=off there keeps results independent of the CPU (no fused
    multiply-add), and there is no -march=native for the same reason.
    """
    values: dict[str, str] = {}
    with open(os.path.join(CSRC, "flags.mk"), encoding="utf-8") as fh:
        for line in fh:
            m = re.match(r"^\s*([A-Z]+)\s*[:?]?=\s*(.*?)\s*$", line.split("#", 1)[0])
            if m:
                values[m.group(1)] = m.group(2)
    flags = []
    for name in ("CSTD", "CWARN", "COPT"):
        if name not in values:
            raise RuntimeError(f"csrc/flags.mk defines no {name}")
        flags += values[name].split()
    return flags


CFLAGS = _flags_mk()


def _defines() -> list[tuple[str, str]]:
    """Compile-time values whose one home is a data file of the package: the default gravity
    (``CF_G_M_S2``, the ``g_m_s2`` of ``pycolfrag/data/constants.json``, which
    :mod:`pycolfrag.core.names` reads as ``G``). ``repr`` of the float gives the literal that parses
    back to the same double."""
    with open(os.path.join(HERE, "data", "constants.json"), encoding="utf-8") as fh:
        g = float(json.load(fh)["g_m_s2"])
    return [("CF_G_M_S2", repr(g))]

def _source_digest_module():
    """pycolfrag/core/source_digest.py, loaded by its path (the package cannot be imported before its
    extension is built)."""
    spec = importlib.util.spec_from_file_location("_pcf_source_digest", os.path.join(HERE, "core", "source_digest.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _build_inputs() -> tuple[list[str], str]:
    """(every file the build reads, relative to the checkout: the extension's ``depends``, and their
    digest, compiled in as ``CF_SOURCE_DIGEST``)."""
    sd = _source_digest_module()
    root = os.path.normpath(os.path.join(HERE, ".."))
    return [os.path.relpath(p, root) for _, p in sd.build_inputs(root)], sd.source_digest(root)


_REGION = re.compile(r"/\*\s*cffi:begin\s*\*/(.*?)/\*\s*cffi:end\s*\*/", re.S)


def _public_headers() -> list[str]:
    headers = sorted(glob.glob(os.path.join(CSRC, "*.h")))
    first = os.path.join(CSRC, "cf_common.h")
    return [first] + [h for h in headers if h != first]


def _cdefs(headers: list[str]) -> str:
    parts = []
    for path in headers:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
        for block in _REGION.findall(text):
            parts.append(f"/* from {os.path.basename(path)} */\n{block}")
    return "\n".join(parts)


def make_builder() -> FFI:
    headers = _public_headers()
    ffi = FFI()
    ffi.cdef(_cdefs(headers))
    # the Python side of cf_solver_set_check (pycolfrag.solver.run: Ctrl-C stops a run promptly)
    ffi.cdef('extern "Python" int _pcf_solver_check(void *);')
    includes = "\n".join(f'#include "{os.path.basename(h)}"' for h in headers)
    sources = sorted(glob.glob(os.path.join(CSRC, "*.c")))
    depends, digest = _build_inputs()
    ffi.set_source(
        "pycolfrag._libcolfrag",
        includes,
        sources=[os.path.relpath(s, os.path.join(HERE, "..")) for s in sources],
        include_dirs=[os.path.relpath(CSRC, os.path.join(HERE, ".."))],
        extra_compile_args=CFLAGS,
        define_macros=_defines() + [("CF_SOURCE_DIGEST", f'"{digest}"')],
        depends=depends,
        libraries=["m"],
    )
    return ffi


ffibuilder = make_builder()

if __name__ == "__main__":  # pragma: no cover - manual use only
    raise SystemExit("build with `pip install -e .` (or `make build`), not directly")
