"""What a user installs: the source distribution builds (it carries every input of the C build), the
licence and the citation are there, and MPI is an optional extra (``pycolfrag[mpi]``) that one process
never needs, with a clear message when MPI is asked for without it.

The expected file lists come from the repository itself (every ``csrc/*.h``, ``*.c``, ``flags.mk``, data
file), so a new header that the sdist would leave out fails here. CI's install-as-a-user check
(``scripts/check_user_install.sh``) builds that sdist into a wheel and runs the commands from a bare venv.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
import tomllib
from pathlib import Path

import pytest

from test_grid import _env

ROOT = Path(__file__).resolve().parent.parent
FAKE = ["--mw", "6", "--dist", "5", "--samples", "2", "--sample-function", "grid_fakes:fake",
        "--no-figures", "--no-progress"]
#: Runs the command line with mpi4py made unimportable (None in sys.modules is how Python marks a module
#: that must not load), as on a machine where the `mpi` extra is not installed.
NO_MPI4PY = ("import sys; sys.modules['mpi4py'] = None\n"
             "from pycolfrag.cli.main import main\n"
             "sys.exit(main(sys.argv[1:]))\n")


def _without_mpi4py(args, tmp_path, **env):
    return subprocess.run([sys.executable, "-c", NO_MPI4PY, *args], capture_output=True, text=True,
                          env=_env(**env), cwd=tmp_path, timeout=120)


def test_mpi4py_is_an_optional_extra():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert not any(d.startswith("mpi4py") for d in project["dependencies"])
    assert any(d.startswith("mpi4py") for d in project["optional-dependencies"]["mpi"])


def test_one_process_runs_a_grid_without_mpi4py(tmp_path):
    p = _without_mpi4py(["grid", *FAKE, "--out", str(tmp_path / "g.h5")], tmp_path)
    assert p.returncode == 0, p.stdout + p.stderr
    assert (tmp_path / "g.h5").is_file()


def test_mpi_asked_for_without_mpi4py_is_refused_with_the_install_command(tmp_path):
    """Under a launcher (its environment variable set) without mpi4py, each rank used to run the whole grid
    as if alone, silently: now exit 2 and one line with the extra to install, before any row."""
    p = _without_mpi4py(["grid", *FAKE, "--out", str(tmp_path / "g.h5")], tmp_path, OMPI_COMM_WORLD_SIZE="2")
    assert p.returncode == 2, p.stdout + p.stderr
    assert "pip install 'pycolfrag[mpi]'" in p.stderr and "OMPI_COMM_WORLD_SIZE" in p.stderr
    assert "Traceback" not in p.stderr
    assert not (tmp_path / "g.h5").exists()
    p = _without_mpi4py(["grid", *FAKE, "--mpi", "yes", "--out", str(tmp_path / "h.h5")], tmp_path)
    assert p.returncode == 2 and "--mpi yes" in p.stderr and "pycolfrag[mpi]" in p.stderr, p.stderr


def test_licence_and_citation():
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["license"] == {"text": "MIT"}
    cff = (ROOT / "CITATION.cff").read_text()
    # the paper the method is taken from (Earthquake Engng Struct. Dyn. 2013, 42(14):2061-2079)
    assert "cff-version: 1.2.0" in cff and 'doi: "10.1002/eqe.2312"' in cff


@pytest.mark.slow
def test_sdist_carries_every_input_of_the_build(tmp_path):
    """setup.py's sdist (what `python -m build` makes first) holds every C source and header, the flags file
    the build reads, the package data, the licence and the citation: the sdist of 3336601 had no header."""
    # in a copy of the tree's files (tracked and new, not ignored ones): setuptools would otherwise reuse the
    # file list of an earlier build's pycolfrag.egg-info and pass without MANIFEST.in
    files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                           capture_output=True, text=True, check=True).stdout.split()
    tree = tmp_path / "tree"
    for rel in files:
        if (ROOT / rel).is_file():
            (tree / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / rel, tree / rel)
    p = subprocess.run([sys.executable, "setup.py", "-q", "sdist", "-d", str(tmp_path)], cwd=tree,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    (sdist,) = tmp_path.glob("pycolfrag-*.tar.gz")
    with tarfile.open(sdist) as tar:
        names = {Path(*Path(n).parts[1:]).as_posix() for n in tar.getnames()}
    wanted = {f.relative_to(ROOT).as_posix() for pattern in ("csrc/*.c", "csrc/*.h", "csrc/flags.mk",
                                                             "pycolfrag/data/*.json")
              for f in ROOT.glob(pattern)}
    wanted |= {"LICENSE", "CITATION.cff", "README.md", "setup.py", "pyproject.toml", "pycolfrag/_build.py"}
    assert len(wanted) > 50
    assert not wanted - names, sorted(wanted - names)
