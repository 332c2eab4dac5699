"""Exceptions of pycolfrag.

One base class, :class:`PycolfragError`; each subclass also inherits the builtin
it means, so ``except ValueError`` keeps working for callers that do not know
this package.
"""
from __future__ import annotations


class PycolfragError(Exception):
    """Base class of every error raised by pycolfrag."""


class ParameterError(PycolfragError, ValueError):
    """A bad argument: NaN/inf, wrong sign, wrong shape, impossible geometry."""


class ModelRangeError(ParameterError):
    """An argument outside the calibrated range of a published model (e.g. Mw, distance)."""


class RecordFileError(PycolfragError, ValueError):
    """A ground-motion file that exists but cannot be parsed (e.g. malformed .AT2)."""


class SolverError(PycolfragError, RuntimeError):
    """The solver detected a numerical failure (instability, NaN, energy blow-up)."""


class ResultsFileError(PycolfragError, ValueError):
    """A results file that does not match the run asked for (use --overwrite)."""


class HazardFileError(PycolfragError, ValueError):
    """A hazard-curve file (OpenQuake CSV) or fragility model file (NRML) that cannot be used as it is."""


class OutputError(PycolfragError, OSError):
    """An output folder or file that cannot be written (a file in the folder's place, no permission,
    a full disk)."""


class RareEventError(PycolfragError, RuntimeError):
    """A rare-event estimate that cannot be made as asked: subset simulation whose levels stop rising,
    more failed runs than a level can absorb, an evaluator that returns other rows than it was given."""


class MissingDependencyError(PycolfragError, ImportError):
    """A feature was asked for whose optional dependency is not installed (MPI ranks without mpi4py: the
    ``mpi`` extra, ``pip install 'pycolfrag[mpi]'``)."""


class StaleBuildError(ResultsFileError):
    """The loaded C library was compiled from other sources than those on disk (a stale build), or
    carries no digest of its sources: a run would be signed by code the sources do not show. Rebuild
    (``python setup.py build_ext --inplace``). A :class:`ResultsFileError`, so every command that
    signs a results file refuses it as it refuses a file of another run (exit code 2)."""
