"""Every ``pycolfrag`` command runs with one BLAS thread and shows its long loops' progress (``pycolfrag
report`` of a full grid took 3 min 53 s of wall time for 104 s of CPU, BLAS threads fighting over
the fits' tiny matrices; 40 s with one thread, the same output; and no bar)."""
import json
import os
import subprocess
import sys
import textwrap
import time

import pytest

from pycolfrag.core import progress, threads
from test_grid import ROOT, SMALL, _ok, _serial

PROBE = '''
import json, os
import scipy.linalg  # noqa: F401  (scipy's own OpenBLAS loads after the entry: it must read the variables)
from pycolfrag.core import threads

def main(argv):
    print(json.dumps({"blas": threads.blas_threads(), "env": {v: os.environ.get(v) for v in threads.ENV_VARS}}))
    return 0
'''

DRIVER = '''
import sys
from pycolfrag.cli import main as commands
from pycolfrag.core import threads
for path in threads._loaded_libraries():   # a many-core machine's default: several threads
    threads._api(path)[1](3)
assert set(threads.blas_threads().values()) == {3}, threads.blas_threads()
commands.COMMANDS["probe"] = commands.Command("probe", "probe_cmd:main", "reports the BLAS threads", "")
sys.exit(commands.main(["probe"]))
'''


def _probe(tmp_path, **env_extra):
    (tmp_path / "probe_cmd.py").write_text(textwrap.dedent(PROBE))
    env = {k: v for k, v in os.environ.items() if k not in threads.ENV_VARS}
    env.update(PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]), **env_extra)
    p = subprocess.run([sys.executable, "-c", DRIVER], capture_output=True, text=True, env=env, cwd=ROOT, timeout=120)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_a_command_runs_with_one_blas_thread(tmp_path):
    """Through the entry every command takes (commands.main), with no thread variable set: numpy's OpenBLAS,
    loaded (and set to 3 threads) before the entry ran, and scipy's, loaded by the command, both use one."""
    got = _probe(tmp_path)
    assert len(got["blas"]) >= 2, got            # numpy's and scipy's libraries (their wheels' OpenBLAS)
    assert set(got["blas"].values()) == {1}, got
    assert got["env"]["OMP_NUM_THREADS"] == got["env"]["OPENBLAS_NUM_THREADS"] == "1"


def test_a_users_own_thread_count_is_kept(tmp_path):
    got = _probe(tmp_path, OPENBLAS_NUM_THREADS="2")
    assert set(got["blas"].values()) == {2}, got
    assert got["env"]["OPENBLAS_NUM_THREADS"] == got["env"]["OMP_NUM_THREADS"] == "2"


class _Bar:
    made: list = []

    def __init__(self, total=None, desc="", unit="", **kw):
        self.total, self.desc, self.unit, self.n, self.closed = total, desc, unit, 0, False
        _Bar.made.append(self)

    def update(self, n=1):
        self.n += n

    def close(self):
        self.closed = True


@pytest.fixture
def bars(monkeypatch):
    import tqdm
    _Bar.made = []
    monkeypatch.setattr(tqdm, "tqdm", _Bar)
    progress.enable(True)
    yield _Bar.made
    progress.enable(False)


def test_no_bar_unless_a_command_asked_for_them(monkeypatch):
    import tqdm
    _Bar.made = []
    monkeypatch.setattr(tqdm, "tqdm", _Bar)
    assert not progress.enabled()                 # library use: quiet
    with progress.task("x", 3, unit="fit"):
        progress.advance(unit="fit")
    assert _Bar.made == []


def test_a_bar_counts_its_own_unit_only(bars):
    for _ in progress.steps(range(4), "figures", unit="figure"):
        progress.advance(unit="fit")              # a figure's own fits: not figures
        with progress.task("inner", 2, unit="figure"):   # nested: no second bar
            pass
    assert len(bars) == 1 and bars[0].n == bars[0].total == 4 and bars[0].closed


def test_the_report_shows_a_bar_that_reaches_its_total(bars, tmp_path):
    from pycolfrag.analysis.report import write_report
    out = tmp_path / "g.h5"
    _ok(_serial([*SMALL, "--out", str(out)]))
    write_report(out, tmp_path / "r.md", n_boot=40)
    assert [b.desc for b in bars] == ["report"]
    # 4 scenarios' fits, then 4 IMs x the performance levels (pycolfrag.analysis.report._n_fits)
    assert bars[0].unit == "fit" and bars[0].n == bars[0].total > 4 and bars[0].closed


def test_in_a_log_the_first_line_comes_after_the_log_delay_not_the_interval(monkeypatch):
    """Into a file or a pipe the bar's first line is due after LOG_DELAY_S (docs/grid.md: "in a log after
    5 s, a line every 30 s"); tqdm alone waited its mininterval, LOG_INTERVAL_S, from the bar's creation,
    so a 20 s ``pycolfrag report`` into a log showed no line. Scaled down here (0.2 s delay, 30 s interval;
    the step at 0.4 s must print, the next one at once must not)."""
    import io
    log = io.StringIO()                                   # not a terminal
    monkeypatch.setattr(sys, "stderr", log)
    monkeypatch.setattr(progress, "LOG_DELAY_S", 0.2)
    progress.enable(True)
    try:
        with progress.task("report", 10, unit="fit"):
            time.sleep(0.4)
            progress.advance(unit="fit")
            first = log.getvalue()
            progress.advance(unit="fit")
            second = log.getvalue()
    finally:
        progress.enable(False)
    assert "report" in first and "1/10" in first, repr(first)
    assert second == first, repr(second)                  # then every LOG_INTERVAL_S, not every step
