"""The README as a newcomer reads it: at most 150 lines, every Python block runs as written from a fresh
interpreter and prints what its comments say, every command it lists exists, every page it links exists.

The printed numbers are the README's own comments (``# 0.065 0.0065 False``), to the digits shown there: a
README whose example no longer gives what it claims fails here.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from pycolfrag.cli import main as commands

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def test_readme_is_short():
    assert len(README.splitlines()) <= 150


def test_readme_defines_the_edps():
    for name in ("`u_top`", "`u_d`", "`collapsed`"):
        assert f"| {name} |" in README, name


def test_readme_python_blocks_run_and_print_what_they_say(tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks
    for code in blocks:
        env = dict(os.environ, MPLBACKEND="Agg")
        p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                           timeout=600)
        assert p.returncode == 0, p.stderr
        for line in code.splitlines():
            m = re.match(r"print\((.*)\)\s+#\s*(.+)$", line.strip())
            if m:
                claimed = m.group(2).split()
                printed = p.stdout.split()
                assert len(printed) == len(claimed), (printed, claimed)
                for got, want in zip(printed, claimed, strict=True):
                    if want in ("True", "False"):
                        assert got == want
                    else:   # the digits the README shows
                        assert f"{float(got):.{len(want.split('.')[1])}f}" == want, (got, want)
        for png in re.findall(r'savefig\("([^"]+)"\)', code):
            assert (tmp_path / png).stat().st_size > 10_000, png


def test_readme_commands_and_links_exist():
    for name in re.findall(r"\| `pycolfrag ([a-z-]+)`", README):
        assert name in commands.COMMANDS, name
    for name in re.findall(r"`(record-report|record-checks|replay|timeline)`", README):
        assert name in commands.COMMANDS, name
    for link in re.findall(r"\]\(((?:docs/)?[^)#:]+\.(?:md|png|cff)|LICENSE)\)", README):
        assert (ROOT / link).is_file(), link
