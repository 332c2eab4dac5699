"""A rare-event level on any EDP the results files store needs no edit of ``pycolfrag/rare``: the levels'
families are the one EDP table's (``pycolfrag.core.names.EDPS``), and every part of the rare route reads a
level's EDP by its name (the exceedances of the estimate, the cross-entropy step's families, the steering
model of the allocation).

The level here is on the peak dowel slip (``dowel_slip_mm``, a stored EDP besides the paper's u_top and
u_d). Expected values: the exceedance rule of Eq. (1) (collapsed, or EDP >= threshold) and the elite mean
computed here with numpy from the same rows (exact up to the stored rounding of the shift, 1e-6).
"""
from __future__ import annotations

import numpy as np
import pytest

from pycolfrag.core import names
from pycolfrag.core.errors import ParameterError
from pycolfrag.damage import PerformanceLevel
from pycolfrag.rare import proposal
from pycolfrag.rare.allocation import SteeringModel
from pycolfrag.rare.estimate import exceedances
from pycolfrag.risk.site_risk import QUANTITIES, RiskQuantity

SLIP = RiskQuantity("dowel_slip_mm >= 2", "Dowel slip", PerformanceLevel("dowel_slip_mm", 2.0, "Dowel slip"))
COLLAPSE = QUANTITIES[-1]


def _rows(n: int = 4000, seed: int = 1) -> dict:
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((n, 2))
    slip = np.exp(0.8 * z[:, 0] + 0.1 * rng.standard_normal(n))          # grows with the pulse amplitude
    collapsed = z[:, 0] + 0.2 * rng.standard_normal(n) > 2.3
    return {"status": np.zeros(n, np.int32), "pulse": np.ones(n, np.uint8), "z_vp": z[:, 0], "z_fp": z[:, 1],
            "mw": rng.uniform(5.5, 7.5, n), "dist_km": rng.uniform(5.0, 20.0, n), "collapsed": collapsed.astype(np.uint8),
            "u_top": 0.1 * slip, "u_d": 0.001 * slip, "dowel_slip_mm": slip}


def test_every_stored_edp_is_a_family():
    assert "dowel_slip_mm" in names.EDPS and proposal.FAMILIES == tuple(names.EDPS)
    assert proposal.family_of(SLIP) == "dowel_slip_mm" and proposal.family_of(COLLAPSE) == "u_top"
    assert proposal.families_of([SLIP, COLLAPSE, QUANTITIES[3]]) == ("u_top", "u_d", "dowel_slip_mm")
    bad = RiskQuantity("nothing > 1", "Nothing", PerformanceLevel("nothing", 1.0, "Nothing"))
    with pytest.raises(ParameterError, match="'nothing'"):
        proposal.family_of(bad)


def test_a_level_on_a_stored_edp_runs_through_the_estimate_the_ce_step_and_the_allocation():
    cols = _rows()
    z = np.column_stack([cols["z_vp"], cols["z_fp"]])
    y = {q.label: exceedances(cols, q) for q in (SLIP, COLLAPSE)}
    assert np.array_equal(y[SLIP.label], (cols["dowel_slip_mm"] >= 2.0) | (cols["collapsed"] == 1))
    scores = {f: proposal.score(cols, f) for f in ("u_top", "dowel_slip_mm")}
    contrib = np.ones(len(z))
    means, notes = proposal.cross_entropy_means(z, contrib, y, scores, [SLIP, COLLAPSE], min_hits=20, quantile=0.9)
    assert len(means) == 2 and notes[0].startswith("u_top family") and notes[1].startswith("dowel_slip_mm family")
    elite = y[SLIP.label]
    assert means[1] == pytest.approx(tuple(z[elite].mean(axis=0)), abs=1e-6)
    model = SteeringModel(cols, [SLIP, COLLAPSE])            # fitted on the level's own EDP
    p = model.prob(True, SLIP.label, np.array([6.5]), np.array([10.0]), np.array([[2.0, 0.0]]))
    assert 0.5 < float(p[0]) <= 1.0    # slip >= 2 mm needs z_vp above ln 2 / 0.8 = 0.87: likely at z_vp = 2
