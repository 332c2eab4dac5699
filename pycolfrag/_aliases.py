"""The old names of modules that moved into :mod:`pycolfrag.analysis`, kept working.

``import pycolfrag.fragility`` (and ``from pycolfrag import report``, ``pcf.fragility``) gives the very
module object of the new home, not a copy, and ``python -m pycolfrag.report ARGS`` runs the new
module as ``__main__`` with the same arguments. One table, :data:`MOVED`; one import hook,
installed by ``pycolfrag/__init__.py``. New code imports the new names.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

#: old module name -> its home now.
MOVED = {f"pycolfrag.{name}": f"pycolfrag.analysis.{name}" for name in (
    "fragility", "figures", "report", "validation", "compare", "record_report", "record_figures",
    "risk", "risk_figures", "openquake")}


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old name of :data:`MOVED` and loads it as the module of its new name."""

    def __init__(self):
        self._specs = {}  # new name -> its own spec, restored after the import machinery set the alias's

    def find_spec(self, fullname, path=None, target=None):
        if fullname not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        module = importlib.import_module(MOVED[spec.name])
        self._specs[module.__name__] = module.__spec__
        return module

    def exec_module(self, module):  # executed already, under its new name
        module.__spec__ = self._specs.pop(module.__name__, module.__spec__)

    def get_code(self, fullname):
        """What ``python -m <old name>`` runs: the new module as ``__main__`` (its own package, so its
        relative imports resolve), with ``sys.argv`` as given."""
        return compile(f"import runpy\nrunpy.run_module({MOVED[fullname]!r}, run_name='__main__', alter_sys=True)\n",
                       f"<{fullname}: moved to {MOVED[fullname]}>", "exec")

    def is_package(self, fullname):
        return False


def install() -> None:
    """Put the finder on :data:`sys.meta_path` (once)."""
    if not any(isinstance(f, _MovedModuleFinder) for f in sys.meta_path):
        sys.meta_path.append(_MovedModuleFinder())
