"""The grid's declared contracts (pycolfrag/grid/protocol.py): both kinds of grid implement every
member of ``RunSpec`` with its signature, their row contexts implement ``RowContext``, and a row
function is a declared ``RowFunction`` (one row, and optionally a chunk side by side), not an
attribute hung on a function.

The expected member lists are read from the protocol classes themselves, so a member added to the
protocol and forgotten by one kind of grid fails here; the parameter names are compared with
:func:`inspect.signature`, so a kind whose method takes other arguments fails too.
"""
from __future__ import annotations

import inspect

import pytest

from pycolfrag import grid
from pycolfrag.grid import protocol
from record_suite import write_suite


def _members(proto) -> tuple[set, dict]:
    """(data members, {method name: parameter names}) that ``proto`` declares."""
    data = set(getattr(proto, "__annotations__", {}))
    methods = {}
    for name, value in vars(proto).items():
        if name.startswith("_"):
            continue
        if isinstance(value, property):
            data.add(name)
        elif callable(value):
            methods[name] = list(inspect.signature(value).parameters)
    return data, methods


def _check(cls, proto):
    data, methods = _members(proto)
    missing = sorted(m for m in data | set(methods) if not hasattr(cls, m) and m not in _fields(cls))
    assert not missing, f"{cls.__name__} lacks {missing} of {proto.__name__}"
    for name, params in methods.items():
        got = list(inspect.signature(getattr(cls, name)).parameters)
        assert got == params, f"{cls.__name__}.{name}{tuple(got)} is not {proto.__name__}.{name}{tuple(params)}"


def _fields(cls) -> set:
    """Data members a class declares without a class attribute: dataclass fields, annotations."""
    return set(getattr(cls, "__dataclass_fields__", {})) | set(getattr(cls, "__annotations__", {}))


def test_the_protocol_names_what_the_two_kinds_share():
    # the members both specs had before the protocol was declared (they are what the scheduler, the
    # probes and the command line call), plus input_notes, which replaced a getattr chain on the suite,
    # and expected_cost, by which the scheduler sizes its chunks
    data, methods = _members(protocol.RunSpec)
    # and what differs between the kinds, asked of the spec rather than read off its layout's name: its
    # rows' fields, its probe and checks before the run, its analysis after it
    assert data == {"column", "solver_options", "periods_s", "damping", "max_record_s", "sample_function",
                    "layout", "n_rows", "fields", "after_run"}
    assert set(methods) == {"signature", "order", "context", "default_function", "file_attrs",
                            "shortest_record_dt", "describe", "input_notes", "expected_cost", "probe",
                            "check_inputs", "expected_work"}


@pytest.mark.parametrize("cls", [grid.GridSpec, grid.RecordGridSpec, grid.EventBatchSpec])
def test_every_kind_of_grid_implements_the_protocol(cls):
    _check(cls, protocol.RunSpec)


@pytest.mark.parametrize("cls", [grid.SampleContext, grid.RecordContext, grid.EventContext])
def test_every_row_context_implements_the_protocol(cls):
    _check(cls, protocol.RowContext)


def test_instances_satisfy_the_protocols_and_declare_their_row_functions(tmp_path):
    specs = [grid.GridSpec(mw=(6.0,), dist_km=(5.0,), samples=2),
             grid.RecordGridSpec(records=str(write_suite(tmp_path)), scales=(1.0,)),
             grid.EventBatchSpec(inputs=({"mw": 6.0, "dist_km": 5.0, "hf_seed": 1},))]
    for spec in specs:
        assert isinstance(spec, protocol.RunSpec)
        assert isinstance(spec.context(), protocol.RowContext)
        rows = spec.default_function()
        assert isinstance(rows, protocol.RowFunction) and rows.many is not None
        assert not hasattr(rows.one, "rows")  # no protocol hung on the function any more
    assert specs[0].default_function() == grid.RowFunction(grid.run_sample, grid.run_samples)
    assert specs[1].default_function() == grid.RowFunction(grid.run_record_row, grid.run_record_rows)
    assert specs[2].default_function() == grid.RowFunction(grid.run_event, grid.run_events)
    assert specs[0].input_notes() == []


def test_a_plain_function_is_a_row_function_of_one_row():
    from pycolfrag.grid.rows import load_function
    fn = load_function("grid_fakes:fake", grid.SYNTHETIC_ROWS)
    assert isinstance(fn, grid.RowFunction) and fn.many is None
    import grid_fakes
    assert fn.one is grid_fakes.fake
    assert load_function(None, grid.SYNTHETIC_ROWS) is grid.SYNTHETIC_ROWS


def test_no_module_of_the_driver_imports_the_analysis():
    """Every module of the grid package, imports inside functions counted (read with ast): nothing of
    ``pycolfrag.analysis`` nor the command line that runs it after a grid (``pycolfrag.cli.grid``); the
    dispatcher (``pycolfrag.cli.main``) is allowed, since it imports no command until one runs."""
    from test_analysis_package import _imports, _modules
    modules = _modules()
    driver = sorted(m for m in modules if m == "pycolfrag.grid" or m.startswith("pycolfrag.grid."))
    assert len(driver) >= 8, driver
    for name in driver:
        bad = {m for m in _imports(modules[name], modules) if m.startswith(("pycolfrag.analysis", "pycolfrag.cli.grid"))}
        assert not bad, f"{name} imports {sorted(bad)}"
    # the dispatcher imports the package's version, its help style, its errors, and the thread limit and progress bars every
    # command runs under: each a leaf that imports nothing of pycolfrag, so no command is loaded with them
    leaves = {"pycolfrag.core.errors", "pycolfrag.core.threads", "pycolfrag.core.progress", "pycolfrag.core.help",
              "pycolfrag.core.version"}
    assert not {m for m in _imports(modules["pycolfrag.cli.main"], modules) if m != "pycolfrag"} - leaves
    for leaf in leaves:
        assert not {m for m in _imports(modules[leaf], modules) if m != leaf}, leaf
