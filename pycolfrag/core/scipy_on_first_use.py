"""scipy modules imported when one of their names is first read.

``import pycolfrag`` binds the fragility package (``pcf.fragility``), and every rank of a grid imports
pycolfrag without ever fitting anything: importing scipy.stats and scipy.optimize there took 0.6-0.8 s
of each rank's start-up. The fragility modules take ``optimize``, ``special`` and ``stats`` from here
instead of from scipy; the first attribute read (``stats.norm``) imports the real module.
"""
from __future__ import annotations

import importlib

__all__ = ["optimize", "special", "stats"]


class _OnFirstUse:
    """Stands for the module ``name``; every attribute is read from the imported module."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr):
        return getattr(importlib.import_module(self._name), attr)

    def __repr__(self) -> str:
        return f"<{self._name}, imported on first use>"


optimize = _OnFirstUse("scipy.optimize")
special = _OnFirstUse("scipy.special")
stats = _OnFirstUse("scipy.stats")
