"""pycolfrag -- seismic fragility of free-standing multidrum classical columns.

Quick tour (the public names the tests, scripts and README rely on)::

    import pycolfrag as pcf
    col = pcf.Column.parthenon()
    rec = pcf.ground_motion.synthesize(6.5, 10.0, seed=1)
    res = pcf.simulate(col, rec.acc, rec.dt, history=True)
    res.u_top, res.u_d, res.collapsed
"""
__version__ = "0.1.0"

from .errors import (  # noqa: E402,F401
    HazardFileError,
    ModelRangeError,
    ParameterError,
    PycolfragError,
    RecordFileError,
    ResultsFileError,
    SolverError,
)
from .column import Block, Column, JointProperties, Segment  # noqa: E402,F401
from .options import SolverOptions  # noqa: E402,F401
from .solver import History, Response, simulate, simulate_batch  # noqa: E402,F401
from . import _aliases  # noqa: E402

_aliases.install()  # the old names of the modules that moved into pycolfrag.analysis

from . import ground_motion, intensity, names, records, results, sample  # noqa: E402,F401


def __getattr__(name):
    """``pcf.fragility``, ``pcf.report``, ...: the modules that moved into :mod:`pycolfrag.analysis`
    (``_aliases.MOVED``), loaded on first use, so that ``import pycolfrag`` (and the grid's driver)
    does not load the analysis package."""
    if f"{__name__}.{name}" in _aliases.MOVED:
        import importlib  # only on this path
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
