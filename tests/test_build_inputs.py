"""The extension's build (pycolfrag/_build.py): it depends on every file it reads, so
``setup.py build_ext`` rebuilds after an edit of a header alone (csrc/*.h hold the contact and
connector laws), and the library it makes carries the digest of those files, by which results are
signed (pycolfrag/grid/signing.py; tests/test_grid_signing.py checks the signing side).

Reported: after an edit of csrc/contact_law.h alone, ``build_ext --inplace`` said the
extension was up to date and the old binary stayed loaded under the new sources' digest.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pycolfrag.core import source_digest as _source_digest

ROOT = Path(__file__).resolve().parent.parent


def _builder():
    spec = importlib.util.spec_from_file_location("_pcf_build_under_test", ROOT / "pycolfrag" / "_build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_extension_depends_on_every_build_input():
    """Every header, flags.mk, the build script and the constants it compiles in are the extension's
    ``depends`` (setuptools rebuilds when one is newer than the library), and the digest compiled in is
    the digest of those files (pycolfrag/core/source_digest.py)."""
    build = _builder()
    kwds = build.ffibuilder._assigned_source[3]
    depends = {Path(p).as_posix() for p in kwds["depends"]}
    headers = {f"csrc/{p.name}" for p in (ROOT / "csrc").glob("*.h")}
    assert len(headers) >= 20 and {"csrc/contact_law.h", "csrc/connector_law.h"} <= headers
    assert headers | {"csrc/flags.mk", "pycolfrag/_build.py", "pycolfrag/data/constants.json"} <= depends
    assert depends == {name for name, _ in _source_digest.build_inputs(ROOT)}
    macros = dict(kwds["define_macros"])
    assert macros["CF_SOURCE_DIGEST"] == f'"{_source_digest.source_digest(ROOT)}"'


def _build_ext(root: Path) -> str:
    p = subprocess.run([sys.executable, "setup.py", "build_ext", "--inplace"], cwd=root, capture_output=True,
                       text=True, timeout=600, env=dict(os.environ, PYTHONPATH=str(root)))
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    return p.stdout + p.stderr


def _digests(root: Path) -> list[str]:
    """(the loaded library's digest, the sources' digest) as the package at ``root`` reports them."""
    code = "from pycolfrag.grid import signing; print(signing.library_digest(), signing.sources_digest())"
    p = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, PYTHONPATH=str(root)))
    assert p.returncode == 0, p.stderr
    return p.stdout.split()


@pytest.mark.slow
def test_build_ext_rebuilds_after_a_header_edit(tmp_path):
    """A real build in a copy of the checkout (about 30 s): built once, a second build_ext compiles
    nothing, then an edit of csrc/contact_law.h alone (a comment: the law's text, so the digest moves)
    makes build_ext compile again, and the new library reports the edited sources' digest."""
    root = tmp_path / "checkout"
    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.so", "_libcolfrag.c")
    shutil.copytree(ROOT / "pycolfrag", root / "pycolfrag", ignore=skip)
    shutil.copytree(ROOT / "csrc", root / "csrc", ignore=skip)
    for name in ("setup.py", "pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, root / name)
    assert "-c csrc/contact.c" in _build_ext(root)
    lib = next((root / "pycolfrag").glob("_libcolfrag*.so"))
    first, built_at = _digests(root), lib.stat().st_mtime_ns
    assert first[0] == first[1] == _source_digest.source_digest(ROOT)
    assert "-c csrc/" not in _build_ext(root)        # nothing changed: nothing compiled
    assert lib.stat().st_mtime_ns == built_at
    time.sleep(1.1)                                  # a newer mtime than the library on any file system
    law = root / "csrc" / "contact_law.h"
    law.write_text(law.read_text() + "/* edited: a header alone */\n")
    out = _build_ext(root)
    assert "-c csrc/contact.c" in out, out[-2000:]   # every object: a header may reach any of them
    assert lib.stat().st_mtime_ns != built_at
    built, disk = _digests(root)
    assert built == disk != first[0]
