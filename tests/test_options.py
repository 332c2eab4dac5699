"""SolverOptions: the one home of the solver's options (defaults from C, one validation,
results-file round trip), and simulate's keyword compatibility.

Expected values: the paper's definitions (residual dislocation averaged over the last 2 s;
no damping by default) and the C library's own range checks."""
import json
import warnings

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.options import SolverOptions

G = 9.81


@pytest.fixture(scope="module")
def col():
    return pcf.Column.parthenon()


def test_defaults_are_the_papers_definitions():
    """The paper averages the residual dislocation over the last 2 s and uses no damping;
    the default step is 0.8 of the whole-stack limit (docs/accuracy.md)."""
    o = SolverOptions()
    assert o.residual_window_s == 2.0 and o.damping_alpha == 0.0 and o.contact == "vertex"
    assert o.dt_solver is None and o.dt_factor == 0.8 and o.unstable_tolerance == 0.5


def test_round_trip_through_a_results_attribute():
    o = SolverOptions(contact="perimeter", points_per_edge=3, dt_factor=0.4, damping_alpha=0.5,
                      damping_start_s=12.0, unstable_tolerance=0.3)
    text = json.dumps(o.to_dict(), sort_keys=True)
    assert SolverOptions.from_dict(json.loads(text)) == o
    assert SolverOptions.from_dict({}) == SolverOptions()


@pytest.mark.parametrize("changes, word", [
    (dict(dt_factor=10.0), "dt_factor"), (dict(dt_factor=0.0), "dt_factor"),
    (dict(points_per_edge=None), "points_per_edge"), (dict(points_per_edge=float("nan")), "points_per_edge"),
    (dict(points_per_edge=65), "points_per_edge"), (dict(contact=["vertex"]), "contact"),
    (dict(contact="soft"), "contact"), (dict(tail_s="3"), "tail_s"), (dict(planar=2), "planar"),
    (dict(dt_solver=0.0), "dt_solver"), (dict(dt_solver=-1e-3), "dt_solver"),
    (dict(unstable_tolerance=0.0), "unstable_tolerance"), (dict(history_dt=float("inf")), "history_dt"),
    (dict(contact_tolerance=0.5), "contact_tolerance"), (dict(bogus=1), "bogus"),
    (dict(reentry_depth=0.11), "reentry_depth"), (dict(reentry_depth=-1e-3), "reentry_depth"),
    (dict(reentry_depth=float("nan")), "reentry_depth"),
])
def test_bad_options_fail_when_built_naming_the_option(changes, word):
    with pytest.raises(pcf.ParameterError, match=word):
        SolverOptions().replace(**changes)


def test_keywords_and_options_give_the_same_bits(col):
    t = np.arange(0, 2.0, 0.005)
    acc = 0.3 * G * np.sin(2 * np.pi * 2.0 * t)
    a = pcf.simulate(col, acc, 0.005, contact="exact", dt_factor=0.5, tail_s=0.5)
    b = pcf.simulate(col, acc, 0.005, options=SolverOptions(contact="exact", dt_factor=0.5, tail_s=0.5))
    c = pcf.simulate(col, acc, 0.005, options=SolverOptions(contact="exact"), dt_factor=0.5, tail_s=0.5)
    assert a.u_top == b.u_top == c.u_top and a.n_steps == b.n_steps == c.n_steps
    assert a.options == b.options == SolverOptions(contact="exact", dt_factor=0.5, tail_s=0.5).to_dict()
    with pytest.raises(pcf.ParameterError, match="bogus"):
        pcf.simulate(col, acc, 0.005, bogus=1)


def test_unstable_tolerance_is_settable_and_acts(col):
    """A step 1.5x the stability limit runs away (hard case test_unstable_step...). With the
    default tolerance (0.5) it stops as unstable; with a tolerance above any reachable error it
    does not stop on the energy balance (it ends either with a NaN state or a huge error)."""
    t = np.arange(0, 1.0, 0.01)
    acc = 0.1 * G * np.sin(2 * np.pi * t)
    crit = pcf.simulate(col, acc[:2], 0.01, tail_s=0.0).dt_crit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(pcf.SolverError, match="energy balance"):
            pcf.simulate(col, acc, 0.01, dt_solver=1.5 * crit, tail_s=2.0)
        try:
            r = pcf.simulate(col, acc, 0.01, dt_solver=1.5 * crit, tail_s=2.0, unstable_tolerance=1e300)
            assert r.energy_error > 0.5
        except pcf.SolverError as exc:
            assert "non-finite" in str(exc)


def test_step_warnings(col):
    acc = np.zeros(200)
    crit = pcf.simulate(col, acc[:2], 0.01, tail_s=0.0).dt_crit
    with pytest.warns(pcf.solver.StepWarning, match="stability limit"):
        try:   # warned before the run starts; the run itself may then stop as unstable
            pcf.simulate(col, acc, 0.01, dt_solver=1.2 * crit, tail_s=0.0)
        except pcf.SolverError:
            pass
    with pytest.warns(pcf.solver.StepWarning, match="record's dt"):
        pcf.simulate(col, np.zeros(20), 1e-4, dt_solver=0.9 * crit, tail_s=0.0)


def test_runs_too_long_or_histories_too_large_are_refused_before_they_start(col):
    """A tiny solver step would need more than CF_SOLVER_MAX_STEPS (1e9) steps: refused with the
    number (before the fix the step count overflowed and the run returned CF_OK with u_top 0); a
    tiny history_dt likewise (the capacity overflowed int)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(pcf.ParameterError, match="steps"):
            pcf.simulate(col, np.zeros(100), 0.01, dt_solver=1e-19)
        with pytest.raises(pcf.ParameterError, match="steps"):
            pcf.simulate(col, np.zeros(100), 0.01, dt_solver=1e-9)
    with pytest.raises(pcf.ParameterError, match="history_dt"):
        pcf.simulate(col, np.zeros(100), 0.01, history=True, history_dt=1e-12)


@pytest.mark.parametrize("bad, word", [
    (None, "None"), ("0 1 2", "str"), (np.ma.masked_array([0.0, 1.0], mask=[0, 1]), "masked"),
    (np.array([0.0, 1j]), "complex"),
])
def test_bad_record_arrays_are_refused(col, bad, word):
    with pytest.raises(pcf.ParameterError, match=word):
        pcf.simulate(col, bad, 0.01)


def test_numpy_scalars_and_ranges():
    """Options read from numpy (a sweep over np.arange, HDF5 attributes) are accepted as their
    Python values; an int beyond C's int range and a float bool are refused with a ParameterError
    (before: a numpy integer was refused, 2**40 became a cffi OverflowError, planar=1.0 was True);
    damping_start_s=None keeps its old meaning, from the start."""
    o = SolverOptions(points_per_edge=np.int64(2), planar=np.bool_(True), dt_factor=np.float32(0.5))
    assert o.points_per_edge == 2 and type(o.points_per_edge) is int and o.planar is True and o.dt_factor == 0.5
    for bad in (dict(points_per_edge=2**40), dict(planar=1.0), dict(planar=np.array([1]))):
        with pytest.raises(pcf.ParameterError):
            SolverOptions(**bad)
    assert SolverOptions(damping_start_s=None).damping_start_s == 0.0


def test_contact_options_are_the_c_registry():
    """The contact option's names and codes come from the C library's registry of contact
    models, in the order of its C names (CF_SOLVER_CONTACT_*), each with its description."""
    from pycolfrag._ffi import lib
    from pycolfrag.options import CONTACT_DOCS, CONTACT_OPTIONS
    # the models this package ships; a model added to the registry adds an entry without editing this test
    shipped = {"vertex": lib.CF_SOLVER_CONTACT_VERTEX, "perimeter": lib.CF_SOLVER_CONTACT_PERIMETER,
               "exact": lib.CF_SOLVER_CONTACT_EXACT}
    assert {k: CONTACT_OPTIONS[k] for k in shipped} == shipped
    assert sorted(CONTACT_OPTIONS.values()) == list(range(lib.cf_solver_contact_model_count()))
    assert set(CONTACT_DOCS) == set(CONTACT_OPTIONS) and "points_per_edge" in CONTACT_DOCS["perimeter"]
    with pytest.raises(pcf.errors.ParameterError, match="contact must be one of"):
        SolverOptions(contact="toy")
