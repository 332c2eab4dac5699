"""pycolfrag.names: one g, and a registry that matches what the code computes and stores."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from pycolfrag import intensity, names, results, solver
from pycolfrag.ground_motion import at2


def test_one_g_everywhere():
    """names.G is the g of the IMs, of the AT2 conversion, of simulate() and of the C solver's
    default (csrc/solver.c); a second value anywhere would make PGA in g disagree with the solver."""
    assert names.G == 9.81
    assert intensity.G == names.G and at2.G == names.G
    assert solver.SolverOptions().g == names.G   # read from cf_solver_def_default
    text = (Path(__file__).resolve().parents[1] / "csrc" / "solver.c").read_text()
    assert re.search(r"d->g\s*=\s*([0-9.]+)\s*;", text).group(1) == "9.81"


def test_registry_matches_intensity_and_results():
    """Every registered IM is computed by intensity.measures (with the registered shape) and has a
    column in the results layout; every EDP is a /samples field."""
    ims = intensity.measures(np.sin(np.arange(200) * 0.1), 0.01, periods=(0.5, 1.0))
    for name, q in names.IMS.items():
        assert name in ims
        assert np.ndim(ims[name]) == (1 if q.spectral else 0), name
        assert name in (results.SPECTRA_FIELDS if q.spectral else results.SAMPLE_FIELDS), name
    for name in names.EDPS:
        assert name in results.SAMPLE_FIELDS


def test_labels():
    assert names.label("pga_g") == "PGA (g)"
    assert names.label("sa_g", 1.0) == "SA(1 s) (g)"
    assert names.label("u_top").startswith("u_top")
    assert names.label("unknown") == "unknown"
    from pycolfrag.analysis import figures
    assert figures.IM_LABELS["pgv_cm_s"] == "PGV (cm/s)" and figures.EDP_LABELS == {
        k: q.label for k, q in names.EDPS.items()}
