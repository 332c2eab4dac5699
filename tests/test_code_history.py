"""A results file resumed with ``--allow-code-change``: ``report`` and ``risk`` name every code that wrote its
rows and the rows of each, not only the first (whose ``version``, ``git_revision`` and ``code_digest`` the root
attributes keep).

The file: a fake grid (tests/grid_fakes.py, 2 Mw x 3 R x 8 samples = 48 rows, 0.05 s a row) killed with
SIGKILL after at least 12 journal rows, then resumed in this process under another code digest (the grid's
``code_digest`` patched to 64 'e's, the test of the resume rule in tests/test_faults_grid.py edits a copy of the
package instead) with ``allow_code_change``. Expected: the first code wrote the rows done at the kill (read from
the file before the resume), the second the rest, 48 in all -- counts of rows, no tolerance.
"""
from __future__ import annotations

import json
import signal
import sys

import pytest

from pycolfrag.analysis.codes import code_history, code_summary
from pycolfrag.analysis.data import load, read_results

h5py = pytest.importorskip("h5py")

from test_grid import SCRIPT, _env, _kill_after  # noqa: E402

ARGS = ["--mw", "6", "7", "--dist", "5", "10", "15", "--samples", "8", "--sample-function", "grid_fakes:fake",
        "--no-figures", "--no-progress", "--flush-s", "0.2"]
OTHER = "e" * 64


@pytest.fixture(scope="module")
def resumed(tmp_path_factory):
    out = tmp_path_factory.mktemp("codes") / "grid.h5"
    args = ARGS + ["--out", str(out)]
    _kill_after([sys.executable, str(SCRIPT), *args], _env(PCF_FAKE_SLEEP_S="0.05"), out, 12, signal.SIGKILL)
    before = len(load(out))
    assert 12 <= before < 48, before
    first = load(out).attrs["code_digest"]
    mp = pytest.MonkeyPatch()
    import pycolfrag.grid.spec as spec
    mp.setattr(spec, "code_digest", lambda opts: OTHER)
    try:
        from pycolfrag.cli.grid import main
        assert main(args + ["--allow-code-change", "--mpi", "no"]) == 0
    finally:
        mp.undo()
    return out, before, first


def test_every_code_and_its_rows_are_read(resumed):
    out, before, first = resumed
    d = read_results(out)
    hist = code_history(d.attrs, d.n_total)
    assert [c["code_digest"] for c in hist] == [first, OTHER]
    assert [c["rows"] for c in hist] == [before, 48 - before]
    line = code_summary(d.attrs, d.n_total)
    assert line.startswith("2 codes wrote the rows") and f"`{first[:12]}`" in line and f"{before} rows" in line
    assert f"`{OTHER[:12]}`" in line and f"{48 - before} rows" in line
    # a file of one code says nothing more than before
    assert code_summary({"code_digests": json.dumps([{"code_digest": first, "rows_done_before": 0}])}, 48) is None


def test_report_shows_every_code(resumed, tmp_path):
    out, before, first = resumed
    from pycolfrag.analysis.report import main
    assert main([str(out), str(tmp_path / "report.md")]) == 0
    text = (tmp_path / "report.md").read_text()
    assert "2 codes wrote the rows" in text and f"`{OTHER[:12]}`" in text and f"{48 - before} rows" in text
    assert "(the first code's)" in text


def test_risk_shows_every_code(resumed, tmp_path, capsys):
    out, before, first = resumed
    from pycolfrag.risk.site_risk import main
    site = __import__("pathlib").Path(__file__).resolve().parents[1] / "examples" / "site_athens.toml"
    rc = main([str(site), str(out), str(tmp_path / "risk"), "--pulse-only", "--outside", "zero", "--no-figures",
               "--draws", "200"])
    assert rc == 0
    printed = capsys.readouterr().out
    assert "pulse branch: 2 codes wrote the rows" in printed and f"{48 - before} rows" in printed
    md = (tmp_path / "risk" / "risk.md").read_text()
    assert "2 codes wrote the rows" in md and "(the first of 2, below)" in md
    ident = json.loads((tmp_path / "risk" / "risk.json").read_text())["identity"]["pulse"]
    assert [(c["code_digest"], c["rows"]) for c in ident["codes"]] == [(first, before), (OTHER, 48 - before)]
