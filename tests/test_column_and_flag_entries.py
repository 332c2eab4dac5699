"""Entry values found wrong by a hostile review: a column made of None, a column file that is not a
file (None, a number, a folder, a FIFO), and flags given as integers (``history=1``).

A flag is True or False (Python's or numpy's bool) and nothing else; the flags of a results file's
solver options still read back (JSON and HDF5 give bools). The column file goes through the one
policy for files a user names (``pycolfrag.core.input_files``): a FIFO is refused before it is opened,
where a plain ``open`` would wait for a writer forever."""
import json
import os
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core.errors import ParameterError

COL = pcf.Column.parthenon()
ACC = np.zeros(5)          # at rest: the run is instant and its numbers do not matter here


@pytest.mark.parametrize("blocks, needle", [
    (None, "blocks must be a sequence of Block (from the bottom up), got NoneType None"),
    ("drums", "blocks must be a sequence of Block (from the bottom up), got str 'drums'"),
    (3, "blocks must be a sequence of Block (from the bottom up), got int 3"),
])
def test_a_column_of_no_blocks_is_refused_by_name(blocks, needle):
    with pytest.raises(ParameterError) as info:
        pcf.Column(blocks)
    assert needle in str(info.value)


@pytest.mark.parametrize("path, needle", [
    (None, "column file must be a path (str or os.PathLike), got None"),
    (123, "column file must be a path (str or os.PathLike), got 123"),
])
def test_a_column_file_that_is_no_path_is_refused_by_name(path, needle):
    with pytest.raises(ParameterError) as info:
        pcf.Column.from_file(path)
    assert needle in str(info.value)


def test_a_folder_is_no_column_file(tmp_path):
    with pytest.raises(ParameterError, match=f"column file {tmp_path} is a folder, not a regular file"):
        pcf.Column.from_file(tmp_path)
    with pytest.raises(FileNotFoundError, match="column file .*nope.toml does not exist"):
        pcf.Column.from_file(tmp_path / "nope.toml")


def test_a_fifo_as_column_file_is_refused_at_once(tmp_path):
    """In a child with a time limit: a reader that opened the FIFO would wait for a writer forever."""
    fifo = tmp_path / "column.json"
    os.mkfifo(fifo)
    code = textwrap.dedent(f"""
        import pycolfrag as pcf
        try:
            pcf.Column.from_file({str(fifo)!r})
        except pcf.errors.ParameterError as exc:
            print(exc)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == f"column file {fifo} is a FIFO (named pipe), not a regular file"


@pytest.mark.parametrize("value", [1, 0, np.int64(1), 1.0, "yes", None])
def test_history_takes_true_or_false_only(value):
    with pytest.raises(ParameterError) as info:
        pcf.simulate(COL, ACC, 0.01, history=value)
    assert str(info.value) == f"history must be True or False, got {type(value).__name__} {value!r}"
    with pytest.raises(ParameterError, match="history must be True or False"):
        pcf.simulate_batch(COL, [(ACC, 0.01)], history=value)


def test_flags_of_python_and_numpy_are_flags():
    assert pcf.simulate(COL, ACC, 0.01, history=np.True_).history is not None
    assert pcf.simulate(COL, ACC, 0.01, history=False).history is None
    assert pcf.SolverOptions(planar=np.bool_(True)).planar is True
    for name in ("planar", "monolithic", "early_exit"):
        with pytest.raises(ParameterError, match=f"^{name} must be True or False, got int 1$"):
            pcf.SolverOptions(**{name: 1})


def test_flags_survive_the_round_trips_of_a_results_file(tmp_path):
    """The solver options a results file stores (the ``solver`` attribute, JSON) read back equal; a
    flag stored as an HDF5 attribute itself comes back as a numpy bool, also a flag."""
    opts = pcf.SolverOptions(planar=True, early_exit=False, monolithic=True)
    with h5py.File(tmp_path / "f.h5", "w") as f:
        f.attrs["solver"] = json.dumps(opts.to_dict())
        f.attrs["planar"] = opts.planar
    with h5py.File(tmp_path / "f.h5", "r") as f:
        back = pcf.SolverOptions.from_dict(json.loads(f.attrs["solver"]))
        raw = f.attrs["planar"]
    assert back == opts and isinstance(raw, np.bool_)
    assert pcf.SolverOptions(planar=raw).planar is True
