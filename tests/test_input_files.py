"""The one policy for the text files a user names (pycolfrag/core/input_files.py): regular files only,
bounded, UTF-8, and a clear exception naming the file for everything else. Each case is a hostile
input that once hung the reader (a FIFO), exhausted memory (/dev/zero) or ended in a traceback."""
import os
import threading

import pytest

from pycolfrag.core import input_files
from pycolfrag.core.errors import HazardFileError, ParameterError


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


def _column_json(tmp_path, text: str):
    p = tmp_path / "column.json"
    p.write_text(text, encoding="utf-8")
    return p


def test_a_json_column_with_a_key_twice_is_refused_naming_it(tmp_path):
    """JSON keeps the last of two equal keys silently: a column file with "density" twice read as the
    second value. Refused, at the top level and inside a nested table (the joints), with the key named."""
    from pycolfrag.structure.column import Column
    good = Column.single_block(1.0, 2.0).to_dict()
    import json
    text = json.dumps(good)
    assert Column.from_file(_column_json(tmp_path, text)).density == good["density"]   # the file as written
    twice = text.replace('"density":', '"density": 1000.0, "density":', 1)
    with pytest.raises(ParameterError, match=r"column file .*duplicate key 'density' in one object"):
        Column.from_file(_column_json(tmp_path, twice))
    joints = json.dumps(good["joints"])
    first = next(iter(good["joints"]))
    nested = text.replace(joints, joints[:-1] + f', "{first}": 0.1}}', 1)
    assert nested != text
    with pytest.raises(ParameterError, match=f"duplicate key '{first}'"):
        Column.from_file(_column_json(tmp_path, nested))


def test_a_json_scene_with_a_key_twice_is_refused_naming_it(tmp_path):
    import json

    from pycolfrag.structure.column import Column
    from pycolfrag.structure.scene import Colonnade
    scene = {"name": "portal", "n_columns": 2, "spacing": 3.0, "column": Column.single_block(1.0, 2.0).to_dict()}
    p = tmp_path / "scene.json"
    p.write_text(json.dumps(scene), encoding="utf-8")
    assert Colonnade.from_file(p).n_columns == 2
    p.write_text(json.dumps(scene).replace('"n_columns": 2', '"n_columns": 2, "n_columns": 3'), encoding="utf-8")
    with pytest.raises(ParameterError, match=r"scene file .*duplicate key 'n_columns'"):
        Colonnade.from_file(p)


def test_json_loads_keeps_what_json_reads_otherwise():
    text = '{"a": [1, {"b": 2.5, "c": null}], "d": "x"}'
    import json
    assert input_files.json_loads(text) == json.loads(text)
    with pytest.raises(ValueError, match="duplicate key 'b'"):
        input_files.json_loads('{"a": {"b": 1, "b": 2}}')
