"""Outputs of an incomplete results file (pycolfrag.analysis.completeness): the report, the figures, the
validation document and the record-suite report refuse it unless asked, and then carry the mark; and
make_validation.py answers a record-suite file with a message instead of a traceback.

The incomplete synthetic file is tests/test_figures.write_results with ``complete=False`` and its last
rows not computed (status -1), as an interrupted grid leaves it; the record suite is the demo suite run
for real (3 records x 2 components at scale 1, about a second), read back, and given the attribute of
an interrupted run in memory.
"""
import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from pycolfrag.analysis import figures, record_report, report, validation
from pycolfrag.analysis.data import load
from pycolfrag.core.errors import ResultsFileError

sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402
from test_figures import write_results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
GRID = dict(mws=(6.5, 7.5), dists=(5.0, 20.0), n=20, n_failed=0)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("inc")
    part = write_results(d / "part.h5", complete=False, pending=20, **GRID)
    done = write_results(d / "done.h5", complete=True, **GRID)
    return part, done


def _script(name, *args):
    return subprocess.run([sys.executable, str(ROOT / "scripts" / name), *map(str, args)], capture_output=True,
                          text=True, timeout=300, env={**os.environ, "OMP_NUM_THREADS": "1"})


def test_report(files, tmp_path, capsys):
    part, done = files
    with pytest.raises(ResultsFileError, match=r"a report refused: .*part.h5 holds 60 of the 80 rows"):
        report.write_report(part, tmp_path / "r.md", n_boot=20)
    assert report.main([str(part), str(tmp_path / "r.md")]) == 2
    assert "--allow-incomplete" in capsys.readouterr().err and not (tmp_path / "r.md").exists()
    report.write_report(part, tmp_path / "r.md", n_boot=20, allow_incomplete=True)   # the CLI's, with fewer resamples
    head = (tmp_path / "r.md").read_text().splitlines()[:4]
    assert head[2].startswith("**INCOMPLETE RESULTS: ") and "60 of the 80 rows" in head[2]
    assert "INCOMPLETE" not in Path(report.write_report(done, tmp_path / "d.md", n_boot=20)).read_text()


def test_figures(files, tmp_path, monkeypatch):
    part, _ = files
    with pytest.raises(ResultsFileError, match="the figures refused"):
        figures.make_all(part, tmp_path / "f", n_boot=20)
    marked = []
    real = figures.mark_figure
    monkeypatch.setattr(figures, "mark_figure", lambda fig, note: (marked.append(note), real(fig, note)))
    written = figures.make_all(part, tmp_path / "f", n_boot=20, formats=("png",), allow_incomplete=True)
    assert len(marked) == len(written) >= 8 and all(m.startswith("INCOMPLETE RESULTS: ") for m in marked)
    p = _script("make_figures.py", part, "--out", tmp_path / "g", "--n-boot", "20")
    assert p.returncode == 2 and "--allow-incomplete" in p.stderr


def test_validation(files, tmp_path):
    part, done = files
    with pytest.raises(ResultsFileError, match="a validation document refused"):
        validation.write_validation(part, tmp_path / "v.md")
    with pytest.raises(ResultsFileError, match=r"sensitivity 'half'"):
        validation.write_validation(done, tmp_path / "v.md", {"half": part})
    text = Path(validation.write_validation(done, tmp_path / "v.md", {"half": part}, allow_incomplete=True)).read_text()
    assert text.count("INCOMPLETE RESULTS: ") == 1 and "- **half**: " in text.split("INCOMPLETE")[0].splitlines()[-1]
    p = _script("make_validation.py", part, "--out", tmp_path / "w.md")
    assert p.returncode == 2 and "pycolfrag validation: a validation document refused" in p.stderr


def test_make_validation_on_a_record_suite_file_says_what_to_use(files, tmp_path):
    suite = write_results(tmp_path / "suite.h5", **GRID)
    with h5py.File(suite, "r+") as f:
        f.attrs["layout"] = "records"
    p = _script("make_validation.py", suite, "--out", tmp_path / "v.md")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert "is a record-suite results file" in p.stderr and "pycolfrag record-report" in p.stderr


def test_record_report(tmp_path):
    suite = rs.write_suite(tmp_path / "suite")
    out = tmp_path / "records.h5"
    p = subprocess.run([sys.executable, str(ROOT / "scripts" / "run_grid.py"), "--records", str(suite), "--scale", "1",
                        "--no-progress", "--no-figures", "--out", str(out)], capture_output=True, text=True,
                       timeout=300, env={**os.environ, "OMP_NUM_THREADS": "1"}, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    res = load(out)
    res.n_rows += 2                        # two rows still pending, as an interrupted run leaves them
    with pytest.raises(ResultsFileError, match="a record-suite report refused: the results hold 6 of the 8 rows"):
        record_report.write_record_report(res, tmp_path / "a", figures=False)
    text = Path(record_report.write_record_report(res, tmp_path / "a", figures=False, allow_incomplete=True)).read_text()
    assert text.splitlines()[2].startswith("**INCOMPLETE RESULTS: the results hold 6 of the 8 rows")
