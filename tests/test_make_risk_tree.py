"""`make risk-tree`'s command line, checked without a run: the recipe as `make -n` prints it is the tree command
of the rare route on the default tree, and its arguments pass everything the command checks before any run
(the tree, every run setting's probe, every end branch's re-weighting)."""
from __future__ import annotations

import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _recipe_args(tmp_path) -> list:
    out = subprocess.run(["make", "-n", "-C", str(ROOT), "risk-tree", f"TREE_DIR={tmp_path / 'tree'}"],
                         capture_output=True, text=True, check=True).stdout
    line = next(x for x in out.replace("\\\n", " ").splitlines() if "-m pycolfrag risk" in x)
    words = shlex.split(line)
    assert words[words.index("mpirun") + 1:words.index("mpirun") + 4] == ["--allow-run-as-root", "-n", "2"]
    assert "bench/risk_tree.py" in out                    # then the tree mean's CoV is checked from the folder
    args = words[words.index("pycolfrag") + 2:]          # after "-m pycolfrag risk", up to the exit status's test
    return args[:next((i for i, w in enumerate(args) if w.startswith(";")), len(args))]


@pytest.mark.skipif(shutil.which("make") is None, reason="make is absent")
def test_make_risk_tree_runs_the_default_tree_on_the_rare_route_to_cov_0_2_of_collapse(tmp_path):
    from pycolfrag.risk import rare_route
    from pycolfrag.risk.tree_rare_run import prepare
    args = _recipe_args(tmp_path)
    assert args[:3] == ["examples/site_athens.toml", "--logic-tree", "examples/logic_tree_default.toml"]
    ap = rare_route.build_parser()
    ap.add_argument("--logic-tree", required=True)
    a = ap.parse_args(args)
    assert (a.simulate, a.target_cov, a.levels, a.max_runs, a.progress) == (str(tmp_path / "tree"), 0.2, ["collapse"],
                                                                             4000, False)
    a.site, a.logic_tree = str(ROOT / a.site), str(ROOT / a.logic_tree)
    p = prepare(a)                                      # the checks before any run, the probes included
    assert len(p["ends"]) == 8 and len(p["groups"]) == 4
    assert [g.record.tp_model for g in p["groups"]] == ["rupakhety_2011"] * 4
    assert [g.record.vp_model for g in p["groups"]] == [""] * 4          # Eq. (6), the paper's relation
    assert [g.record.vp_scale for g in p["groups"]] == [1.0, 1.0, 2.0, 2.0]
    assert [g.record.solver_options.contact for g in p["groups"]] == ["vertex", "exact", "vertex", "exact"]
    assert not (tmp_path / "tree").exists()             # nothing written before the run
