"""The one policy for the text files a user names (pycolfrag/input_files.py): regular files only,
bounded, UTF-8, and a clear exception naming the file for everything else. Each case is a hostile
input that once hung the reader (a FIFO), exhausted memory (/dev/zero) or ended in a traceback."""
import os
import threading

import pytest

from pycolfrag import input_files
from pycolfrag.errors import HazardFileError, ParameterError


def test_reads_utf8_text_and_drops_a_bom(tmp_path):
    p = tmp_path / "a.toml"
    p.write_bytes("\ufeffname = \"Αθήνα\"\n".encode("utf-8"))
    assert input_files.read_text(p, "site file") == 'name = "Αθήνα"\n'


@pytest.mark.parametrize("bad", [None, 123, b"/tmp/x", "", 1.5])
def test_a_path_that_is_not_a_path_is_named(bad):
    with pytest.raises(ParameterError, match="column file must be a path"):
        input_files.read_text(bad, "column file")


def test_missing_file_is_the_callers_error_and_file_not_found(tmp_path):
    with pytest.raises(HazardFileError, match="does not exist") as info:
        input_files.read_text(tmp_path / "nope.csv", "hazard-curve file", error=HazardFileError)
    assert isinstance(info.value, FileNotFoundError)


def test_folder_is_refused(tmp_path):
    with pytest.raises(ParameterError, match="is a folder"):
        input_files.read_text(tmp_path, "site file")


def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    out = {}

    def read():
        try:
            input_files.read_text(fifo, "site file")
        except ParameterError as exc:
            out["msg"] = str(exc)

    t = threading.Thread(target=read, daemon=True)
    t.start()
    t.join(5.0)   # a blocking open of a FIFO without a writer would never return
    assert not t.is_alive(), "reading a FIFO blocked"
    assert "FIFO" in out["msg"]


def test_device_is_refused():
    with pytest.raises(ParameterError, match="character device"):
        input_files.read_bytes("/dev/zero", "hazard-curve file")


def test_size_limit(tmp_path):
    p = tmp_path / "big.csv"
    p.write_bytes(b"x" * 101)
    assert len(input_files.read_bytes(p, "hazard-curve file", max_bytes=101)) == 101
    with pytest.raises(ParameterError, match="101 bytes, more than the 100"):
        input_files.read_bytes(p, "hazard-curve file", max_bytes=100)


def test_not_utf8_names_the_offset(tmp_path):
    p = tmp_path / "latin1.csv"
    p.write_bytes("lon,lat\n# Jos\u00e9\n".encode("latin-1"))
    with pytest.raises(HazardFileError, match=r"not UTF-8 text \(byte 13 is 0xe9\)"):
        input_files.read_text(p, "hazard-curve file", error=HazardFileError)
