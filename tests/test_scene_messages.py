"""What scenes, dowels and the risk command say when something is wrong -- the
real quantities of a beam too heavy for its columns, the part that sets a tiny automatic step (a
near-massless epistyle, a dowel far too stiff) named in a bounded pre-run check and in a warning
before a run of hundreds of millions of steps, advice that fits the command, a signature difference
that shows the key that differs, and outputs written with the ordinary file mode."""
import os
import re
import time
import warnings

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.grid import probes
from pycolfrag.results import ResultsLockedError, RunLock, signature_mismatch
from pycolfrag.risk import report as risk_report
from pycolfrag.risk import simulate as risk_command
from pycolfrag.solver import step_cause
from pycolfrag.solver.run import StepWarning
from pycolfrag.structure.connectors import Connectors, DowelLaw
from pycolfrag.structure.scene import Colonnade, Epistyle


def test_a_beam_too_heavy_for_its_columns_is_refused_with_its_settlement():
    """A 100 km high epistyle on the 2-column portal: each column would settle by about 110 m under
    it (the load over kn x area, joint by joint, measured 110.282 m), which made the column's settled top
    negative and the old refusal read "differ in height by 0 m". The refusal now names the
    settlement, the load and the height, each to 6 significant digits."""
    sc = Colonnade.portal(2, epistyle=Epistyle(height=1e5))
    with pytest.raises(pcf.ParameterError) as exc:
        pcf.simulate(sc, np.zeros(3), 0.005)
    text = str(exc.value)
    assert "differ in height by 0 m" not in text
    m = re.search(r"column 0 settles by ([0-9.e+]+) m under its blocks and ([0-9.e+]+) N of beams, over 1/100 of its "
                  r"height ([0-9.e+]+) m", text)
    assert m, text
    settle, load, height = (float(x) for x in m.groups())
    # the beam's half weight on column 0 (density 2700 x 4.865 x 1.73 x 1e5 m^3 x 9.81 / 2): 1.1e10 N
    assert load == pytest.approx(0.5 * 2700 * (4.0 + 1.73) * 1.73 * 1e5 * 9.81, rel=1e-3)
    assert settle > 10 * height > 100


def _count_runs(monkeypatch) -> list:
    """The solver's step counts of every run the pre-run check makes (simulate spied on where probes calls it)."""
    seen = []
    real = probes._solver.simulate

    def spy(*a, **k):
        res = real(*a, **k)
        seen.append(res.n_steps)
        return res

    monkeypatch.setattr(probes._solver, "simulate", spy)
    return seen


def test_the_pre_run_check_names_the_near_massless_epistyle_and_runs_only_a_probe(monkeypatch):
    """An epistyle of 1e-6 kg/m^3 (13 mg) on stiff bearings: the automatic step is 4e-8 s. The
    check used to run 3 samples at that step (3.7e5 steps, 13 s here) before refusing, and advised a
    longer dt_solver, which the user had not given; it now reads the step from the set-up solver and
    names the epistyle, its density, and what lengthens the step. Its one run is the probe for a collapse
    at t = 0 (three samples at the solver's own step: at most 3 steps), which would be the better message."""
    sc = Colonnade.portal(2, epistyle=Epistyle(density=1e-6))
    runs = _count_runs(monkeypatch)
    with pytest.raises(pcf.ParameterError) as exc:
        probes.check_solver_options(sc, None)
    text = str(exc.value)
    assert len(runs) <= 1 and sum(runs) <= 3, runs
    assert "choose a longer dt_solver" not in text
    assert "the step is automatic" in text and "epistyle 0" in text and "density 1e-06 kg/m^3" in text, text


def test_the_pre_run_check_runs_at_most_its_bound_of_steps(monkeypatch):
    """An epistyle of 1e-4 kg/m^3: a step of 4e-7 s, 7.4e6 steps for the check's 3 samples and 3 s of
    tail, under MAX_CHECK_STEPS (2e7), so the check ran: 2.5e4 steps of a probe, then 1.25e6 until the
    run stopped at rest after 0.5 s (measured; 21 s here, the issue's 86 s case at a smaller density).
    Its tail is now cut to MAX_CHECK_RUN_STEPS (3e5) steps, and the probe run is gone; the count is the
    solver's own (n_steps)."""
    sc = Colonnade.portal(2, epistyle=Epistyle(density=1e-4))
    dt = pcf.solver.run.automatic_step(sc, pcf.SolverOptions())
    assert (3 * 0.005 + pcf.SolverOptions().tail_s) / dt > 5 * probes.MAX_CHECK_RUN_STEPS
    seen = _count_runs(monkeypatch)
    out = probes.check_solver_options(sc, None)
    assert len(seen) == 1 and seen[0] <= probes.MAX_CHECK_RUN_STEPS + 10
    assert "epistyle 0" in out["cause"]


def test_a_run_of_hundreds_of_millions_of_steps_warns_naming_the_stiff_dowel():
    """A dowel of k_shear 1e18 N/m in joint 5: a step of about 1e-7 s, over 2e8 steps for 20 s of
    record -- the issue's 5.7e8-step run went without a word. simulate warns (StepWarning, before
    the run: as an error here, so nothing runs) with the count and the dowel's law as the cause."""
    col = pcf.Column.parthenon().with_connectors(Connectors(DowelLaw("elastoplastic", k_shear=1e18), (5,)))
    with warnings.catch_warnings():
        warnings.simplefilter("error", StepWarning)
        t0 = time.perf_counter()
        with pytest.raises(StepWarning) as exc:
            pcf.simulate(col, np.zeros(4000), 0.005)
    text = str(exc.value)
    steps = float(re.search(r"needs about ([0-9.e+]+) solver steps", text).group(1))
    assert steps > step_cause.MAX_RUN_STEPS
    assert "a dowel in joint 5 (k_shear = 1e+18 N/m" in text and "a softer dowel law" in text, text
    assert time.perf_counter() - t0 < 60    # the warning comes before the run (a bound, not a timing)


def test_the_risk_commands_lock_refusal_advises_its_own_option(tmp_path):
    """A folder's batch file another run holds: the lock's refusal advised `--out`, which `risk` lacks;
    risk --simulate's failure line advises another --simulate folder (exit code EXIT_LOCKED)."""
    target = tmp_path / "batch.h5"
    held = RunLock.acquire(target, log=lambda s: None)
    try:
        with pytest.raises(ResultsLockedError) as exc:
            RunLock.acquire(target, log=lambda s: None)
    finally:
        held.release()
    said = []
    code = risk_command._failed(exc.value, None, 1, said.append)
    assert code == risk_command.EXIT_LOCKED
    assert "--out" not in said[0] and "give --simulate another folder" in said[0], said


def test_a_signature_difference_names_the_key_that_differs():
    """Two settings tables whose JSON differs past its 120th character: the difference was cut at 120
    characters, before the key that differs. Tables are now compared key by key, and a long value is
    shown around its first difference."""
    base = {f"key_{i:02d}": "x" * 10 for i in range(12)}
    old = {"settings": dict(base, zz_batch=200), "site": "a" * 300 + "B"}
    new = {"settings": dict(base, zz_batch=100), "site": "a" * 300 + "C"}
    diffs = signature_mismatch(old, new)
    assert "settings: zz_batch: file has 200, this run asks for 100" in diffs
    site = [d for d in diffs if d.startswith("site:")][0]
    assert 'B"' in site and 'C"' in site, site


def test_risk_outputs_are_written_with_the_ordinary_mode(tmp_path):
    """risk.md and risk.json go through a temporary file of mkstemp (mode 0600) renamed into place:
    they were left 0600. They now get 0666 less the umask (0644 under the usual 022)."""
    old = os.umask(0o022)
    try:
        p = tmp_path / "risk.md"
        risk_report._write_text(p, "# risk\n")
    finally:
        os.umask(old)
    assert p.read_text() == "# risk\n"
    assert oct(os.stat(p).st_mode & 0o777) == oct(0o644)
