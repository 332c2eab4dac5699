#!/usr/bin/env python3
"""Monte Carlo fragility grid (docs/grid.md): ``pycolfrag grid``, kept under its old name.

    python scripts/run_grid.py ARGS...                   # = pycolfrag grid ARGS...
    mpirun -n 2 python -m mpi4py scripts/run_grid.py     # = mpirun -n 2 python -m mpi4py -m pycolfrag grid

Rerunning the same command resumes an interrupted run. Options: ``--help``; guide: docs/grid.md.
"""
import os
import sys

# One thread per rank: BLAS threads must not fight the MPI ranks for the cores (set before numpy loads).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pycolfrag.cli.main import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(["grid", *sys.argv[1:]]))
