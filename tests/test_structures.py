"""The Structure contract (pycolfrag/structure/kinds.py): every structure reaches C through
one set-up (scene_run.setup, a plain column as a one-column scene), and a structure's kind is its
registry line, never an attribute or a key tested elsewhere."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core import names
from pycolfrag.core.errors import ParameterError
from pycolfrag.solver import scene_setup as scene_run
from pycolfrag.solver.run import Response
from pycolfrag.structure import kinds as structures
from pycolfrag.structure.connectors import Connectors
from pycolfrag.structure.lintel import LintelOnWall
from pycolfrag.structure.scene import Colonnade
from pycolfrag.structure.scene_parts import SceneParts

T = np.arange(0.0, 1.0, 0.01)
ACC = 0.3 * 9.81 * np.sin(2 * np.pi * 2.0 * T)


def _spy(monkeypatch) -> list:
    seen: list = []
    real = scene_run.setup

    def setup(solver, d, parts, caller):
        seen.append(parts)
        return real(solver, d, parts, caller)

    monkeypatch.setattr(scene_run, "setup", setup)
    return seen


@pytest.mark.parametrize("call", ["simulate", "simulate_batch", "batch_width"])
def test_a_plain_column_is_set_up_as_a_one_column_scene(monkeypatch, call):
    """simulate, simulate_batch and batch_width set a plain column up through scene_run.setup (the one
    path into C), with its parts: itself at the origin, no beams, no dowels; its Response still
    reports no parts (a plain column's, as before)."""
    seen = _spy(monkeypatch)
    col = pcf.Column.parthenon()
    if call == "simulate":
        res = pcf.simulate(col, ACC, 0.01)
    elif call == "simulate_batch":
        res = pcf.simulate_batch(col, [(ACC, 0.01)])[0]
    else:
        res = None
        pcf.solver.run.batch_width(col)
    assert len(seen) == 1
    parts = seen[0]
    assert parts.columns == [(col, 0.0, 0.0)] and not parts.beams and not parts.bearings and not parts.dowels
    if res is not None:
        assert res.columns is None and res.dowels is None and np.isnan(res.dowel_shear_kn)


def test_every_structure_takes_the_one_set_up(monkeypatch):
    """A column with dowels and a portal go through the same function, with their dowels and beams."""
    seen = _spy(monkeypatch)
    dowelled = pcf.Column.parthenon().with_connectors(Connectors.of("titanium", (1,)))
    pcf.simulate(dowelled, ACC[:20], 0.01)
    pcf.simulate(Colonnade.portal(2), ACC[:20], 0.01)
    assert [len(p.dowels) for p in seen] == [1, 0] and [len(p.beams) for p in seen] == [0, 1]


def test_a_class_with_parts_is_not_a_structure_until_registered():
    """An object that merely has a ``scene_parts`` method is refused, naming the registered classes
    (the kind is the registry's line of its class, not an attribute found on the object)."""
    col = pcf.Column.parthenon()

    class Impostor:
        name = "impostor"

        def scene_parts(self):
            return col.scene_parts()

    with pytest.raises(ParameterError, match="col must be a Column or a Colonnade or a LintelOnWall, got Impostor"):
        pcf.simulate(Impostor(), ACC, 0.01)
    with pytest.raises(ParameterError, match="a Column or a Colonnade"):
        structures.kind_of(Impostor())


def test_the_kinds_are_read_from_the_registry():
    """kind_of follows a class's line (a subclass takes its base's), kind_of_dict a table's key."""
    col = pcf.Column.parthenon()

    class MyColumn(pcf.Column):
        pass

    assert structures.kind_of(col).name == "column"
    assert structures.kind_of(MyColumn(col.blocks)).name == "column"
    assert structures.kind_of(Colonnade.portal(2)).name == "colonnade"
    assert structures.kind_of_dict(col.to_dict()).name == "column"
    assert structures.kind_of_dict(Colonnade.portal(2).to_dict()).name == "colonnade"


def test_model_from_dict_reads_each_kind_by_its_file_key(monkeypatch):
    """A column's table, a colonnade's, the empty table (the default column); and a kind added by one
    registry line is read by its own key (the line is the whole of what the reader needs)."""
    col = pcf.Column.parthenon()
    portal = Colonnade.portal(2)
    assert structures.model_from_dict(col.to_dict()).to_json() == col.to_json()
    assert structures.model_from_dict(portal.to_dict()).to_json() == portal.to_json()
    assert structures.model_from_dict({}).to_json() == col.to_json()

    class Lintel:
        @classmethod
        def from_dict(cls, d):
            return ("lintel", d["lintel"])

    line = structures.StructureKind("lintel", Lintel, "lintel", True, structures.STACK_EDPS)
    monkeypatch.setattr(structures, "KINDS", (*structures.KINDS, line))
    assert structures.model_from_dict({"lintel": 2.5, "column": {}}) == ("lintel", 2.5)


def test_every_kind_declares_its_edps_and_parts():
    """Each line's EDPs are named quantities (names.EDPS) that a Response carries; each kind's
    example gives its parts for C as SceneParts; the default kind (no file key) comes first."""
    fields = {f.name for f in dataclasses.fields(Response)}
    examples = {"column": pcf.Column.parthenon(), "colonnade": Colonnade.portal(2), "lintel": LintelOnWall.example()}
    assert structures.KINDS[0].file_key == "" and all(k.file_key for k in structures.KINDS[1:])
    for kind in structures.KINDS:
        assert set(kind.edps) <= set(names.EDPS) and set(kind.edps) <= fields, kind
        assert isinstance(examples[kind.name].scene_parts(), SceneParts)


class _Lintel:
    """A stand-in for a new scene kind (its class is all a kind adds besides its registry line)."""

    name, n_blocks, n_joints = "a lintel", 3, 4

    def __init__(self, span):
        self.span = span

    @classmethod
    def from_dict(cls, d):
        return cls(d["lintel"])

    @classmethod
    def from_file(cls, path):
        return cls(("file", str(path)))


def _register_lintel(monkeypatch):
    line = structures.StructureKind("lintel", _Lintel, "lintel", True, structures.STACK_EDPS)
    monkeypatch.setattr(structures, "KINDS", (*structures.KINDS, line))
    monkeypatch.setattr(structures, "BY_CLASS", structures.Kinds({**structures.BY_CLASS, _Lintel: line}))


def test_a_scene_file_is_read_by_its_kind(monkeypatch, tmp_path):
    """A grid's --scene file: a colonnade's (n_columns given or left out, as the scene format allows),
    or, once a kind is registered, the file of that kind by its key."""
    import os
    examples = os.path.join(os.path.dirname(__file__), "..", "examples")
    assert structures.scene_from_file(os.path.join(examples, "portal_2.toml")).to_json() == \
        Colonnade.portal(2).to_json()
    bare = tmp_path / "bare.toml"
    bare.write_text('column = "' + os.path.abspath(os.path.join(examples, "column_parthenon.toml")) + '"\n')
    assert structures.scene_from_file(bare).n_columns == 2
    _register_lintel(monkeypatch)
    lintel = tmp_path / "lintel.toml"
    lintel.write_text("lintel = 3.5\n")
    assert structures.scene_from_file(lintel).span == ("file", str(lintel))


def test_the_report_describes_a_kind_it_does_not_know(monkeypatch):
    """A results file's model of a registered kind without a report text of its own is described by
    what every structure has (its name, blocks and joints), not read as a column."""
    from pycolfrag.analysis.report_text import model_lines
    _register_lintel(monkeypatch)
    assert model_lines('{"lintel": 2.0}') == ["- lintel: a lintel; 3 blocks, 4 joints"]
    assert model_lines(pcf.Column.parthenon().to_json())[0].startswith("- column")


def test_the_debug_plots_read_a_scene_by_its_parts():
    """plots_scene knows a scene by its kind and draws its parts: a portal's joints by column then its
    bearings, its columns' joint diameters in the history's order (the first column's top for top_disp)."""
    from pycolfrag.plots import scene as plots_scene
    portal, col = Colonnade.portal(2), pcf.Column.parthenon()
    assert plots_scene.is_scene(portal) and not plots_scene.is_scene(col) and not plots_scene.is_scene(None)
    n = col.n_joints
    labels = plots_scene.joint_labels(portal, portal.n_joints)
    assert labels[:2] == ["c1 base", "c1 joint 1"] and labels[n] == "c2 base" and labels[-1].startswith("bearing")
    assert list(plots_scene.column_joint_diameters(portal)) == 2 * list(col.joint_diameters)
    assert plots_scene.first_column(portal) is portal.column and plots_scene.first_column(col) is col
