"""The restoration study's risk figure (scripts/restoration_study.py, docs/figures/restoration_risk.png):
points with interval bars on a log axis, no bars from an arbitrary floor, a title that says what the
numbers are (one site model, the grid route), a rate of 0 drawn at the axis' foot; and the figure is
redrawn from the docs block's numbers, the study's results folder not being in the repository."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest
from matplotlib.patches import Rectangle

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def study():
    spec = importlib.util.spec_from_file_location("restoration_study", ROOT / "scripts" / "restoration_study.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_points_with_intervals_on_a_log_axis(study):
    """Made-up rates: every variant 1e-4 [5e-5, 3e-4] per level, the free column's collapse 0 [0, 2e-4]."""
    risks = {v: {"rate_per_year": {k: [1e-4, 5e-5, 3e-4] for k in study.LEVELS}} for v in study.VARIANTS}
    risks["free"]["rate_per_year"]["collapse"] = [0.0, 0.0, 2e-4]
    fig = study.fig_risk(risks)
    (ax,) = fig.axes
    assert ax.get_yscale() == "log" and ax.get_ylabel() == "annual rate of exceedance (1/yr)"
    assert ax.get_title().splitlines()[0] == study.RISK_TITLE
    assert "Annual rate per variant at the example site (grid route, one model)" == study.RISK_TITLE
    assert not [p for p in ax.patches if isinstance(p, Rectangle)]       # no bars
    points = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
    assert len(points) == 4 and all(np.allclose(ln.get_ydata(), 1e-4) for ln in points)
    assert len(points[0].get_ydata()) == len(study.LEVELS) - 1        # the free column's 0 is not a point
    zeros = [ln for ln in ax.get_lines() if ln.get_marker() == "v" and len(ln.get_ydata())]
    foot = ax.get_ylim()[0]
    assert len(zeros) == 1 and np.allclose(zeros[0].get_ydata(), foot) and foot == pytest.approx(1e-5)
    segs = np.concatenate([c.get_segments() for c in ax.collections])   # the interval bars
    lows, highs = segs[:, 0, 1], segs[:, 1, 1]
    assert set(np.round(highs, 12)) == {3e-4, 2e-4} and set(np.round(lows, 12)) == {5e-5, foot}


def test_the_figure_from_the_docs_block(study, tmp_path):
    """docs/restoration.md's risk table read back: the free column's u_top > 0.15 is 3.49e-04
    [2.79e-04, 6.09e-04] per year, titanium's u_d > 0.005 1.84e-05 [8.20e-06, 2.79e-04] (the block)."""
    risks = study.risks_from_docs((ROOT / "docs" / "restoration.md").read_text(encoding="utf-8"))
    assert risks["free"]["rate_per_year"]["u_top > 0.15"] == [3.49e-04, 2.79e-04, 6.09e-04]
    assert risks["titanium"]["rate_per_year"]["u_d > 0.005"] == [1.84e-05, 8.20e-06, 2.79e-04]
    assert all(len(r["rate_per_year"]) == len(study.LEVELS) for r in risks.values())
    assert study.main(["figure", str(ROOT / "docs" / "restoration.md"), "--figures", str(tmp_path)]) == 0
    assert (tmp_path / "restoration_risk.png").read_bytes().startswith(b"\x89PNG")
