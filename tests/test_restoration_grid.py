"""The pipeline takes connectors and scenes: the grid with a dowelled column (--column) and a portal
(--scene), their rows' EDPs, one rank against two, the report on them, the refusal of both options at
once, and compare's reading of an EDP that a run does not have (NaN throughout) as absent."""
import dataclasses
import json
import os
import sys
from pathlib import Path

import numpy as np

import pycolfrag as pcf
from pycolfrag.analysis import report
from pycolfrag.analysis.compare import compare_results
from pycolfrag.analysis.data import load
from pycolfrag.core import names
from pycolfrag.structure.kinds import model_from_dict
from pycolfrag.structure.scene import Colonnade

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
sys.path.insert(0, os.path.dirname(__file__))
from test_grid import _mpirun, _ok, _same_rows, _serial  # noqa: E402  (tests/ is not a package)

# 1 Mw x 2 R x 2 samples, records cut to 4 s
TINY = ["--mw", "6.5", "--dist", "5", "20", "--samples", "2", "--max-record-s", "4", "--no-figures", "--no-progress"]
DOWEL_EDPS = ("dowel_shear_kn", "dowel_slip_mm", "dowels_yielded", "dowels_broken")
EPISTYLE_EDPS = ("epistyle_slip_mm", "epistyle_unseat")


def test_grid_of_a_dowelled_column(tmp_path):
    out = tmp_path / "ti.h5"
    _ok(_serial([*TINY, "--column", str(EXAMPLES / "column_parthenon_titanium.toml"), "--out", str(out)]))
    r = load(out)
    s = r.samples
    assert r.complete and (s["status"] == 0).all()
    for e in DOWEL_EDPS:
        assert np.isfinite(s[e]).all(), e
    assert (s["dowel_shear_kn"] <= 50.0 + 1e-9).all()    # the titanium law's yield force, 50 kN
    for e in EPISTYLE_EDPS:
        assert np.isnan(s[e]).all(), e
    col = model_from_dict(json.loads(r.attrs["column"]))
    assert isinstance(col, pcf.Column) and len(col.dowels()) == 13
    assert names.edps_of(s) == ("u_top", "u_d", *DOWEL_EDPS)


def test_grid_of_a_portal_one_rank_and_two(tmp_path):
    one, two = tmp_path / "p1.h5", tmp_path / "p2.h5"
    args = [*TINY, "--scene", str(EXAMPLES / "portal_2.toml")]
    _ok(_serial([*args, "--out", str(one)]))
    _ok(_mpirun(2, [*args, "--out", str(two)]))
    a, b = load(one), load(two)
    _same_rows(a, b)
    s = a.samples
    assert (s["status"] == 0).all() and np.isfinite(s["epistyle_slip_mm"]).all()
    assert np.isnan(s["dowel_shear_kn"]).all()
    scene = model_from_dict(json.loads(a.attrs["column"]))
    assert scene.to_json() == Colonnade.portal(2).to_json()
    md = report.write_report(one, tmp_path / "report.md")
    text = Path(md).read_text()
    assert "mean epistyle_slip_mm" in text and "mean dowel_shear_kn" not in text


def test_column_and_scene_together_are_refused(tmp_path):
    p = _serial([*TINY, "--column", str(EXAMPLES / "column_parthenon.toml"), "--scene",
                 str(EXAMPLES / "portal_2.toml"), "--out", str(tmp_path / "x.h5")])
    assert p.returncode == 2 and "--column and --scene: give one" in p.stdout, p.stdout + p.stderr


def test_compare_reads_an_edp_nan_throughout_as_absent(tmp_path):
    """A file of the code before the connectors lacks their EDPs; a free column's run has them NaN in
    every row: the two say the same, so compare finds the rows bitwise equal. An EDP with a value
    in some row that the other file lacks still differs."""
    out = tmp_path / "g.h5"
    _ok(_serial(["--mw", "6.5", "--dist", "10", "--samples", "2", "--max-record-s", "3", "--no-figures",
                 "--no-progress", "--out", str(out)]))
    new = load(out)
    old = dataclasses.replace(new, samples={k: v for k, v in new.samples.items() if k not in DOWEL_EDPS + EPISTYLE_EDPS})
    assert compare_results(old, new).identical
    valued = dict(new.samples)
    valued["dowel_slip_mm"] = np.where(np.arange(len(new)) == 0, 1.0, np.nan)
    cmp = compare_results(old, dataclasses.replace(new, samples=valued))
    assert not cmp.identical and cmp.differing_fields == {"dowel_slip_mm": len(new)}


def test_record_suite_grids_of_a_dowelled_column_and_a_portal(tmp_path):
    """A record suite (the demo suite's 3 records, both horizontal components, 2 scales: 12 runs) runs a
    dowelled column and a portal as it runs the free column: every run succeeds, the parts' EDPs are
    finite where the parts exist and NaN where they do not, and the report of the record grid takes them."""
    import record_suite as rs
    suite = rs.write_suite(tmp_path / "suite")
    base = ["--records", str(suite), "--scale", "0.5", "1", "--max-record-s", "4", "--no-figures", "--no-progress"]
    ti, portal = tmp_path / "ti.h5", tmp_path / "portal.h5"
    _ok(_serial([*base, "--column", str(EXAMPLES / "column_parthenon_titanium.toml"), "--out", str(ti)]))
    _ok(_serial([*base, "--scene", str(EXAMPLES / "portal_2.toml"), "--out", str(portal)]))
    a, b = load(ti), load(portal)
    for r in (a, b):
        assert r.complete and len(r) == 12 and (r.samples["status"] == 0).all()
    assert all(np.isfinite(a.samples[e]).all() for e in DOWEL_EDPS)
    assert all(np.isnan(a.samples[e]).all() for e in EPISTYLE_EDPS)
    assert all(np.isfinite(b.samples[e]).all() for e in EPISTYLE_EDPS)
    assert all(np.isnan(b.samples[e]).all() for e in DOWEL_EDPS)
    from pycolfrag.analysis.record_report import write_record_report
    text = Path(write_record_report(ti, tmp_path / "ti", n_boot=50, figures=False)).read_text()
    assert "dowel_shear_kn" in text and "epistyle_slip_mm" not in text
