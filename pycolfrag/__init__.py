"""pycolfrag -- seismic fragility of free-standing multidrum classical columns.

Quick tour (the public names the tests, scripts and README rely on)::

    import pycolfrag as pcf
    col = pcf.Column.parthenon()
    rec = pcf.ground_motion.synthesize(6.5, 10.0, seed=1)
    res = pcf.simulate(col, rec.acc, rec.dt, history=True)
    res.u_top, res.u_d, res.collapsed
    ti = col.with_connectors(pcf.Connectors.of("titanium", "all"))   # dowels between the drums
    portal = pcf.Colonnade.portal(2)                                  # two columns and an epistyle
    p = pcf.fragility.exceedance(edp, collapsed, threshold)     # Eq. (4); pycolfrag.analysis.fragility

Everything that reads results files is :mod:`pycolfrag.analysis` (``pycolfrag.analysis.data.load``,
``python -m pycolfrag.analysis.report``, ...); the writing side is :mod:`pycolfrag.results`.
"""
__version__ = "0.1.0"

# The imports below keep their order (no sorting): `time` first starts the timeline, and the fragility
# package comes last (see its comment).
# isort: off
import time as _time  # noqa: E402

#: When this package began to load (wall s since the epoch, process CPU s): where a grid rank's
#: imports begin in its timeline (pycolfrag.grid.timeline).
_IMPORT_STARTED = (_time.time(), _time.process_time())

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
from .connectors import Connectors, DowelLaw  # noqa: E402,F401
from .scene import Colonnade, Epistyle  # noqa: E402,F401
from .options import SolverOptions  # noqa: E402,F401
from .solver import History, Response, simulate, simulate_batch  # noqa: E402,F401
from . import ground_motion, intensity, names, records, results, sample  # noqa: E402,F401
# ``pcf.fragility.exceedance(...)`` after ``import pycolfrag as pcf`` is public (the statistics of the
# paper's Eqs. 1-4). A plain submodule attribute: it costs ``import pycolfrag`` the fragility package's
# own modules alone, since their scipy is imported on first use (pycolfrag/_scipy_on_first_use.py: a grid
# rank that imports pycolfrag loads no scipy; docs/architecture.md).
from .analysis import fragility  # noqa: E402,F401
