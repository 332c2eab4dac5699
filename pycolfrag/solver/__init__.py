"""One run of a structure under a record (:mod:`.run`: ``simulate``, ``simulate_batch``), the solver's
options (:mod:`.options`), the scene's set-up in C (:mod:`.scene_setup`), the state that carries over
(:mod:`.state`), what sets the step (:mod:`.step_cause`) and one sample: record -> IMs -> response -> row
(:mod:`.sample`)."""
from pycolfrag.solver.run import (  # noqa: F401 (the run's public names, as the module had them)
    CONTACT_OPTIONS,
    MAX_ABS_ACC,
    EnergyWarning,
    History,
    Response,
    SolverOptions,
    StepWarning,
    batch_width,
    simulate,
    simulate_batch,
)
