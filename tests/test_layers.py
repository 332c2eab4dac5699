"""The layers a grid row passes through, from the driver down (docs/architecture.md, "The walk of a
grid row"): nothing lower imports or calls anything higher.

Two checks, each of which a new import or call anywhere on the row's path can break:

* the import graph of the row's modules, read from the sources with :mod:`ast` (imports inside
  functions too), goes downwards or stays within a layer;
* a synthetic row and a record row, run under a profiler, call only downwards or within a layer, pass
  only through modules that have a layer, and through at most 8 stations: the names of the layer table
  below that the walk's modules lie under (``pycolfrag.ground_motion`` one station,
  ``pycolfrag.ground_motion.intensity`` another), the foundation every layer uses left out.
"""
from __future__ import annotations

import ast
import os
import sys
from pathlib import Path

import pytest

import pycolfrag

PKG = Path(pycolfrag.__file__).resolve().parent
sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402

#: The layers, from the top: a module belongs to the layer of the longest of the names it is or lies under.
LAYERS = (
    ("driver", ("pycolfrag.grid",)),
    ("sample", ("pycolfrag.solver.sample",)),
    ("run and results layout", ("pycolfrag.solver", "pycolfrag.results")),   # run, scene_setup, state: one station
    ("inputs", ("pycolfrag.ground_motion.record_suites", "pycolfrag.ground_motion.record_tables", "pycolfrag.structure",
                "pycolfrag.solver.options", "pycolfrag.solver.step_cause")),
    ("ground motions", ("pycolfrag.ground_motion",)),
    ("kernels", ("pycolfrag.ground_motion.intensity",)),
    ("foundation", ("pycolfrag.core",)),
)
FOUNDATION = len(LAYERS) - 1
#: Most stations of a row's walk (see the module docstring).
MAX_STATIONS = 8


def _home(module: str):
    """(layer index, the name on the board) of ``module``: the longest name it is or lies under."""
    hits = [(len(n), i, n) for i, (_, names) in enumerate(LAYERS) for n in names
            if module == n or module.startswith(n + ".")]
    return max(hits)[1:] if hits else (None, None)


def _layer(module: str):
    return _home(module)[0]


def _module(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module(p): p for p in PKG.rglob("*.py")}


def _imports(path: Path) -> set:
    """The pycolfrag modules ``path`` imports, at the top or inside a function (``from . import x``:
    the submodule when there is one)."""
    name = _module(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("pycolfrag."))
        elif isinstance(node, ast.ImportFrom):
            base = package.rsplit(".", node.level - 1)[0] if node.level else ""
            target = ".".join(p for p in (base, node.module or "") if p)
            if target.startswith("pycolfrag"):
                out.update(f"{target}.{a.name}" if f"{target}.{a.name}" in MODULES else target for a in node.names)
    out.discard(name)
    return out


def test_the_layers_name_existing_modules():
    """A layer naming a module that moved would silently check nothing."""
    for _, layer in LAYERS:
        for n in layer:
            assert any(m == n or m.startswith(n + ".") for m in MODULES), f"no module {n}"


def test_the_row_modules_import_downwards():
    up = []
    for m, path in sorted(MODULES.items()):
        lm = _layer(m)
        if lm is None:
            continue
        for t in sorted(_imports(path)):
            lt = _layer(t)
            if lt is not None and lt < lm:
                up.append(f"{m} ({LAYERS[lm][0]}) imports {t} ({LAYERS[lt][0]})")
    assert not up, "imports up a layer:\n" + "\n".join(up)


def _walk(run) -> tuple[list, set]:
    """The pycolfrag modules ``run()`` enters, in order, and the (caller, callee) module pairs."""
    order, edges = [], set()

    def module_of(frame):
        f = frame.f_code.co_filename
        return _module(Path(f).resolve()) if f.startswith(str(PKG)) else None

    def profile(frame, event, arg):
        if event != "call":
            return
        m = module_of(frame)
        if m is None:
            return
        if m not in order:
            order.append(m)
        back = frame.f_back
        while back is not None and module_of(back) is None:
            back = back.f_back
        if back is not None and module_of(back) != m:
            edges.add((module_of(back), m))

    sys.setprofile(profile)
    try:
        run()
    finally:
        sys.setprofile(None)
    return order, edges


def _stations(order) -> list:
    tops = []
    for m in order:
        layer, top = _home(m)
        if layer != FOUNDATION and top not in tops:
            tops.append(top)
    return tops


def _check_walk(order, edges, what):
    homeless = [m for m in order if _layer(m) is None]
    assert not homeless, f"{what}: modules without a layer on the walk: {homeless}"
    up = sorted(f"{a} -> {b}" for a, b in edges if _layer(b) < _layer(a))
    assert not up, f"{what}: calls up a layer: {up}"
    stations = _stations(order)
    assert len(stations) <= MAX_STATIONS - 1, f"{what}: {len(stations) + 1} stations with the driver: {stations}"
    return stations


def test_a_synthetic_row_calls_downwards_only():
    """Two rows of the paper's grid below the driver, as its row function makes them: the scenario's
    pulse parameters (ground_motion.sample_pulse_parameters), then sample.run_synthetic_samples; 2 s of
    record each, the grid's resolved solver options."""
    from pycolfrag import Column, SolverOptions, ground_motion
    from pycolfrag.solver import sample
    col, options, rows = Column.parthenon(), SolverOptions(), []

    def rows_of_the_grid():
        table = ground_motion.sample_pulse_parameters(6.5, 20.0, 2, 1)
        pulses = [{k: v[i] for k, v in table.items()} for i in range(2)]
        rows.extend(sample.run_synthetic_samples(col, [(6.5, 20.0, 1, pulses[0]), (6.5, 20.0, 2, pulses[1])],
                                                 max_record_s=2.0, solver_options=options))
    order, edges = _walk(rows_of_the_grid)
    assert [r["status"] for r in rows] == [0, 0], rows
    stations = _check_walk(order, edges, "synthetic row")
    assert stations[:2] == ["pycolfrag.ground_motion", "pycolfrag.solver.sample"], stations


def test_a_record_row_calls_downwards_only(tmp_path):
    """Two rows of a record suite below the driver, as its row function makes them: the members taken
    from the suite (RecordSet indexing), then sample.run_record_samples: a component alone and the
    pair, scaled; the grid's resolved solver options. The suite's tables were read before the rows."""
    from pycolfrag import Column, SolverOptions
    from pycolfrag.ground_motion import record_suites as records
    from pycolfrag.solver import sample
    suite = records.load_records(rs.write_suite(tmp_path))
    col, options, rows = Column.parthenon(), SolverOptions(), []
    order, edges = _walk(lambda: rows.extend(sample.run_record_samples(
        [(suite[1], "h1", 0.5), (suite[1], "both", 1.0)], column=col, max_record_s=2.0, solver_options=options)))
    assert [r["status"] for r in rows] == [0, 0], rows
    stations = _check_walk(order, edges, "record row")
    assert stations[:2] == ["pycolfrag.ground_motion.record_suites", "pycolfrag.solver.sample"], stations
    assert "pycolfrag.ground_motion.record_tables" not in stations, stations


#: Most pycolfrag files (modules) a grid row enters in steady state, the driver's own included (the
#: package's target; docs/architecture.md, "A row of the synthetic grid"): a row does only its own work,
#: what every row shares being prepared once. 10 for a synthetic row and 9 for a record row when this was
#: written (2026-12-06), against 20 and 12 before.
MAX_ROW_FILES = 10


def _steady_walk(rows_of, ctx, first, then):
    """The walk of the rows ``then`` of a grid's chunk after the chunk ``first`` (which prepares what
    every row shares: the scenario's LHS and synthesis, the column's C set-up), as a rank runs them."""
    rows_of(ctx, first)
    out: list = []
    order, edges = _walk(lambda: out.extend(rows_of(ctx, then)))
    return order, edges, out


def _check_files(order, what):
    assert len(order) <= MAX_ROW_FILES, \
        f"{what}: a row in steady state enters {len(order)} files (at most {MAX_ROW_FILES}), in order: {order}"


def test_a_synthetic_row_in_steady_state_enters_at_most_10_files():
    """A chunk of the synthetic grid after the scenario's first (grid.rows.run_samples, 2 s of record):
    the row's seeds, its record from the scenario's prepared synthesis, its IMs, its run on the column
    set up once; at most MAX_ROW_FILES files, calling downwards only."""
    from pycolfrag import Column
    from pycolfrag.grid import rows as grid_rows
    from pycolfrag.grid.spec import GridSpec
    spec = GridSpec(mw=(6.5,), dist_km=(20.0,), samples=4, seed=7, max_record_s=2.0,
                    column=Column.parthenon().to_dict())
    order, edges, out = _steady_walk(grid_rows.run_samples, grid_rows.SampleContext(spec), [0, 1], [2, 3])
    assert [r["status"] for r in out] == [0, 0], out
    _check_walk(order, edges, "synthetic row in steady state")
    _check_files(order, "synthetic row")


def test_a_record_row_in_steady_state_enters_at_most_10_files(tmp_path):
    """A chunk of a record-suite grid after its first (grid.rows.run_record_rows): a component alone and
    the pair, scaled, on the column set up once; at most MAX_ROW_FILES files, calling downwards only."""
    from pycolfrag import Column
    from pycolfrag.grid import rows as grid_rows
    from pycolfrag.grid.spec import RecordGridSpec
    spec = RecordGridSpec(records=str(rs.write_suite(tmp_path)), components=("h1", "both"), scales=(0.5, 1.0),
                          max_record_s=2.0, column=Column.parthenon().to_dict())
    order, edges, out = _steady_walk(grid_rows.run_record_rows, grid_rows.RecordContext(spec), [0, 1], [2, 3])
    assert [r["status"] for r in out] == [0, 0], out
    _check_walk(order, edges, "record row in steady state")
    _check_files(order, "record row")


def test_the_walk_check_sees_a_climb():
    """Code that the profiler attributes to intensity.py (the kernels) calling the sample module is
    reported as a climb: the checks above can fail."""
    from pycolfrag.solver import sample
    code = compile("sample.rows_to_table([])", str(PKG / "ground_motion" / "intensity.py"), "exec")
    order, edges = _walk(lambda: exec(code, {"sample": sample}))
    with pytest.raises(AssertionError, match="calls up a layer: .*pycolfrag.ground_motion.intensity -> pycolfrag.solver.sample"):
        _check_walk(order, edges, "a climb")
