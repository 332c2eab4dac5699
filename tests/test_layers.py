"""The layers a grid row passes through, from the driver down (docs/architecture.md, "The walk of a
grid row"): nothing lower imports or calls anything higher.

Two checks, each of which a new import or call anywhere on the row's path can break:

* the import graph of the row's modules, read from the sources with :mod:`ast` (imports inside
  functions too), goes downwards or stays within a layer;
* a synthetic row and a record row, run under a profiler, call only downwards or within a layer, pass
  only through modules that have a layer, and through at most 8 stations: the top-level modules of
  the package, a subpackage (``ground_motion``, a ``grid`` package) counted as one, the foundation
  every layer uses left out.
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

#: The layers, from the top: a module belongs to the first layer one of whose names it is or lies under.
LAYERS = (
    ("driver", ("pycolfrag.grid",)),
    ("sample", ("pycolfrag.sample",)),
    ("run and results layout", ("pycolfrag.solver", "pycolfrag.scene_run", "pycolfrag.results")),
    ("inputs", ("pycolfrag.records", "pycolfrag.record_tables", "pycolfrag.scene", "pycolfrag.column",
                "pycolfrag.connectors", "pycolfrag.foundation", "pycolfrag.as_built", "pycolfrag.options",
                "pycolfrag.step_cause")),
    ("ground motions", ("pycolfrag.ground_motion",)),
    ("kernels", ("pycolfrag.intensity",)),
    ("foundation", ("pycolfrag._ffi", "pycolfrag.names", "pycolfrag._validate", "pycolfrag.input_files",
                    "pycolfrag.errors")),
)
FOUNDATION = len(LAYERS) - 1
#: Most stations of a row's walk (see the module docstring).
MAX_STATIONS = 8


def _layer(module: str):
    for i, (_, names) in enumerate(LAYERS):
        if any(module == n or module.startswith(n + ".") for n in names):
            return i
    return None


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
        top = ".".join(m.split(".")[:2])
        if _layer(m) != FOUNDATION and top not in tops:
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
    from pycolfrag import Column, SolverOptions, ground_motion, sample
    col, options, rows = Column.parthenon(), SolverOptions(), []

    def rows_of_the_grid():
        table = ground_motion.sample_pulse_parameters(6.5, 20.0, 2, 1)
        pulses = [{k: v[i] for k, v in table.items()} for i in range(2)]
        rows.extend(sample.run_synthetic_samples(col, [(6.5, 20.0, 1, pulses[0]), (6.5, 20.0, 2, pulses[1])],
                                                 max_record_s=2.0, solver_options=options))
    order, edges = _walk(rows_of_the_grid)
    assert [r["status"] for r in rows] == [0, 0], rows
    stations = _check_walk(order, edges, "synthetic row")
    assert stations[:2] == ["pycolfrag.ground_motion", "pycolfrag.sample"], stations


def test_a_record_row_calls_downwards_only(tmp_path):
    """Two rows of a record suite below the driver, as its row function makes them: the members taken
    from the suite (RecordSet indexing), then sample.run_record_samples: a component alone and the
    pair, scaled; the grid's resolved solver options. The suite's tables were read before the rows."""
    from pycolfrag import Column, SolverOptions, records, sample
    suite = records.load_records(rs.write_suite(tmp_path))
    col, options, rows = Column.parthenon(), SolverOptions(), []
    order, edges = _walk(lambda: rows.extend(sample.run_record_samples(
        [(suite[1], "h1", 0.5), (suite[1], "both", 1.0)], column=col, max_record_s=2.0, solver_options=options)))
    assert [r["status"] for r in rows] == [0, 0], rows
    stations = _check_walk(order, edges, "record row")
    assert stations[:2] == ["pycolfrag.records", "pycolfrag.sample"] and "pycolfrag.record_tables" not in stations


def test_the_walk_check_sees_a_climb():
    """Code that the profiler attributes to intensity.py (the kernels) calling the sample module is
    reported as a climb: the checks above can fail."""
    from pycolfrag import sample
    code = compile("sample.rows_to_table([])", str(PKG / "intensity.py"), "exec")
    order, edges = _walk(lambda: exec(code, {"sample": sample}))
    with pytest.raises(AssertionError, match="calls up a layer: .*pycolfrag.intensity -> pycolfrag.sample"):
        _check_walk(order, edges, "a climb")
