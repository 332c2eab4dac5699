"""The Structure contract and the registry of structure kinds (docs/architecture.md, "Costs of change").

A structure is what :func:`~pycolfrag.simulate`, :func:`~pycolfrag.simulate_batch`, a grid and a
results file take: today a :class:`~pycolfrag.structure.column.Column`, a :class:`~pycolfrag.structure.scene.Colonnade`
or a :class:`~pycolfrag.structure.lintel.LintelOnWall`.
Every kind of structure

* is a class with ``scene_parts()``, its parts for C (a :class:`~pycolfrag.structure.scene_parts.SceneParts`:
  columns at their places, beams, bearings, dowels; a column is a one-column scene), which
  :func:`pycolfrag.solver.scene_setup.setup`, the one text of a set-up, hands to C (``cf_solver_setup_scene``);
  and ``name``, ``to_dict()``, ``to_json()``, ``from_dict()``, ``n_blocks``, ``n_joints``, ``joints``,
  ``with_joints()`` as the column has them;
* has one line in :data:`KINDS`: its name, its class, its file key (the key of its ``to_dict()`` that
  says the kind; the default kind, a column, has none), whether a run reports its parts (per column,
  epistyle and dowel) even without dowels, and the EDPs its runs give (``names.EDPS``).

The kind of a structure is the line of its class (:func:`kind_of`), of a file's table the line whose
key it has (:func:`kind_of_dict`): no attribute or key is tested anywhere else. A new kind is its class,
its line here, and the C it truly needs: the lintel resting on a column and a wall (``lintel.py``) needed
no C (its wall is a column of rectangular blocks, ``Segment.rectangle``).
"""
from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass

from pycolfrag.core import input_files
from pycolfrag.core.errors import ParameterError
from pycolfrag.structure.column import Column
from pycolfrag.structure.lintel import LintelOnWall
from pycolfrag.structure.scene import Colonnade

__all__ = ["StructureKind", "Kinds", "KINDS", "BY_CLASS", "ACCEPTED", "kind_of", "kind_of_dict", "model_from_dict",
           "scene_from_file"]

#: The EDPs of every structure, of its dowels, of its epistyles (keys of ``names.EDPS``; a run of a
#: structure without such parts gives NaN for theirs).
STACK_EDPS = ("u_top", "u_d")
DOWEL_EDPS = ("dowel_shear_kn", "dowel_slip_mm", "dowels_yielded", "dowels_broken")
EPISTYLE_EDPS = ("epistyle_slip_mm", "epistyle_unseat")


@dataclass(frozen=True)
class StructureKind:
    """One kind of structure: see the module's text."""

    name: str
    cls: type
    file_key: str            # "" for the default kind (a table with no other kind's key)
    reports_parts: bool      # its Response has ``columns``, ``epistyles``, ``dowels`` (else only with dowels)
    edps: tuple[str, ...]


#: The registry, one line per kind; the default kind (no file key) first.
KINDS: tuple[StructureKind, ...] = (
    StructureKind("column", Column, "", False, STACK_EDPS + DOWEL_EDPS),
    StructureKind("colonnade", Colonnade, "n_columns", True, STACK_EDPS + DOWEL_EDPS + EPISTYLE_EDPS),
    StructureKind("lintel", LintelOnWall, "wall", True, STACK_EDPS + DOWEL_EDPS + EPISTYLE_EDPS),
)


class Kinds(dict):
    """The kinds by class: ``BY_CLASS[type(model)]``, a subclass taking its base's line (looked up, not
    stored), None for a class of no kind. A registered class is found without a call into this module
    (so a grid row's walk does not enter it)."""

    def __missing__(self, cls):
        return next((self[c] for c in cls.__mro__[1:] if dict.__contains__(self, c)), None)


#: The kinds by their class (:class:`Kinds`).
BY_CLASS = Kinds({k.cls: k for k in KINDS})
#: The kinds a model may be, in words, for messages ("a Column or a Colonnade").
ACCEPTED = " or ".join(f"a {k.cls.__name__}" for k in KINDS)


def kind_of(model, what: str = "col") -> StructureKind:
    """The kind of ``model`` (its class's line, or a base class's); ParameterError naming the accepted
    classes for anything else."""
    kind = BY_CLASS[type(model)]
    if kind is None:
        raise ParameterError(f"{what} must be {ACCEPTED}, got {type(model).__name__}")
    return kind


def kind_of_dict(d: dict) -> StructureKind:
    """The kind of a structure's table (a ``to_dict()``, a file): the kind whose file key it has, else
    the default kind."""
    return next((k for k in KINDS if k.file_key and k.file_key in d), KINDS[0])


def model_from_dict(d):
    """A structure from its ``to_dict()`` (a results file's ``column`` attribute, a grid's spec), of the
    kind its keys say (:func:`kind_of_dict`); an empty table is the default column."""
    if not d:
        return Column.parthenon()
    if not isinstance(d, dict):
        return Column.from_dict(d)   # the column's own message for what is not a table
    return kind_of_dict(d).cls.from_dict(d)


def scene_from_file(path):
    """A scene file (a grid's ``--scene``; docs/scene_format.md) read by the class of its kind: the scene
    kind whose file key it has, else the first scene kind (a colonnade, whose ``n_columns`` a file may
    leave out). The file is read by the one policy for files a user names (:mod:`pycolfrag.core.input_files`)."""
    name = os.fspath(path)
    text = input_files.read_text(path, "scene file")
    try:
        d = tomllib.loads(text) if name.lower().endswith(".toml") else input_files.json_loads(text)
    except ValueError as exc:
        raise ParameterError(f"cannot parse scene file {name}: {exc}") from None
    scenes = [k for k in KINDS if k.file_key]
    kind = next((k for k in scenes if isinstance(d, dict) and k.file_key in d), scenes[0])
    return kind.cls.from_file(path)
