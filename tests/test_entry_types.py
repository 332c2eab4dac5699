"""One entry-type policy for the public API (pycolfrag.core.validate): numbers are real numbers, seeds and
counts are integers, arrays hold integers or floats. Strings that float() would read, bools and arrays of
strings or bools are refused with a ParameterError naming the argument and the value, the same words in
every module; numpy numbers keep working and give the same results as Python floats.

Wrong files given to the readers (analysis.data.load, the report, make_figures) end with a ResultsFileError
saying what the file is, and on the command line with one line and exit status 2, never a traceback."""
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag import results as R
from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.data import load
from pycolfrag.core.errors import ParameterError, ResultsFileError
from pycolfrag.ground_motion import intensity

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DT = 0.01
ACC = 0.5 * np.sin(2 * np.pi * np.arange(100) * DT)        # 1 s of a 1 Hz sine, m/s^2: far below rocking
COL = pcf.Column.parthenon()
SYN = pcf.ground_motion.synthesize


@pytest.mark.parametrize("call, needle", [
    (lambda: pcf.simulate(COL, ACC, "0.01"), "dt (record sampling interval, s) must be a real number, got str '0.01'"),
    (lambda: pcf.simulate(COL, ACC, True), "must be a real number, got bool True"),
    (lambda: pcf.simulate(COL, ACC.astype(str), DT), "acc_x must be an array of numbers (integers or floats), "
                                                     "got an array of strings"),
    (lambda: pcf.simulate(COL, ACC > 0, DT), "acc_x must be an array of numbers (integers or floats), "
                                             "got an array of booleans"),
    (lambda: pcf.simulate(COL, [0.1, None, 0.2], DT), "acc_x must be an array of numbers (integers or floats), "
                                                      "got an array of Python objects"),
    (lambda: pcf.simulate(COL, ACC, DT, acc_y=list(map(str, ACC))), "acc_y must be an array of numbers"),
    (lambda: pcf.simulate(COL, ACC, DT, history="yes"), "history must be True or False, got str 'yes'"),
    (lambda: pcf.simulate(COL, ACC, DT, damping_alpha="5"), "damping_alpha must be a real number, got str '5'"),
    (lambda: SYN(7, "10", seed=1), "dist_km must be a real number, got str '10'"),
    (lambda: SYN(7, 10, seed=True), "seed must be an integer, got the bool True"),
    (lambda: SYN(7, 10, seed=np.True_), "seed must be an integer, got the bool np.True_"),
    (lambda: SYN(7, 10, seed=1.0), "seed must be an integer, got float 1.0"),
    (lambda: SYN(7, 10, seed=1, dt="0.005"), "dt must be a real number, got str '0.005'"),
    (lambda: pcf.ground_motion.sample_pulse_parameters(7, 10, True, 1), "n must be an integer, got the bool True"),
    (lambda: intensity.measures(ACC.astype(str), DT), "acc must be an array of numbers"),
    (lambda: intensity.measures(ACC, DT, periods=["1.0"]), "periods (s) must be an array of numbers"),
    (lambda: intensity.measures(ACC, DT, damping="0.05"), "damping must be a real number, got str '0.05'"),
    (lambda: fr.exceedance([0.4], [False], "0.35"), "threshold must be a real number, got str '0.35'"),
    (lambda: fr.exceedance(["0.4", "0.2"], [False, False], 0.35), "edp must be an array of numbers"),
    (lambda: fr.exceedance([True, False], [False, False], 0.35), "edp must be an array of numbers (integers or "
                                                                 "floats), got an array of booleans"),
    (lambda: fr.exceedance([0.4, 0.1], ["yes", "no"], 0.35), "collapsed must hold booleans (or 0/1), got "),
    (lambda: fr.fit_lognormal_fragility(["0.1", "0.2"], [0.1, 0.5], [False, False], 0.35),
     "im must be an array of numbers"),
    (lambda: fr.cloud_analysis([0.1, 0.2, 0.3], ["1", "2", "3"]), "edp must be an array of numbers"),
    (lambda: pcf.Column.from_drums([1.0, 1.0], "1.0"), "must be a real number, got str '1.0'"),
    (lambda: fr.bootstrap_interval([0.1, 0.2], [False, False], 0.15, n_boot="100"),
     "n_boot must be an integer, got str '100'"),
    (lambda: fr.bootstrap_interval([0.1, 0.2], [False, False], 0.15, confidence="0.9"),
     "confidence must be a real number, got str '0.9'"),
    (lambda: fr.stripe_edges([0.1, 0.2], n_stripes=12.0), "n_stripes must be an integer, got float 12.0"),
])
def test_wrong_entry_types_are_refused_naming_the_argument(call, needle):
    with pytest.raises(ParameterError) as info:
        call()
    assert needle in str(info.value)
    assert isinstance(info.value, ValueError)


def test_numpy_numbers_are_numbers_and_give_the_same_results():
    """np.float32/np.int64 scalars and 0-d arrays, integer arrays: accepted, and the same numbers as the
    Python float path (the conversion is exact for these values)."""
    ref = pcf.simulate(COL, ACC, DT)
    for dt in (np.float64(DT), np.array(DT)):
        r = pcf.simulate(COL, list(ACC), dt)
        assert (r.u_top, r.u_d, r.n_steps) == (ref.u_top, ref.u_d, ref.n_steps)
    ims = intensity.measures(np.arange(-50, 50), np.float32(0.5), periods=np.int64(1))
    assert ims["pga_g"] == pytest.approx(50 / pcf.names.G, rel=1e-15)      # max |a| / g of the integer ramp
    assert fr.exceedance(np.array([4, 2]), np.array([0, 1]), np.float32(0.5)) == fr.exceedance([4.0, 2.0],
                                                                                               [False, True], 0.5)
    rec = SYN(np.float64(6.5), np.int64(10), seed=np.uint32(3))
    assert np.array_equal(rec.acc, SYN(6.5, 10.0, seed=3).acc)


def test_a_solver_option_refused_by_the_library_is_named_by_its_own_name():
    """The C check names its fields; the Python names differ for one field only (dt -> dt_solver), and
    history_dt once came out as "history_dt_solver"."""
    with pytest.raises(ParameterError) as info:
        pcf.SolverOptions(history_dt=0.0)
    assert str(info.value) == "solver options: history_dt must be > 0, got 0"


# --------------------------------------------------------------------------- wrong files

def _cli(*args):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=300, cwd=ROOT)


def test_a_file_that_is_not_hdf5_or_a_folder_is_named_as_such(tmp_path):
    text = tmp_path / "grid.h5"
    text.write_text("mw,dist_km\n6.5,10\n")
    with pytest.raises(ResultsFileError, match="is not an HDF5 file") as info:
        load(text)
    assert not isinstance(info.value, R.ResultsDamagedError)       # it was never a results file
    with pytest.raises(ResultsFileError, match="is a folder, not a results file"):
        load(tmp_path)
    for args in (["-m", "pycolfrag.analysis.report", str(text), str(tmp_path / "r.md")],
                 ["scripts/make_figures.py", str(tmp_path), "--out", str(tmp_path / "f")]):
        p = _cli(*args)
        assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
        assert ("not an HDF5 file" in p.stderr) or ("is a folder" in p.stderr), p.stderr


def test_a_results_file_lacking_a_field_an_output_needs_names_it(tmp_path):
    """A file in the documented layout written by other code, without PGA: the report stops on a
    ResultsFileError naming the field instead of a KeyError."""
    from pycolfrag.analysis import report
    sys.path.insert(0, os.path.dirname(__file__))
    from test_figures import write_results
    path = write_results(tmp_path / "grid.h5", mws=(6.5,), dists=(10.0,), n=10, n_failed=0)
    with h5py.File(path, "a") as f:
        del f["samples/pga_g"]
    with pytest.raises(ResultsFileError, match="/samples has no field 'pga_g'"):
        report.write_report(path, tmp_path / "r.md", n_boot=20)


def test_plot_arguments_follow_the_same_policy(tmp_path):
    from pycolfrag.plots import response as plots
    res = pcf.simulate(COL, ACC, DT, history=True)
    for kw, needle in (({"fps": "20"}, "fps must be a real number, got str '20'"),
                       ({"max_frames": True}, "max_frames must be an integer, got the bool True"),
                       ({"max_frames": 4.0}, "max_frames must be an integer, got float 4.0"),
                       ({"t_start": "0.5"}, "t_start (s) must be a real number, got str '0.5'")):
        with pytest.raises(ParameterError) as info:
            plots.animate(COL, res, tmp_path / "x.gif", **kw)
        assert needle in str(info.value)
