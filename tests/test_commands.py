"""The ``pycolfrag`` command (pycolfrag/cli/main.py): one entry point over every command line, each
command dispatched to the ``main(argv)`` of the module that owns it, imported only when it runs.

The list of command lines a command must exist for is read from the sources (every ``def main(`` of
the package and of ``scripts/``), so a new command line without its ``pycolfrag`` command fails here.
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pycolfrag.analysis.data import load
from pycolfrag.cli import main as commands

ROOT = Path(__file__).resolve().parent.parent
from test_grid import _env, _ok, _same_rows, _serial  # noqa: E402

FAKE = ["--mw", "6", "7", "--dist", "5", "--samples", "3", "--sample-function", "grid_fakes:fake",
        "--no-figures", "--no-progress"]


def _pycolfrag(*args, timeout=120):
    return subprocess.run(["timeout", "-k", "10", str(timeout), sys.executable, "-m", "pycolfrag", *args],
                          capture_output=True, text=True, env=_env(), cwd=ROOT)


def _command_lines() -> set[str]:
    """Every command line of the project: the modules and scripts that define ``main``."""
    found = set()
    for path in sorted((ROOT / "pycolfrag").rglob("*.py")) + sorted((ROOT / "scripts").glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body):
            rel = path.relative_to(ROOT)
            found.add(rel.as_posix() if rel.parts[0] == "scripts" else ".".join(rel.with_suffix("").parts))
    return found


def test_every_command_line_has_its_command():
    targets = {c.target.partition(":")[0] for c in commands.COMMANDS.values()}
    # the dispatcher itself is the one main without a command of its own; run_grid.py calls it
    missing = _command_lines() - targets - {"pycolfrag.cli.main", "scripts/run_grid.py"} - set(commands.DEVELOPER_SCRIPTS)
    assert not missing, f"command lines without a 'pycolfrag' command: {sorted(missing)}"
    assert not targets - _command_lines(), "a command names a main that does not exist"


def test_help_lists_every_command_and_loads_no_command():
    """``pycolfrag --help`` in a fresh interpreter: every command with its older equivalent, and none
    of the commands' modules (the analysis beyond what ``import pycolfrag`` binds -- the fragility
    statistics of the public ``pcf.fragility`` --, the grid driver, the grid's command line) loaded."""
    code = ("import sys\nfrom pycolfrag.cli.main import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit as e:\n    assert e.code == 0, e.code\n"
            "print(sorted(m for m in sys.modules if m.startswith(('pycolfrag.analysis', 'pycolfrag.grid',"
            " 'pycolfrag.cli.grid', 'matplotlib', '_pycolfrag_script'))))\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(), cwd=ROOT)
    assert p.returncode == 0, p.stderr
    text, loaded = p.stdout.rsplit("\n", 2)[0], p.stdout.strip().splitlines()[-1]
    bound = {"pycolfrag.analysis", "pycolfrag.analysis.fragility"}   # pycolfrag/__init__.py's own imports
    assert [m for m in ast.literal_eval(loaded) if m not in bound and not m.startswith("pycolfrag.analysis.fragility.")] == [], loaded
    for c in commands.COMMANDS.values():
        assert f"  {c.name} " in text and c.old in text, c.name
    p = _pycolfrag("--help")   # python -m pycolfrag: the same
    assert p.returncode == 0 and "record-checks" in p.stdout and "pycolfrag grid" in p.stdout


def test_each_command_answers_help_under_its_name(capsys, monkeypatch):
    """Every command's own ``--help`` through the dispatcher exits 0 with a usage line; the commands whose
    parser does not name itself are named as run (``pycolfrag grid``), and the grid shows its defaults."""
    import matplotlib
    matplotlib.use("Agg")
    for name in commands.COMMANDS:
        with pytest.raises(SystemExit) as exc:
            code = commands.main([name, "--help"])
            raise SystemExit(code)   # a main that prints its usage and returns
        out = capsys.readouterr().out
        assert exc.value.code in (0, None) and out.startswith("usage: "), (name, out[:200])
        if name in ("grid", "figures", "validation"):
            assert out.startswith(f"usage: pycolfrag {name} "), out[:80]
    with pytest.raises(SystemExit):
        commands.main(["grid", "--help"])
    out = capsys.readouterr().out
    assert "--chunk-max CHUNK_MAX" in out and "(default: 32)" in out and "--allow-code-change" in out


def test_a_command_gets_its_arguments_and_returns_its_exit_code():
    # the same two missing files through the old command and the new one: the same exit code (3, the
    # compare command's code for an unreadable file) and the same message
    old = subprocess.run([sys.executable, "-m", "pycolfrag.analysis.compare", "a_missing.h5", "b_missing.h5"],
                         capture_output=True, text=True, env=_env(), cwd=ROOT)
    new = _pycolfrag("compare", "a_missing.h5", "b_missing.h5")
    assert old.returncode == new.returncode == 3 and "a_missing.h5" in new.stderr
    assert new.stderr == old.stderr


def test_unknown_command_and_no_command_are_usage_errors():
    p = _pycolfrag("gird")
    assert p.returncode == 2 and "invalid choice: 'gird'" in p.stderr, p.stderr
    p = _pycolfrag()
    assert p.returncode == 2 and "usage: pycolfrag" in p.stderr


def test_pycolfrag_grid_is_run_grid_py(tmp_path):
    """The new command and the old script write the same rows; the file records the command as run."""
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    _ok(_serial([*FAKE, "--out", str(a)]))
    p = _ok(_pycolfrag("grid", *FAKE, "--out", str(b)))
    assert "6 runs computed" in p.stdout
    ra, rb = load(a), load(b)
    _same_rows(ra, rb)
    assert rb.attrs["command"].startswith("pycolfrag grid --mw 6 7")


@pytest.mark.mpi
def test_pycolfrag_grid_under_mpirun(tmp_path):
    """``mpirun -n 2 python -m mpi4py -m pycolfrag grid``: two ranks, the rows of one."""
    import shutil
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    _ok(_serial([*FAKE, "--out", str(one)]))
    cmd = ["timeout", "-k", "10", "150", "mpirun", "--allow-run-as-root", "-n", "2", sys.executable, "-m", "mpi4py",
           "-m", "pycolfrag", "grid", *FAKE, "--out", str(two)]
    p = _ok(subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=ROOT))
    assert "on 2 ranks" in p.stdout
    _same_rows(load(one), load(two))


def test_the_console_script_is_installed():
    exe = Path(sys.executable).parent / "pycolfrag"
    if not exe.exists():
        pytest.skip("not installed with pip install -e . (make setup)")
    p = subprocess.run([str(exe), "--version"], capture_output=True, text=True, env=_env(), cwd=ROOT)
    import pycolfrag
    assert p.returncode == 0 and p.stdout.strip() == f"pycolfrag {pycolfrag.__version__}"
    assert os.access(exe, os.X_OK)
