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
# The imports below keep their order (no sorting): the version module first (it starts the timeline of a
# grid rank's imports), and the fragility package last (see its comment).
# isort: off
from pycolfrag.core.version import __version__  # noqa: F401

from pycolfrag.core.errors import (  # noqa: E402,F401
    HazardFileError,
    ModelRangeError,
    ParameterError,
    PycolfragError,
    RecordFileError,
    ResultsFileError,
    SolverError,
)
from pycolfrag.structure.column import Block, Column, JointProperties, Segment  # noqa: E402,F401
from pycolfrag.structure.connectors import Connectors, DowelLaw  # noqa: E402,F401
from pycolfrag.structure.scene import Colonnade, Epistyle  # noqa: E402,F401
from pycolfrag.solver.options import SolverOptions  # noqa: E402,F401
from pycolfrag.solver.run import History, Response, simulate, simulate_batch  # noqa: E402,F401
# The submodules the quick tour and the docs call through the package (``pcf.ground_motion.synthesize``,
# ``pcf.records.RecordSet``, ``pcf.names.G``, ...), bound under their public names.
from pycolfrag.core import errors  # noqa: E402,F401
from pycolfrag import ground_motion, results  # noqa: E402,F401
from pycolfrag.core import names  # noqa: E402,F401
from pycolfrag.ground_motion import intensity, record_suites as records  # noqa: E402,F401
from pycolfrag.solver import sample  # noqa: E402,F401
# ``pcf.fragility.exceedance(...)`` after ``import pycolfrag as pcf`` is public (the statistics of the
# paper's Eqs. 1-4). A plain submodule attribute: it costs ``import pycolfrag`` the fragility package's
# own modules alone, since their scipy is imported on first use (pycolfrag/core/scipy_on_first_use.py: a grid
# rank that imports pycolfrag loads no scipy; docs/architecture.md).
from pycolfrag.analysis import fragility  # noqa: E402,F401
