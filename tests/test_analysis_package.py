"""How the analysis package sits in pycolfrag: what imports what.

* the Monte Carlo driver (``pycolfrag.grid``) imports nothing of the analysis: the command line
  (``pycolfrag/cli/grid.py``) runs the summary, figures and report after a grid;
* no import circle between pycolfrag's modules, counting the imports inside functions too -- none
  allowed;
* the statistics import no C binding: ``analysis.fragility``, ``analysis.data`` and ``analysis.summary``
  import (and fragility computes) with the C extension made unimportable;
* importing the package or the driver loads, of the analysis package, the statistics of
  ``pcf.fragility`` alone (a public name of the package, a plain attribute) -- no reader, figure,
  report or matplotlib;
* the names from before the analysis package are gone, with nothing standing in for them: no import
  hook, no module ``__getattr__``.

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

import pytest

import pycolfrag

PKG = Path(pycolfrag.__file__).resolve().parent

#: Modules with a ``pycolfrag`` prefix that load the C extension or sit on the driver's side.
C_BINDINGS = {"pycolfrag.core.ffi", "pycolfrag._libcolfrag", "pycolfrag.solver.run", "pycolfrag.structure.column",
              "pycolfrag.solver.options", "pycolfrag.ground_motion.intensity"}


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
    driver = [m for m in modules if m == "pycolfrag.grid" or m.startswith("pycolfrag.grid.")]  # a module or a package
    assert driver
    for name in driver:
        analysis = {m for m in _imports(modules[name], modules) if m.startswith(("pycolfrag.analysis", "pycolfrag.cli.grid"))}
        assert not analysis, f"{name} imports {sorted(analysis)}"
    # the command line is what ties the two together
    cli = _imports(modules["pycolfrag.cli.grid"], modules)
    assert "pycolfrag.grid" in cli and any(m.startswith("pycolfrag.analysis") for m in cli)


def test_no_import_circle():
    graph = _graph()
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
        bad = _imports(modules[name], modules) & (C_BINDINGS | {"pycolfrag.grid", "pycolfrag.solver.sample"})
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


def _is_fragility(module: str) -> bool:
    """The statistics behind ``pcf.fragility``: the module, or the package and its own modules."""
    return module == "pycolfrag.analysis.fragility" or module.startswith("pycolfrag.analysis.fragility.")


@pytest.mark.parametrize("target", ["pycolfrag", "pycolfrag.grid"])
def test_importing_the_package_or_the_driver_loads_only_the_statistics_of_the_analysis(target):
    """At run time, in a fresh interpreter: ``import pycolfrag`` (and so the driver) loads
    ``pycolfrag.analysis`` (its ``__init__`` is a docstring) and ``pycolfrag.analysis.fragility`` -- what
    ``pcf.fragility`` names -- and no other analysis module, no command line, no matplotlib. Fragility
    imports numpy, scipy and pycolfrag's names and checks only, which the package loads anyway."""
    code = (f"import sys, {target}\n"
            "print(sorted(m for m in sys.modules if m.startswith(('pycolfrag.analysis', 'pycolfrag.cli.grid', "
            "'matplotlib'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    loaded = ast.literal_eval(out.stdout.strip())
    assert "pycolfrag.analysis.fragility" in loaded, loaded
    extra = [m for m in loaded if m != "pycolfrag.analysis" and not _is_fragility(m)]
    assert not extra, extra


def test_pcf_fragility_is_a_plain_attribute_and_the_old_names_are_gone():
    """``pcf.fragility`` (the product's public interface) is the module ``pycolfrag.analysis.fragility``
    itself, bound by the package's ``__init__``; the old names (``pycolfrag.report``, ``python -m
    pycolfrag.compare``, ``pycolfrag.results.load``) no longer resolve, and no hook or module
    ``__getattr__`` is left to make them."""
    import pycolfrag.analysis.fragility as fragility
    from pycolfrag import results
    assert pycolfrag.fragility is fragility and "fragility" in vars(pycolfrag)
    assert "__getattr__" not in vars(pycolfrag) and "__getattr__" not in vars(results)
    assert not any(type(f).__module__.startswith("pycolfrag") for f in sys.meta_path)
    for old in ("pycolfrag.report", "pycolfrag.fragility", "pycolfrag._aliases"):
        with pytest.raises(ModuleNotFoundError):
            __import__(old)
    assert not hasattr(pycolfrag, "report") and not hasattr(results, "load")
    p = subprocess.run([sys.executable, "-m", "pycolfrag.compare", "--help"], capture_output=True, text=True)
    assert p.returncode == 1 and "No module named pycolfrag.compare" in p.stderr, p.stderr
    p = subprocess.run([sys.executable, "-m", "pycolfrag.analysis.compare", "--help"], capture_output=True, text=True)
    assert p.returncode == 0 and p.stdout.startswith("usage: pycolfrag compare"), p.stderr
