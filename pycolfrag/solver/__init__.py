"""One run of a structure under a record (:mod:`.run`: ``simulate``, ``simulate_batch``), the solver's
options (:mod:`.options`), the scene's set-up in C (:mod:`.scene_setup`), the state that carries over
(:mod:`.state`), what sets the step (:mod:`.step_cause`) and one sample: record -> IMs -> response -> row
(:mod:`.sample`)."""
from pycolfrag.solver.run import (  # noqa: F401
    CONTACT_OPTIONS,
    EnergyWarning,
    History,
    Response,
    StepWarning,
    simulate,
    simulate_batch,
)
