"""Each kind of grid declares what differs about it, and nothing branches on a layout's name.

* a kind of row is data (``pycolfrag.layouts.RowKind``): registered, its file's fields are its own around
  the shared ones, and what names one of its rows decides which done rows are false (no edit of
  ``pycolfrag/results``: the toy kind below is registered from this test);
* ``pycolfrag/results`` spells no kind's own field (the rare algorithm's tags among them);
* the grid's probes, its command and the command line after it ask the spec (``probe``,
  ``check_inputs``, ``expected_work``, ``after_run``) instead of testing ``spec.layout``.

The expected values are the declarations themselves (no numbers of a physics run enter here).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pycolfrag import grid, layouts
from pycolfrag import results as R
from pycolfrag.grid import probes
from pycolfrag.layouts import RowKind

ROOT = Path(__file__).resolve().parents[1]

TOY = RowKind(name="toy-trials", identity={"trial": ("i4", -1, "trial index"), "label": ("S8", b"", "its label")},
              inputs={"knob": ("f8", np.nan, "the knob, -")}, named_by=("trial", "label"), owner="this test")


@pytest.fixture
def toy_layout():
    fields = R.register_layout(TOY)
    yield fields
    for n in TOY.names:                       # leave the registry as the package fills it
        R.layout.LAYOUTS.pop(n)
        R.layout._KINDS.pop(n)


def test_a_kind_of_row_is_one_declaration(toy_layout):
    names = list(toy_layout)
    shared = [k for k in R.SAMPLE_FIELDS if k not in layouts.synthetic.KIND.identity
              and k not in layouts.synthetic.KIND.inputs]
    assert names == ["trial", "label", "status", "message", "knob", *shared[2:]]
    assert R.fields_of("toy-trials") is toy_layout and R.fields_of(b"toy-trials") is toy_layout
    samples, _ = R.empty_columns(4, 1, "toy-trials")
    samples["status"][:] = [0, 0, 0, R.STATUS_PENDING]
    samples["trial"][:] = [3, -1, -1, -1]
    samples["label"][:] = [b"", b"x", b" ", b""]
    # named by its trial or its label: row 2 (neither) is done without a name, row 3 is pending
    assert R.layout.false_done(samples, "toy-trials").tolist() == [False, False, True, False]
    with pytest.raises(ValueError, match="registered already"):
        R.register_layout(RowKind("records", {}, {}, (), "another test"))


def test_the_package_kinds_are_the_registry():
    assert [k.name for k in layouts.KINDS] == [None, "records", "events"]
    for k in layouts.KINDS:
        for n in k.names:
            assert R.kind_of(n) is k and list(R.fields_of(n))[:len(k.identity)] == list(k.identity)
    with pytest.raises(R.ResultsFileError, match="known: synthetic, records, events"):
        R.fields_of("nonsense")


def test_results_spells_no_kind_of_rows_own_field():
    own = {f for k in layouts.KINDS for f in k.identity if f not in ("mw", "dist_km")}
    hits = [f"{p.name}: {f}" for p in sorted((ROOT / "pycolfrag" / "results").glob("*.py"))
            for f in own if re.search(rf"[\"']{f}[\"']", p.read_text())]
    assert not hits, hits


def test_no_driver_or_command_branches_on_a_layout_name():
    # (make_outputs' "read" is its own sentinel, not a layout: "read it from the file")
    pattern = re.compile(r"layout\s*(==|!=|\bis\b)\s*(['\"](?!read['\"])|None)")
    hits = [f"{p.relative_to(ROOT)}:{n}: {line.strip()}"
            for folder in ("grid", "cli") for p in sorted((ROOT / "pycolfrag" / folder).glob("*.py"))
            for n, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
    assert not hits, hits


class _ToySpec(grid.GridSpec):
    """A kind of grid that differs only by what it declares."""

    after_run = "pycolfrag.cli.grid:record_outputs"

    def probe(self):
        return np.zeros(4), 0.01, "the toy's record", [("toy", 2.0)], "--toy-scale"

    def expected_work(self, durations, timing, log):
        log(f"toy work of {durations}")
        return 1e9


def test_the_probes_and_the_command_ask_the_spec():
    spec = _ToySpec(mw=(6.0,), dist_km=(5.0,), samples=1)
    assert spec.layout is None and spec.fields is R.SAMPLE_FIELDS
    assert probes.probe_rows(spec) == [("toy", 2.0)]            # its probe, not the synthetic one
    said = []
    probes.check_work(spec, [("toy", 2.0)], {"dt_s": 1e-3, "step_s": 1e-6}, said.append)
    assert said[0] == "toy work of [('toy', 2.0)]" and "expected work about" in said[1]
    from pycolfrag.cli import grid as cli_grid
    assert cli_grid._after_run(spec.after_run) is cli_grid.record_outputs
    assert grid.spec_kind(None) is grid.GridSpec and grid.spec_kind("records") is grid.RecordGridSpec
    assert grid.spec_kind(b"events") is grid.EventBatchSpec and grid.spec_kind("synthetic") is grid.GridSpec
