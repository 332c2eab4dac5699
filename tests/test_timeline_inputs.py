"""``pycolfrag timeline`` and ``pycolfrag replay`` given what a hostile user gives them: a FIFO (blocked
``open`` forever), a tampered ``n_ranks`` (a loop over 10^12 ranks), an edited ``kinds`` (read as "0 rows"
with no warning), outputs to paths that cannot be written (raw tracebacks).
Each case must end in seconds with a message naming what is wrong, exit 2, no traceback."""
import json
import os
import shutil
import subprocess
import sys

import h5py
import pytest

from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results.timeline import GROUP, KINDS, read_timeline
from test_grid import ROOT, SMALL, _ok, _serial


@pytest.fixture(scope="module")
def grid_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("tl") / "one.h5"
    _ok(_serial([*SMALL, "--out", str(out)]))
    return out


@pytest.fixture
def copy(grid_file, tmp_path):
    dst = tmp_path / "copy.h5"
    shutil.copy(grid_file, dst)
    return dst


def _run(*args, timeout=60):
    return subprocess.run([sys.executable, "-m", "pycolfrag", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=timeout)


def _refused(p, *words):
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    assert "Traceback" not in p.stderr, p.stderr
    for w in words:
        assert w in p.stderr, (w, p.stderr)


def test_a_fifo_is_refused_before_it_is_opened(tmp_path):
    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    p = _run("timeline", fifo, timeout=30)   # before the fix: blocked in open() until the timeout
    _refused(p, f"{fifo} is a FIFO")
    _refused(_run("replay", fifo, "--ranks", "1", timeout=30), f"{fifo} is a FIFO")


@pytest.mark.parametrize("value", [10 ** 12, 0, -3, "many"])
def test_a_tampered_n_ranks_is_refused_naming_it(copy, value):
    with h5py.File(copy, "r+", locking=False) as f:
        f[GROUP]["session_0"].attrs["n_ranks"] = value
    with pytest.raises(ResultsFileError, match=f"n_ranks {value!r}"):
        read_timeline(copy)
    for cmd in ("timeline", "replay"):   # before the fix: 10^12 iterations of a loop over the ranks
        _refused(_run(cmd, copy, "--ranks", "2") if cmd == "replay" else _run(cmd, copy), f"n_ranks {value!r}")


def test_n_ranks_below_the_rows_ranks_is_refused(copy):
    with h5py.File(copy, "r+", locking=False) as f:
        ds = f[GROUP]["session_0"]
        rows = ds[...]
        rows["rank"][0] = 4
        ds[...] = rows
    with pytest.raises(ResultsFileError, match="n_ranks 1: not an integer from 5 .* to [0-9]+"):
        read_timeline(copy)


def test_an_edited_kinds_attribute_is_flagged_by_the_checksum(copy):
    kinds = list(KINDS)
    i, j = kinds.index("chunk"), kinds.index("wait")
    kinds[i], kinds[j] = kinds[j], kinds[i]
    with h5py.File(copy, "r+", locking=False) as f:
        f[GROUP].attrs["kinds"] = json.dumps(kinds)
    assert not read_timeline(copy)["session_0"]["crc_ok"]
    p = _run("timeline", copy)
    assert p.returncode == 0 and "0 rows in 0 chunks" in p.stdout
    assert "WARNING: this timeline fails its CRC-32" in p.stdout


def test_an_edited_session_attribute_is_flagged_and_unknown_kinds_refused(copy):
    """n_ranks 3 is within range (the summary would be of 3 ranks): the attributes' CRC says it changed."""
    with h5py.File(copy, "r+", locking=False) as f:
        f[GROUP]["session_0"].attrs["n_ranks"] = 3
    assert not read_timeline(copy)["session_0"]["crc_ok"]
    with h5py.File(copy, "r+", locking=False) as f:
        f[GROUP].attrs["kinds"] = json.dumps(["launch", "crunch"])
    with pytest.raises(ResultsFileError, match="kinds attribute .*crunch"):
        read_timeline(copy)
    _refused(_run("timeline", copy), "crunch")


def test_an_untouched_timeline_passes_both_checksums(grid_file):
    sess = read_timeline(grid_file)["session_0"]
    assert sess["crc_ok"] and "attrs_crc32" not in sess["attrs"]


@pytest.mark.parametrize("where", ["missing/out.png", "folder.png"])
def test_outputs_that_cannot_be_written_are_refused_by_name(grid_file, tmp_path, where):
    """A path in a missing folder, and a folder in the file's place (the tests run as root: a folder
    without write permission would be written)."""
    target = png = tmp_path / where
    if where == "folder.png":
        target.mkdir()
    for args, opt in ((("timeline", grid_file, "--plot", png), "--plot"),
                      (("timeline", grid_file, "--json", target), "--json"),
                      (("replay", grid_file, "--ranks", "1", "--json", target), "--json")):
        p = _run(*args)
        _refused(p, f"cannot write {opt} {args[-1]}")
