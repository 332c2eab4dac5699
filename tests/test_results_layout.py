"""The results layouts: the IM/EDP fields come from the one registry
(pycolfrag.core.names) without changing the synthetic layout, and the record-suite layout is the one
documented in docs/results_format.md."""
import re
import subprocess
import sys
import textwrap
from pathlib import Path

from pycolfrag import results as R
from pycolfrag.core import names

DOC = Path(__file__).resolve().parent.parent / "docs" / "results_format.md"


def _doc_table(after: str) -> list:
    """(field, dtype) rows of the first markdown table after the heading ``after`` in results_format.md."""
    text = DOC.read_text()
    part = text[text.index(after):]
    rows, started = [], False
    for line in part.splitlines()[1:]:
        m = re.match(r"^\| `(\w+)` \| (\w+) \|", line)
        if m:
            rows.append((m.group(1), m.group(2)))
            started = True
        elif started and not line.startswith("|"):
            break
    return rows


def test_synthetic_layout_is_the_documented_one():
    """Names, order and dtypes of /samples of a synthetic grid = the table of docs/results_format.md
    (written before the registry drove the writer: the layout did not change)."""
    doc = _doc_table("## `/samples`")
    got = [(k, f"S{R.MESSAGE_BYTES}" if code == "S" else code) for k, (code, _, _) in R.SAMPLE_FIELDS.items()]
    assert got == doc


def test_record_layout_is_the_documented_one():
    doc = dict(_doc_table("## Record-suite files"))
    for k, code in doc.items():
        assert R.RECORD_SAMPLE_FIELDS[k][0] == code, k
    # and the shared tail (IMs, EDPs, run diagnostics) of the synthetic layout, same dtypes
    for k in list(names.SCALAR_IMS) + list(names.EDPS) + ["collapsed", "n_steps", "collapse_reason", "wall_s"]:
        assert R.RECORD_SAMPLE_FIELDS[k] == R.SAMPLE_FIELDS[k], k
    assert set(R.SPECTRA_FIELDS) == set(names.SPECTRAL_IMS)


def test_event_layout_is_the_documented_one():
    """The identity and inputs of an event row (docs/results_format.md, "Event files") in this order, then the
    synthetic layout's fields from mw on, the same dtypes."""
    doc = _doc_table("## Event files")
    got = list(R.EVENT_SAMPLE_FIELDS.items())
    head = [(k, code) for k, (code, _, _) in got[:len(doc)]]
    assert head == doc
    tail = [k for k, _ in got[len(doc):]]
    assert tail == [k for k in R.SAMPLE_FIELDS if k not in ("scenario", "sample")]
    assert all(R.EVENT_SAMPLE_FIELDS[k] == R.SAMPLE_FIELDS[k] for k in tail)


def test_a_new_im_in_the_registry_reaches_both_layouts():
    """Declaring an IM in pycolfrag.core.names is enough for the writer: a child interpreter adds one
    and (re)loads the layout of pycolfrag.results, and finds it in both layouts with its description."""
    code = textwrap.dedent("""
        import importlib
        from pycolfrag import names
        names.IMS["cav_m_s"] = names.Quantity("cav_m_s", "m/s", "CAV (m/s)", "CAV", description="cumulative absolute velocity")
        from pycolfrag import results as R
        from pycolfrag.results import layout
        importlib.reload(layout)
        R = importlib.reload(R)     # the package's names are the layout's
        for fields in (R.SAMPLE_FIELDS, R.RECORD_SAMPLE_FIELDS):
            assert fields["cav_m_s"] == ("f8", fields["pga_g"][1], "cumulative absolute velocity, m/s"), fields.get("cav_m_s")
        print("ok")
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "ok", p.stderr
