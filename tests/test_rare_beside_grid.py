"""The site simulation beside a grid's results: only like with like.

A simulation of the two-drum verification column (bench/data/column_two_drums.toml) at the tiny site of
tests/data/site_rare_tiny.toml, records cut to 8 s, 60 runs (as tests/test_rare_site_plumbing.py), set beside
grids of Mw 6, 6.5, 7 x R 5, 7.5, 10 km (the strata's edges) with and without pulses. A grid of the same
column and options is compared (its verdicts printed); a grid of the Parthenon column -- the hostile case,
which printed "agree: yes" -- is refused with the column named, and so is every other difference
(:func:`pycolfrag.risk.rare_like.differences` against the RecordSettings the simulation ran with).
No expected numbers: which settings differ is an identity of the files.
"""
from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from pycolfrag.core.errors import ParameterError
from pycolfrag.rare.evaluator import RecordSettings
from pycolfrag.risk.rare_like import check_like_with_like, differences
from pycolfrag.structure.column import Column

h5py = pytest.importorskip("h5py")

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "tests" / "data" / "site_rare_tiny.toml"
COLUMN = ROOT / "bench" / "data" / "column_two_drums.toml"
SIM = ["--column", str(COLUMN), "--max-record-s", "8", "--seed", "5", "--no-progress", "--no-figures",
       "--batch", "20", "--max-runs", "60"]
GRID = ["--mw", "6", "6.5", "7", "--dist", "5", "7.5", "10", "--max-record-s", "8", "--no-figures", "--no-progress"]


def _env():
    env = {k: v for k, v in os.environ.items() if not (k.startswith("PMIX_") or k.startswith("OMPI_"))}
    env.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    return env


def _pycolfrag(*args):
    return subprocess.run([sys.executable, "-m", "pycolfrag", *args], capture_output=True, text=True, env=_env(),
                          cwd=ROOT, timeout=300)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The simulation's folder and four grid files: two-drum pulse / no-pulse (4 samples), Parthenon pulse /
    no-pulse (2 samples: about 0.13 s a run)."""
    tmp = tmp_path_factory.mktemp("beside")
    out = {"sim": tmp / "sim"}
    p = _pycolfrag("risk", str(SITE), *SIM, "--simulate", str(out["sim"]))
    assert p.returncode in (0, 6), p.stdout + p.stderr
    for name, extra in (("drums", ["--column", str(COLUMN), "--samples", "4"]),
                        ("parthenon", ["--samples", "2"])):
        for branch, pulse in (("", []), ("_np", ["--pulse", "none"])):
            out[name + branch] = tmp / f"{name}{branch}.h5"
            p = _pycolfrag("grid", *GRID, *extra, *pulse, "--out", str(out[name + branch]))
            assert p.returncode == 0, p.stdout + p.stderr
    return out


def _record(**kw):
    """The RecordSettings of the simulation above (rare/command.py's settings_from_args)."""
    return RecordSettings(column=Column.from_file(COLUMN).to_dict(), max_record_s=8.0, **kw)


def test_a_grid_of_the_simulated_column_is_compared(files):
    p = _pycolfrag("risk", str(SITE), str(files["drums"]), "--no-pulse", str(files["drums_np"]), *SIM,
                   "--simulate", str(files["sim"]))
    assert p.returncode in (0, 6), p.stdout + p.stderr
    assert "grid route (its range)" in p.stdout and "not runs of the simulated model" not in p.stdout + p.stderr
    assert "| agree |" in (files["sim"] / "risk.md").read_text()


def test_a_parthenon_grid_beside_a_two_drum_simulation_is_refused(files):
    """The issue's case: it printed "grid route (its range) agrees" for most levels."""
    fresh = files["sim"].parent / "sim_beside_parthenon"
    p = _pycolfrag("risk", str(SITE), str(files["parthenon"]), "--no-pulse", str(files["parthenon_np"]), *SIM,
                   "--simulate", str(fresh))
    text = p.stdout + p.stderr
    assert p.returncode == 2, text
    # refused before any run: no batch of the simulation was computed (the check used to come after it)
    assert not list(fresh.glob("**/*.h5")), sorted(fresh.glob("**/*"))
    assert "not runs of the simulated model" in text and "grid route (its range)" not in text
    assert "column: the simulation ran the column 'two drums" in text and "the grid the column 'Parthenon" in text
    # the column is the only difference: the rest of the options are the simulation's
    assert text.count("  - ") == 2 and "parthenon_np.h5 (no-pulse branch): column:" in text


def test_every_difference_is_named(files):
    both = {"pulse": files["drums"], "no-pulse": files["drums_np"]}
    assert differences(_record(), both) == []
    check_like_with_like(_record(), both)
    [d] = differences(_record(vp_scale=2.0), both)                  # the no-pulse branch has no amplitude
    assert "amplitude scale (--vp-scale) 2 in the simulation, 1 in the grid" in d
    [d] = differences(_record(tp_model="baker_2007"), both)
    assert "pulse-period relation 'baker_2007' in the simulation, 'rupakhety_2011' in the grid" in d
    [d] = differences(_record(vp_model="bray_rodriguez_marek_2004"), both)
    assert "pulse-amplitude relation 'bray_rodriguez_marek_2004' in the simulation, 'rupakhety_2011' in the grid" in d
    d = differences(_record(solver_options={"dt_factor": 0.5}), both)
    assert len(d) == 2 and all("solver options: dt_factor 0.5 in the simulation, 0.8 in the grid" in x for x in d)
    d = differences(_record(record_dt_s=0.01), both)
    assert len(d) == 2 and "record time step (--record-dt): 0.01 in the simulation, 0.005 in the grid" in d[0]
    d = differences(replace(_record(), max_record_s=None), both)
    assert len(d) == 2 and "records cut (--max-record-s): none (the default) in the simulation, 8.0" in d[0]
    d = differences(_record(), {"pulse": files["drums_np"], "no-pulse": files["drums"]})   # branches swapped
    assert len(d) == 2 and "pulses are 'mp03', the grid's 'none'" in d[0] and "declares pulse 'mp03'" in d[1]
    with pytest.raises(ParameterError, match="column: the simulation ran the column 'two drums"):
        check_like_with_like(_record(), {"pulse": files["parthenon"]})


def test_a_record_suite_or_another_noise_is_refused(files, tmp_path):
    """A record suite's rows are not the site's synthetic events; a grid whose seeds mean another noise
    (its signed ``streams``, edited here in a copy: only the attribute is read) is another model."""
    import json
    import shutil
    rec = tmp_path / "records.h5"
    shutil.copy(files["drums"], rec)
    with h5py.File(rec, "a") as f:
        f.attrs["layout"] = "records"
    [d] = differences(_record(), {"pulse": rec})
    assert "a 'records' file, not a synthetic grid" in d
    other = tmp_path / "streams.h5"
    shutil.copy(files["drums"], other)
    with h5py.File(other, "a") as f:
        sig = json.loads(f.attrs["grid_signature"])
        f.attrs["grid_signature"] = json.dumps(dict(sig, streams="PCG64(seed + row); v0"))
    [d] = differences(_record(), {"pulse": other})
    assert "seeds: the grid's rows draw their noise as 'PCG64(seed + row); v0'" in d
