"""PEER NGA .AT2 reader. The two files in tests/data were written for these tests from the
formulas quoted in tests/data/README.md, so the expected samples are those formulas rounded to
the file's printed digits (E15.7: 8 significant digits; F10.6: 1e-6 g absolute)."""
from pathlib import Path

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core.errors import PycolfragError, RecordFileError
from pycolfrag.ground_motion import read_at2

DATA = Path(__file__).parent / "data"
G = 9.81  # m/s^2, the package's g


def test_nga_west2_header():
    rec = read_at2(DATA / "synthetic_nga_west2.AT2")
    t = np.arange(23) * 0.01
    expected_g = 0.05 * np.exp(-t / 0.1) * np.sin(2 * np.pi * 2 * t)
    assert rec.dt == 0.01 and rec.n == 23
    np.testing.assert_allclose(rec.acc, expected_g * G, rtol=1e-7, atol=1e-12)  # E15.7 rounding
    assert rec.meta["npts"] == 23 and rec.meta["source"] == "AT2"
    assert len(rec.meta["header"]) == 4 and "SYNTHETIC" in rec.meta["title"]


def test_old_header():
    rec = read_at2(str(DATA / "synthetic_old_header.AT2"))
    t = np.arange(17) * 0.005
    assert rec.dt == 0.005 and rec.n == 17
    np.testing.assert_allclose(rec.acc, -0.2 * np.sin(2 * np.pi * 5 * t) * G, rtol=0, atol=0.6e-6 * G)


def test_record_goes_through_the_pipeline():
    rec = read_at2(DATA / "synthetic_old_header.AT2")
    ims = pcf.intensity.measures(rec.acc, rec.dt)
    assert ims["pga_g"] == pytest.approx(0.2, abs=1e-6)       # max |-0.2 sin| sampled at its peak
    assert rec.measures()["pga_g"] == ims["pga_g"]


HEADER = ["PEER NGA STRONG MOTION DATABASE RECORD", "TEST", "ACCELERATION TIME SERIES IN UNITS OF G"]


@pytest.mark.parametrize("line4, body, line, words", [
    ("NPTS=  3, DT= .0100 SEC", "0.1 0.2 abc", 5, ["'abc'"]),
    ("NPTS=  3, DT= .0100 SEC", "0.1 0.2\n0.3 0.4", 6, ["more values", "3"]),
    ("NPTS=  4, DT= .0100 SEC", "0.1 0.2\n0.3", 6, ["3 values", "NPTS = 4"]),
    ("NPTS=  3, DT= -.01 SEC", "0.1 0.2 0.3", 4, ["DT", "-.01"]),
    ("NPTS=  3, DT= 0 SEC", "0.1 0.2 0.3", 4, ["DT"]),
    ("NPTS= 3.5, DT= .01 SEC", "0.1 0.2 0.3", 4, ["NPTS", "3.5"]),
    ("NPTS=  3, DT= x SEC", "0.1 0.2 0.3", 4, ["DT", "'x'"]),
    ("garbage header", "0.1 0.2 0.3", 4, ["NPTS"]),
    ("NPTS=  3, DT= .0100 SEC", "0.1 nan 0.3", 5, ["non-finite", "nan"]),
])
def test_malformed_names_file_and_line(tmp_path, line4, body, line, words):
    p = tmp_path / "bad.AT2"
    p.write_text("\n".join(HEADER + [line4, body]) + "\n")
    with pytest.raises(RecordFileError) as ei:
        read_at2(p)
    msg = str(ei.value)
    assert isinstance(ei.value, ValueError) and isinstance(ei.value, PycolfragError)
    assert str(p) in msg and f"line {line}" in msg
    for w in words:
        assert w in msg


def test_wrong_units_and_short_file(tmp_path):
    p = tmp_path / "cm.AT2"
    p.write_text("A\nB\nACCELERATION TIME SERIES IN UNITS OF CM/S/S\nNPTS= 1, DT= .01 SEC\n1.0\n")
    with pytest.raises(RecordFileError, match="line 3"):
        read_at2(p)
    q = tmp_path / "short.AT2"
    q.write_text("only\ntwo lines\n")
    with pytest.raises(RecordFileError, match="4-line header"):
        read_at2(q)


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(OSError):
        read_at2(tmp_path / "nope.AT2")
