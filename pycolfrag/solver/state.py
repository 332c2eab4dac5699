"""The state that carries over from one run to the next (docs/sequences.md, "State that carries over").

:func:`pycolfrag.simulate` returns the state at the end of its run as ``Response.final_state``, and
``simulate(model, acc, dt, initial_state=state)`` continues from one instead of from rest: the next
record of an earthquake sequence on the damaged column. A :class:`State` holds the C solver's flat
array (``cf_solver_state_get``: every body's position, rotation and velocity, the joints' contact
state, the connectors' law state with their yield, crushing and break, the epistyles as bodies, and
the monitor's running values) and what it belongs to: the model (its kind, name and the digest of its
canonical JSON), the contact model, the package version and the digest of the C library's sources. A
state is refused by a run of another model, contact model, version or code, naming the difference.
It saves to and loads from HDF5 (float64) and JSON (``repr`` of each float: lossless).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import check, ffi, lib, ptr
from pycolfrag.core.version import __version__
from pycolfrag.structure.column import Column

#: the format of a saved state (the C layout's own version is its first value)
FORMAT = "pycolfrag-state-1"
_HEAD, _MON = 22, 12   # solver_state.c's CF_ST_HEAD and CF_ST_MON: where the bodies start
_IDENTITY = ("kind", "model_name", "model_digest", "contact", "version", "code_digest")


def identity(model, options) -> dict:
    """What a state of a run of ``model`` with ``options`` belongs to."""
    return {"kind": "column" if isinstance(model, Column) else "scene", "model_name": model.name,
            "model_digest": hashlib.sha256(model.to_json().encode()).hexdigest(), "contact": options.contact,
            "version": __version__, "code_digest": ffi.string(lib.cf_common_source_digest()).decode()}


@dataclass(frozen=True, eq=False)
class State:
    """The state at the end of a run (see the module's text): ``values`` is the C layout (float64)."""

    values: np.ndarray
    kind: str
    model_name: str
    model_digest: str
    contact: str
    version: str
    code_digest: str

    @property
    def step(self) -> int:
        """The solver step whose positions the state holds (its velocities are half a step on)."""
        return int(self.values[12])

    @property
    def time(self) -> float:
        """Its time on the sequence's time axis, s (step x the solver step)."""
        return self.step * float(self.values[11])

    @property
    def collapsed(self) -> bool:
        return bool(self.values[14])

    def bodies(self) -> dict:
        """Every body's (the ground first, then the blocks, then the epistyles) position ``x`` (m),
        velocity ``v`` (m/s), unit quaternion ``q`` and angular velocity ``w`` (body axes, rad/s)."""
        nb = int(self.values[2])
        out, k = {}, _HEAD + _MON
        for name, w in (("x", 3), ("v", 3), ("q", 4), ("w", 3)):
            out[name] = self.values[k:k + w * nb].reshape(nb, w).copy()
            k += w * nb
        return out

    def identity(self) -> dict:
        return {k: getattr(self, k) for k in _IDENTITY}

    def check_for(self, model, options, caller: str) -> None:
        """Refuse (ParameterError naming the difference) a state of another model, contact model,
        version or code than a run of ``model`` with ``options``."""
        want = identity(model, options)
        for k in _IDENTITY:
            if getattr(self, k) != want[k]:
                raise ParameterError(f"{caller}: initial_state belongs to another {k.replace('_', ' ')}: "
                                     f"{getattr(self, k)!r}, this run's {want[k]!r}")

    def save(self, path) -> None:
        """Write to ``path``: HDF5 (``.h5``, ``.hdf5``) or JSON (``.json``), both lossless."""
        path = Path(path)
        meta = {"format": FORMAT, **self.identity()}
        if path.suffix in (".h5", ".hdf5"):
            import h5py
            with h5py.File(path, "w") as f:
                f.create_dataset("values", data=np.asarray(self.values, dtype=np.float64))
                for k, v in meta.items():
                    f.attrs[k] = v
        elif path.suffix == ".json":
            meta["values"] = [float(v) for v in self.values]   # json writes repr: the float back exactly
            path.write_text(json.dumps(meta, sort_keys=True))
        else:
            raise ParameterError(f"State.save: path must end in .h5, .hdf5 or .json, got {str(path)!r}")

    @classmethod
    def load(cls, path) -> "State":
        """Read a state written by :meth:`save`."""
        path = Path(path)
        if path.suffix in (".h5", ".hdf5"):
            import h5py
            with h5py.File(path, "r") as f:
                meta = {k: (v.decode() if isinstance(v, bytes) else str(v)) for k, v in f.attrs.items()}
                values = np.array(f["values"], dtype=np.float64)
        elif path.suffix == ".json":
            meta = json.loads(path.read_text())
            values = np.array(meta.pop("values"), dtype=np.float64)
        else:
            raise ParameterError(f"State.load: path must end in .h5, .hdf5 or .json, got {str(path)!r}")
        if meta.get("format") != FORMAT:
            raise ParameterError(f"State.load: {str(path)!r} is not a state of format {FORMAT!r} "
                                 f"(format {meta.get('format')!r})")
        missing = [k for k in _IDENTITY if k not in meta]
        if missing:
            raise ParameterError(f"State.load: {str(path)!r} lacks {missing}")
        return cls(values=values, **{k: meta[k] for k in _IDENTITY})


def prepare(solver, model, options, initial_state, caller: str) -> None:
    """A set-up solver: keep its final state, and continue from ``initial_state`` (None: from rest)."""
    check(lib.cf_solver_state_keep(solver, 1), lib.cf_solver_message(solver), caller)
    if initial_state is None:
        return
    if not isinstance(initial_state, State):
        raise ParameterError(f"{caller}: initial_state must be a State, got {type(initial_state).__name__}")
    initial_state.check_for(model, options, caller)
    if initial_state.collapsed:   # one long run stops at the collapse: there is nothing to continue
        raise ParameterError(f"{caller}: initial_state is the state of a run that collapsed (at t = "
                             f"{initial_state.time:g} s): a sequence ends at a collapse, so no record continues it")
    v = np.ascontiguousarray(initial_state.values, dtype=np.float64)
    check(lib.cf_solver_state_set(solver, ptr(v), v.size), lib.cf_solver_message(solver), caller)


def take(solver, model, options) -> State | None:
    """The state the solver kept at the end of its run (None when it kept none)."""
    n = int(lib.cf_solver_state_size(solver))
    v = np.zeros(n)
    if n == 0 or lib.cf_solver_state_get(solver, ptr(v), n) != lib.CF_OK:
        return None
    return State(values=v, **identity(model, options))
