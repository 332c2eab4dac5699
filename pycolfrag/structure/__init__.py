"""What stands on the ground: a column of drums (:mod:`.column`), its dowels (:mod:`.connectors`, the laws
read from C's registry in :mod:`.connector_laws`), a tilted foundation (:mod:`.foundation`), drums as built
(:mod:`.as_built`: offsets, turns, chipped faces, missing parts, and their checks), colonnades with
epistyles (:mod:`.scene`); the Structure contract: the registry of kinds (:mod:`.kinds`) and the parts a
structure gives the solver (:mod:`.scene_parts`). Inputs and their checks: the solver
(:mod:`pycolfrag.solver`) sets them up in C."""
