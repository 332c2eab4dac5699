"""What stands on the ground: a column of drums (:mod:`.column`), its dowels (:mod:`.connectors`), a
tilted foundation (:mod:`.foundation`), colonnades with epistyles (:mod:`.scene`). Inputs only: the
solver (:mod:`pycolfrag.solver`) sets them up in C."""
