"""A small demo record suite, in the layout of a PEER NGA-West2 download (the tests' suite, and the
fallback suite of the record scripts when no real records are at hand).

Every record is a closed-form motion, so its IMs are known without running any code of ours:

* ``RSN9001`` "Sine Quake" -- H1 = 0.30 g sin(2 pi 2 t), H2 = 0.20 g sin(2 pi 1 t), V = 0.10 g sin(2 pi 3 t),
  4 s at dt = 0.005 s: PGA = amplitude (a sample falls on every crest), PGV = A g / (pi f)
  (velocity from rest: A g / (2 pi f) (1 - cos 2 pi f t)).
* ``RSN9002`` "Pulse Quake" -- H1 = one full sine cycle of acceleration, Ap = 0.40 g, Tp = 1 s, then
  3 s at rest; H2 = the same pulse at half amplitude; no vertical. PGA = Ap, PGV = Ap g Tp / pi.
* ``RSN9003`` "Far Quake" -- H1 = 0.05 g sin(2 pi 0.5 t), H2 = 0.05 g cos(2 pi 0.5 t) (dt = 0.01 s):
  a circular motion whose peak is the same in every direction.

:func:`write_suite` writes the AT2 files, ``_SearchResults.csv`` (header block, metadata table,
notes and a spectra block, as PEER writes them) and ``suite.csv`` (our plain format).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["RECORDS", "write_suite", "write_at2"]


def sine(amp_g, f_hz, duration_s, dt, phase=0.0):
    t = np.arange(int(round(duration_s / dt)) + 1) * dt
    return amp_g * np.sin(2 * math.pi * f_hz * t + phase)


def pulse(amp_g, tp_s, duration_s, dt):
    t = np.arange(int(round(duration_s / dt)) + 1) * dt
    return np.where(t <= tp_s, amp_g * np.sin(2 * math.pi * t / tp_s), 0.0)


#: record id -> (dt, {component: acceleration in g}, metadata)
RECORDS = {
    "RSN9001": (0.005, {"h1": sine(0.30, 2.0, 4.0, 0.005), "h2": sine(0.20, 1.0, 4.0, 0.005),
                        "v": sine(0.10, 3.0, 4.0, 0.005)},
                dict(event="Sine Quake", year=2001, station="Station A", mw=6.5, mechanism="strike slip",
                     rjb_km=19.0, rrup_km=20.0, vs30=400.0, tp="-",
                     files=("RSN9001_SINE_A000.AT2", "RSN9001_SINE_A090.AT2", "RSN9001_SINE_A-UP.AT2"))),
    "RSN9002": (0.005, {"h1": pulse(0.40, 1.0, 4.0, 0.005), "h2": pulse(0.20, 1.0, 4.0, 0.005)},
                dict(event="Pulse Quake", year=2002, station="Station B, North", mw=7.0, mechanism="Reverse",
                     rjb_km=15.5, rrup_km=16.0, vs30=760.0, tp="1.0",
                     files=("RSN9002_PULSE_B-N.AT2", "RSN9002_PULSE_B-E.AT2", "-----"))),
    "RSN9003": (0.01, {"h1": sine(0.05, 0.5, 6.0, 0.01), "h2": sine(0.05, 0.5, 6.0, 0.01, phase=math.pi / 2)},
                dict(event="Far Quake", year=2003, station="Station C", mw=6.0, mechanism="Normal",
                     rjb_km=40.0, rrup_km=42.0, vs30=300.0, tp="-",
                     files=("RSN9003_FAR_C045.AT2", "RSN9003_FAR_C135.AT2", "-----"))),
}


def write_at2(path, acc_g, dt, title="TEST", npts=None):
    """An AT2 file as PEER writes it: 4 header lines, then 5 values per line in E format."""
    acc_g = np.asarray(acc_g, dtype=float)
    lines = ["PEER NGA STRONG MOTION DATABASE RECORD", f"{title}, 1/1/2000, TEST STATION, 000",
             "ACCELERATION TIME SERIES IN UNITS OF G",
             f"NPTS= {acc_g.size if npts is None else npts:5d}, DT= {dt:8.4f} SEC"]
    for i in range(0, acc_g.size, 5):
        lines.append("".join(f"{v:16.7E}" for v in acc_g[i:i + 5]))
    Path(path).write_text("\n".join(lines) + "\n")


PEER_COLUMNS = ("Result ID, Spectral Ordinate, Record Sequence Number, Mean Squared Error, Scale Factor, "
                "Tp-Pulse Period (sec), 5-75% Duration (sec), 5-95% Duration (sec), Arias Intensity (m/sec), "
                "Earthquake Name, Year, Station Name, Magnitude, Mechanism, Rjb (km), Rrup (km), Vs30 (m/sec), "
                "Lowest Useable Frequency (Hz), Initial-search Scale Factor, Horizontal-1 Acc. Filename, "
                "Horizontal-2 Acc. Filename, Vertical Acc. Filename")


def peer_row(i, rsn, m):
    """One data row as PEER writes it: names in doubled quotes after a space, commas in names as '_'."""
    f1, f2, fv = m["files"]
    return (f"{i}, SRSS,{rsn},0.2034,1.4457, {m['tp']},21.7,27.1,2.3,\" \"\"{m['event']}\"\"\",{m['year']},"
            f"\" \"\"{m['station'].replace(',', '_')}\"\"\",{m['mw']}, {m['mechanism']},{m['rjb_km']},"
            f"{m['rrup_km']},{m['vs30']},0.07,1.5578, {f1}, {f2} , {fv}  ,,,,,,,,,")


def search_results_text(rows):
    head = [" PEER Ground Motion Database, Time Series Search Report -- NGA-West2 -- 2022-01-12,,,,,",
            ",,,,,", ",,,,,", " -- Summary of PEER Ground Motion Database Search Criteria --,,,,,",
            "Magnitude Min:,6.7,,,,", "Magnitude Max:,8,,,,", "Pulse:,1,,,,", "Component:, SRSS,,,,",
            ",,,,,", ",,,,,", " -- Summary of Metadata of Selected Records --,,,,,,", PEER_COLUMNS + ",,,,,,,,,"]
    tail = [",,,,,", " These records were obtained from the NGA-West2 On-Line Ground-Motion Database Tool,,,,",
            " These records are UNSCALED, AS RECORDED,,,,", ",,,,,",
            " -- Scaled Spectra used in Search & Scaling --,,,,,",
            "Period (sec),Target pSa (g),Arithmetic Mean pSa (g),", "0.01,0.74433468,0.66003232,"]
    return "\n".join(head + rows + tail) + "\n"


def write_suite(folder, records=RECORDS):
    """Write the AT2 files, ``_SearchResults.csv`` and ``suite.csv`` into ``folder``; return the folder."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    peer_rows, plain = [], ["record_id,file_h1,file_h2,file_v,mw,rrup_km,event,station,note"]
    for i, (rid, (dt, comps, m)) in enumerate(records.items(), start=1):
        for comp, name in zip(("h1", "h2", "v"), m["files"]):
            if comp in comps:
                write_at2(folder / name, comps[comp], dt, title=m["event"].upper())
        peer_rows.append(peer_row(i, rid[3:], m))
        files = [n if not n.startswith("-") else "" for n in m["files"]]
        plain.append(f"{rid},{files[0]},{files[1]},{files[2]},{m['mw']},{m['rrup_km']},{m['event']},"
                     f"\"{m['station']}\",plain note {i}")
    (folder / "_SearchResults.csv").write_text(search_results_text(peer_rows))
    (folder / "suite.csv").write_text("# a record suite in the plain format of docs/records.md\n" + "\n".join(plain) + "\n")
    return folder
