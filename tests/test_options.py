"""SolverOptions: the solver's options built from the C library's option tables (fields, defaults,
types, ranges, docs), the results-file round trip, and simulate's keyword compatibility.

Expected values: the paper's definitions (residual dislocation averaged over the last 2 s; no
damping by default); the ranges and defaults each option declares in C, read from the
declarations themselves, so that an option or a contact model added there is tested here without
an edit."""
import dataclasses
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.solver.options import CONTACT_DOCS, CONTACT_OPTIONS, OPTIONS, SolverOptions

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


def _outside(opt):
    """Values just outside each declared bound of an option (the bound itself where it is open), and
    the closed finite bounds, which are accepted: what the C library's check must enforce, read from
    the declaration itself."""
    bad, good = [], []
    integer = opt.kind == "int"
    if opt.kind in ("model", "flag"):
        return bad, good
    if math.isfinite(opt.lo):
        bad.append(opt.lo if opt.lo_open or opt.kind == "step" else opt.lo - 1 if integer
                   else np.nextafter(opt.lo, -np.inf))
        if not opt.lo_open and opt.kind != "step":
            good.append(opt.lo)
    if math.isfinite(opt.hi):
        bad.append(opt.hi if opt.hi_open else opt.hi + 1 if integer else np.nextafter(opt.hi, np.inf))
        if not opt.hi_open:
            good.append(opt.hi)
    return bad, good


_RANGES = [(name, v, ok) for name, opt in OPTIONS.items() for ok, vs in zip((False, True), _outside(opt))
           for v in vs]


@pytest.mark.parametrize("name, value, ok", _RANGES, ids=[f"{n}={v!r}" for n, v, _ in _RANGES])
def test_every_declared_range_holds_in_python(name, value, ok):
    """Every bound of every option as its C declaration gives it: just outside refused with a
    ParameterError naming the option (its Python name: dt_solver for C's dt), the closed bound accepted."""
    if ok:
        assert getattr(SolverOptions().replace(**{name: value}), name) == value
    else:
        with pytest.raises(pcf.ParameterError, match=rf"\b{name}\b"):
            SolverOptions().replace(**{name: value})


# Values of the wrong type for each kind of option (any option of that kind refuses them, naming itself).
_WRONG_TYPE = {"real": ["3", [1.0], float("nan"), float("inf"), True], "int": [None, float("nan"), 2.5, "2", True],
               "flag": [2, 1.0, "yes", None], "step": [0.0, -1e-3, "0.01"], "model": [["vertex"], "no_such_model", 0]}


@pytest.mark.parametrize("name", list(OPTIONS))
def test_bad_types_fail_when_built_naming_the_option(name):
    for v in _WRONG_TYPE[OPTIONS[name].kind]:
        with pytest.raises(pcf.ParameterError, match=rf"\b{name}\b"):
            SolverOptions().replace(**{name: v})
    with pytest.raises(pcf.ParameterError, match="bogus"):
        SolverOptions().replace(bogus=1)


def test_fields_defaults_and_c_definition_are_the_c_tables():
    """SolverOptions has one field per option of the C tables, in their order, with the default the C
    definition holds (cf_solver_def_default read back by name), and to_c puts every field where C reads
    it: a non-default value of each option, read back by name from the definition."""
    from pycolfrag.core.ffi import ffi, lib
    c_names = [ffi.string(lib.cf_solver_options_get(i).name).decode() for i in range(lib.cf_solver_options_count())]
    assert [o.c_name for o in OPTIONS.values()] == c_names
    assert [f.name for f in dataclasses.fields(SolverOptions)] == list(OPTIONS) == list(SolverOptions.names())
    d = ffi.new("cf_solver_def *")
    lib.cf_solver_def_default(d)
    v = ffi.new("double *")
    for name, opt in OPTIONS.items():
        assert getattr(SolverOptions(), name) == opt.default
        assert lib.cf_solver_options_value(d, opt.c_name.encode(), v) == lib.CF_OK
        assert v[0] == {"model": lambda x: CONTACT_OPTIONS[x], "step": lambda x: 0.0 if x is None else x}.get(
            opt.kind, float)(opt.default)
    for name, opt in OPTIONS.items():
        _, good = _outside(opt)
        other = {"model": list(CONTACT_OPTIONS)[-1], "flag": not opt.default, "step": 1e-4}.get(
            opt.kind, good[-1] if good and good[-1] != opt.default else opt.default)
        if other == opt.default and opt.kind in ("real", "int"):
            other = opt.default + 1 if opt.kind == "int" else opt.default * 0.5 + (opt.hi if math.isfinite(opt.hi)
                                                                                   else 1.0) * 0.5
        d2 = SolverOptions().replace(**{name: other}).to_c()
        assert lib.cf_solver_options_value(d2, opt.c_name.encode(), v) == lib.CF_OK
        expect = CONTACT_OPTIONS[other] if opt.kind == "model" else float(other)
        assert v[0] == expect and other != opt.default, name


def test_docs_table_is_the_c_tables():
    """docs/solver.md's options table is options.docs_table() (printed from the C tables): paste it
    again when an option or a contact model changes."""
    from pycolfrag.solver.options import docs_table
    text = (Path(__file__).resolve().parents[1] / "docs" / "solver.md").read_text()
    assert docs_table() in text, "docs/solver.md's options table differs from pycolfrag.solver.options.docs_table()"


def test_the_docstring_names_every_option_with_its_default():
    for name, opt in OPTIONS.items():
        assert f"\n{name} : " in SolverOptions.__doc__ and opt.doc in SolverOptions.__doc__


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
    with pytest.warns(pcf.solver.run.StepWarning, match="stability limit"):
        try:   # warned before the run starts; the run itself may then stop as unstable
            pcf.simulate(col, acc, 0.01, dt_solver=1.2 * crit, tail_s=0.0)
        except pcf.SolverError:
            pass
    with pytest.warns(pcf.solver.run.StepWarning, match="record's dt"):
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
    """The contact option's names and codes come from the C library's registry of contact models: every
    entry, in its order, each with its description; the C callers' names of the first entries
    (CF_SOLVER_CONTACT_*) index the models they name; a model's options name it."""
    from pycolfrag.core.ffi import ffi, lib
    n = lib.cf_solver_contact_model_count()
    assert CONTACT_OPTIONS == {ffi.string(lib.cf_solver_contact_model_name(i)).decode(): i for i in range(n)}
    assert set(CONTACT_DOCS) == set(CONTACT_OPTIONS) and all(len(d) > 20 for d in CONTACT_DOCS.values())
    for const in ("VERTEX", "PERIMETER", "EXACT"):
        assert CONTACT_OPTIONS[const.lower()] == getattr(lib, f"CF_SOLVER_CONTACT_{const}")
    for opt in OPTIONS.values():
        for model in opt.models:
            m = CONTACT_OPTIONS[model]
            assert opt.c_name in [ffi.string(lib.cf_solver_contact_model_option(m, k).name).decode()
                                  for k in range(lib.cf_solver_contact_model_n_options(m))]
    with pytest.raises(pcf.errors.ParameterError, match="contact must be one of"):
        SolverOptions(contact="no_such_model")
