"""pycolfrag.core.names: one g, and a registry that matches what the code computes and stores."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from pycolfrag import results
from pycolfrag.core import names
from pycolfrag.ground_motion import at2, intensity
from pycolfrag.solver import run as solver


def test_one_g_everywhere():
    """One text for g: pycolfrag/data/constants.json. names.G reads it; the C solver's default
    (cf_solver_def_default) is compiled from it (pycolfrag/_build.py for the extension, csrc/flags.mk
    for every other C build) and holds no literal of its own; the IMs, the AT2 conversion and
    simulate() use names.G. A second value anywhere would make PGA in g disagree with the solver."""
    root = Path(__file__).resolve().parents[1]
    g = json.loads((root / "pycolfrag" / "data" / "constants.json").read_text())["g_m_s2"]
    assert g == 9.81                         # the package's documented gravity (names.py says why not 9.80665)
    assert names.G == g
    assert intensity.G == names.G and at2.G == names.G
    assert solver.SolverOptions().g == names.G   # compiled from the same file (a stale build fails here)
    text = (root / "csrc" / "solver_options.c").read_text()   # the option table: g's default is its 7th item
    assert re.search(r'\{\{"g",(?:[^,]*,){5}\s*(\w+)\s*,', text).group(1) == "CF_G_M_S2"
    flags = subprocess.run(["make", "-s", "-f", "csrc/flags.mk", "-f", "-", "p"], cwd=root, text=True, check=True,
                           input="p: ; @echo $(CFLAGS)\n", capture_output=True).stdout.split()
    assert f"-DCF_G_M_S2={g:g}" in flags


def test_c_without_the_gravity_define_does_not_compile(tmp_path):
    """No silent fallback: a C build that did not take g from the data file stops with a message."""
    if shutil.which("gcc") is None:
        pytest.skip("no gcc")
    root = Path(__file__).resolve().parents[1]
    p = subprocess.run(["gcc", "-std=c99", "-fsyntax-only", "-I", str(root / "csrc"),
                        str(root / "csrc" / "solver_options.c")],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "CF_G_M_S2" in p.stderr


# A child interpreter in which the compiled library cannot be imported, and the package's __init__
# (which loads the solver) is skipped: only the named modules and what they import run.
_NO_C = textwrap.dedent("""
    import importlib.abc, importlib.util, sys
    from pathlib import Path
    class Block(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name == "pycolfrag._libcolfrag":
                raise ImportError("the C extension is made unimportable for this test")
    sys.meta_path.insert(0, Block())
    here = Path({pkg!r})
    spec = importlib.util.spec_from_file_location("pycolfrag", here / "__init__.py",
                                                  submodule_search_locations=[str(here)])
    sys.modules["pycolfrag"] = importlib.util.module_from_spec(spec)   # not executed
    sys.modules["pycolfrag"].__version__ = "unused"                    # what _ffi reads first
    import importlib
    for name in {modules!r}:
        importlib.import_module(name)
    print("C loaded:", "pycolfrag.core.ffi" in sys.modules)
""")


def _import_without_c(*modules):
    pkg = Path(names.__file__).resolve().parents[1]   # the package (names lives in its core)
    return subprocess.run([sys.executable, "-c", _NO_C.format(pkg=str(pkg), modules=list(modules))],
                          capture_output=True, text=True, timeout=120)


def test_names_and_the_declarations_import_no_c():
    """names.py is pure data, and so are what the results layout is built from (the ground-motion
    declarations of the registry) and the layout itself: they import with the C extension unimportable."""
    p = _import_without_c("pycolfrag.core.names", "pycolfrag.ground_motion.registry", "pycolfrag.results")
    assert p.returncode == 0 and p.stdout.strip() == "C loaded: False", p.stderr
    # the block is real: a module that needs C fails in the same child
    p = _import_without_c("pycolfrag.ground_motion.intensity")
    assert p.returncode != 0 and "made unimportable" in p.stderr


def test_registry_matches_intensity_and_results():
    """Every registered IM is computed by intensity.measures (with the registered shape) and has a
    column in the results layout; every EDP is a /samples field."""
    ims = intensity.measures(np.sin(np.arange(200) * 0.1), 0.01, periods=(0.5, 1.0))
    for name, q in names.IMS.items():
        assert name in ims
        assert np.ndim(ims[name]) == (1 if q.spectral else 0), name
        assert name in (results.SPECTRA_FIELDS if q.spectral else results.SAMPLE_FIELDS), name
    for name in names.EDPS:
        assert name in results.SAMPLE_FIELDS


def test_labels():
    assert names.label("pga_g") == "PGA (g)"
    assert names.label("sa_g", 1.0) == "SA(1 s) (g)"
    assert names.label("u_top").startswith("u_top")
    assert names.label("unknown") == "unknown"
    from pycolfrag.analysis import figures
    assert figures.IM_LABELS["pgv_cm_s"] == "PGV (cm/s)" and figures.EDP_LABELS == {
        k: q.label for k, q in names.EDPS.items()}


def test_docs_samples_table_follows_the_registry():
    """docs/results_format.md's /samples table: the meaning of every scalar IM and EDP row starts with
    the registry's "description, unit" (the dataset's description attribute), in the registry's order."""
    doc = (Path(__file__).resolve().parents[1] / "docs" / "results_format.md").read_text()
    part = doc[doc.index("## `/samples`"):doc.index("## `/spectra`")]
    rows = re.findall(r"^\| `(\w+)` \| \w+ \| [^|]+ \| ([^|]+) \|$", part, re.M)
    meaning = dict(rows)
    order = [name for name, _ in rows]
    for table in (names.IMS, names.EDPS):
        declared = [k for k, q in table.items() if not q.spectral]
        assert [k for k in order if k in declared] == declared
        for k in declared:
            q = table[k]
            assert meaning[k].strip().startswith(f"{q.description}, {q.unit}"), k


def test_a_new_edp_in_the_registry_reaches_row_layout_and_labels():
    """Declaring an EDP in names.EDPS (with the Response attribute that holds it) is all a row, the
    /samples layout and the figures' labels need: a child interpreter adds one and reloads them."""
    code = textwrap.dedent("""
        import importlib, math
        from types import SimpleNamespace
        from pycolfrag import names
        names.EDPS["top_m"] = names.Quantity("top_m", "m", "peak top displacement (m)", "top",
                                             description="peak top displacement", response="max_top_disp")
        from pycolfrag import results, sample
        from pycolfrag.analysis import figures
        from pycolfrag.results import layout
        importlib.reload(layout)
        R = importlib.reload(results)
        assert R.SAMPLE_FIELDS["top_m"] == ("f8", R.SAMPLE_FIELDS["u_top"][1], "peak top displacement, m")
        assert R.RECORD_SAMPLE_FIELDS["top_m"] == R.SAMPLE_FIELDS["top_m"]
        res = SimpleNamespace(**{**{q.response or n: math.nan for n, q in names.EDPS.items()},
                                 **dict(u_top=0.2, u_d=0.01, max_top_disp=0.31, collapsed=False, n_steps=5, t_end=1.0)})
        assert sample._edp_row(res)["top_m"] == 0.31
        assert importlib.reload(figures).EDP_LABELS["top_m"] == "peak top displacement (m)"
        print("ok")
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and p.stdout.strip() == "ok", p.stderr
