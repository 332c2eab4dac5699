"""Every ``pycolfrag`` command names itself as the user runs it: its usage line says
``pycolfrag COMMAND`` (five said ``python -m pycolfrag.analysis.X``), its help cites ``pycolfrag grid``
rather than ``scripts/run_grid.py``, ``risk --help`` shows the ``--simulate`` form's options, and ``risk``
given only the grid with pulses says the one command that makes the no-pulse grid."""
import shlex
import subprocess
import sys

import pytest

from pycolfrag import commands
from pycolfrag.commands import COMMANDS
from test_grid import ROOT, SMALL, _ok, _serial


def _help(capsys, run) -> str:
    with pytest.raises(SystemExit) as exc:
        run(["--help"])
    assert exc.value.code in (0, None)
    return capsys.readouterr().out


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_command_names_itself_in_its_usage(name, capsys, monkeypatch):
    # through the pycolfrag entry
    with pytest.raises(SystemExit) as exc:
        commands.main([name, "--help"])
    assert exc.value.code in (0, None)
    text = capsys.readouterr().out
    assert text.startswith(f"usage: pycolfrag {name} "), text[:200]
    assert "python -m pycolfrag." not in text
    if name != "grid":   # the grid's own help names its older alias on purpose
        assert "run_grid.py" not in text
    # and through the module's own main, run under another name (python -m ..., the old scripts): argparse's
    # default prog would be that name, so the command's own prog= must say it
    monkeypatch.setattr(sys, "argv", ["some_script.py"])
    text = _help(capsys, COMMANDS[name].load())
    assert text.startswith(f"usage: pycolfrag {name} "), text[:200]


def test_risk_help_shows_the_simulate_form(capsys):
    text = _help(capsys, COMMANDS["risk"].load())
    for opt in ("--simulate OUTDIR", "--target-cov", "--max-runs", "--batch", "--pilot"):
        assert opt in text, opt


def test_risk_with_the_pulse_grid_alone_gives_the_command_of_the_no_pulse_grid(tmp_path):
    """The message's command, run as given, makes the no-pulse twin, and risk then takes both."""
    pulse = tmp_path / "g.h5"
    _ok(_serial([*SMALL, "--out", str(pulse)]))
    risk = [sys.executable, "-m", "pycolfrag", "risk", "examples/site_athens.toml", str(pulse), str(tmp_path / "o"),
            "--no-figures", "--draws", "50"]
    p = subprocess.run(risk, capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    nopulse = tmp_path / "g_nopulse.h5"
    want = shlex.join(["pycolfrag", "grid", *SMALL, "--pulse", "none", "--out", str(nopulse)])
    assert f"make them with {want} ;" in p.stderr, p.stderr
    _ok(_serial(shlex.split(want)[2:]))
    p = subprocess.run([*risk, "--no-pulse", str(nopulse)], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
