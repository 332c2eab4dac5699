"""How the analysis package sits in pycolfrag: what imports what.

* the Monte Carlo driver (``pycolfrag/grid.py``) imports nothing of the analysis: the command line
  (``pycolfrag/cli.py``) runs the summary, figures and report after a grid;
* no import circle between pycolfrag's modules, counting the imports inside functions too;
* the statistics import no C binding: ``analysis.fragility``, ``analysis.data`` and ``analysis.summary``
  import (and fragility computes) with the C extension made unimportable;
* importing the driver (``pycolfrag.grid``) loads no module of the analysis package at run time;
* the old module names (``pycolfrag.fragility``, ``python -m pycolfrag.compare``) still work and are the
  modules of the new home, not copies.

The expected import graph is read from the source files with :mod:`ast`, not from the modules' own
idea of themselves, so a new import anywhere can make these tests fail.
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pycolfrag

PKG = Path(pycolfrag.__file__).resolve().parent

#: Modules with a ``pycolfrag`` prefix that load the C extension or sit on the driver's side.
C_BINDINGS = {"pycolfrag._ffi", "pycolfrag._libcolfrag", "pycolfrag.solver", "pycolfrag.column",
              "pycolfrag.options", "pycolfrag.intensity"}

#: The one import circle left, each edge with its reason: ``pycolfrag.results.load`` (a public name
#: from before the reader moved) resolves to ``analysis.data.load`` on first use, and the reader
#: imports the results layout.
ALLOWED_BACK_EDGES = {("pycolfrag.results", "pycolfrag.analysis.data")}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict:
    return {_module_name(p): p for p in PKG.rglob("*.py")}


def _imports(path: Path, modules: dict) -> set:
    """Every pycolfrag module ``path`` imports, at the top or inside a function."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("pycolfrag"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            if not target.startswith("pycolfrag"):
                continue
            for a in node.names:  # "from . import results": the submodule, when there is one
                sub = f"{target}.{a.name}"
                out.add(sub if sub in modules else target)
    out.discard(name)
    return out


def _graph() -> dict:
    """Module -> the pycolfrag modules it imports. The package root is left out: its ``__init__``
    imports the public modules, and the modules that import from it read ``__version__``, which it
    sets before it imports anything."""
    modules = _modules()
    return {m: {t for t in _imports(p, modules) if t in modules and t != "pycolfrag"}
            for m, p in modules.items() if m != "pycolfrag"}


def test_the_driver_imports_nothing_of_the_analysis():
    modules = _modules()
    grid = _imports(modules["pycolfrag.grid"], modules)
    analysis = {m for m in grid if m.startswith(("pycolfrag.analysis", "pycolfrag.cli"))}
    assert not analysis, f"pycolfrag.grid imports {sorted(analysis)}"
    # the command line is what ties the two together
    cli = _imports(modules["pycolfrag.cli"], modules)
    assert "pycolfrag.grid" in cli and any(m.startswith("pycolfrag.analysis") for m in cli)


def test_no_import_circle():
    graph = _graph()
    for a, b in ALLOWED_BACK_EDGES:
        assert b in graph[a], f"{a} no longer imports {b}: remove the allowance"
        graph[a].discard(b)
    state, stack, circles = {}, [], []

    def visit(m):  # depth-first search; a grey node met again closes a circle
        state[m] = "grey"
        stack.append(m)
        for t in sorted(graph.get(m, ())):
            if state.get(t) == "grey":
                circles.append(stack[stack.index(t):] + [t])
            elif t not in state:
                visit(t)
        stack.pop()
        state[m] = "black"

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert not circles, "import circles: " + "; ".join(" -> ".join(c) for c in circles)


def test_statistics_name_no_c_binding():
    modules = _modules()
    for name in ("pycolfrag.analysis.fragility", "pycolfrag.analysis.summary", "pycolfrag.analysis.data"):
        bad = _imports(modules[name], modules) & (C_BINDINGS | {"pycolfrag.grid", "pycolfrag.sample"})
        assert not bad, f"{name} imports {sorted(bad)}"


def test_fragility_runs_without_the_c_extension():
    """In a child interpreter where the C extension cannot be imported. The package's ``__init__``
    loads the solver, so the child builds the package object itself from its folder (only
    ``pycolfrag.analysis.fragility`` and what it imports are executed). Eq. (4) of three standing runs
    u = 0.1, 0.2, 0.4 and threshold 0.2 is the lognormal MLE's exceedance: ln u has mean
    ln 0.2 exactly (geometric mean 0.2), so P = 0.5 whatever the dispersion."""
    code = textwrap.dedent(f"""
        import importlib.util, sys
        sys.modules["pycolfrag._libcolfrag"] = None        # importing the C extension now raises
        spec = importlib.util.spec_from_file_location("pycolfrag", {str(PKG / "__init__.py")!r},
                                                      submodule_search_locations=[{str(PKG)!r}])
        sys.modules["pycolfrag"] = importlib.util.module_from_spec(spec)   # not executed: no solver
        import pycolfrag.analysis.fragility as fr
        import pycolfrag.analysis.data, pycolfrag.analysis.summary
        p = fr.exceedance([0.1, 0.2, 0.4], [False, False, False], 0.2)
        loaded = sorted(m for m, v in sys.modules.items() if v is not None and m in {sorted(C_BINDINGS)!r})
        print(repr(p), loaded)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=os.getcwd())
    assert out.returncode == 0, out.stderr
    p, loaded = out.stdout.split(" ", 1)
    assert abs(float(p) - 0.5) < 1e-12 and loaded.strip() == "[]"


def test_importing_the_driver_loads_no_analysis():
    """At run time, not only in the source: ``import pycolfrag.grid`` in a fresh interpreter leaves every
    ``pycolfrag.analysis`` module unloaded (the package's ``__init__`` loads the moved modules on first
    use only)."""
    code = ("import sys, pycolfrag.grid\n"
            "print(sorted(m for m in sys.modules if m.startswith(('pycolfrag.analysis', 'pycolfrag.cli'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", out.stdout


def test_old_module_names_are_the_new_modules():
    import pycolfrag.analysis.fragility as new
    import pycolfrag.fragility as old
    from pycolfrag import report
    from pycolfrag.analysis import report as new_report
    assert old is new and pycolfrag.fragility is new and report is new_report
    assert new.__spec__.name == "pycolfrag.analysis.fragility"  # the module keeps its own spec
    from pycolfrag.results import Results, load
    from pycolfrag.analysis import data
    assert load is data.load and Results is data.Results


def test_old_module_names_run_with_dash_m():
    """``python -m pycolfrag.compare`` runs the moved module as ``__main__`` with the arguments given:
    its parser's own program name proves which code ran."""
    p = subprocess.run([sys.executable, "-m", "pycolfrag.compare", "--help"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("usage: python -m pycolfrag.analysis.compare") and not p.stderr
    p = subprocess.run([sys.executable, "-m", "pycolfrag.compare", "a_missing.h5", "b_missing.h5"],
                       capture_output=True, text=True)
    assert p.returncode == 3 and "a_missing.h5" in p.stderr
