"""What sets a model's solver step, in words: the part whose spring on its mass is the stiffest.

The solver's step is ``dt_factor`` times the stability limit of the whole linearised model
(``csrc/solver_timestep.c``), which no part alone gives; but a limit thousands of times shorter than
a plain column's has one cause -- a dowel law far stiffer than its drum's mass calls for, an epistyle
almost without mass on its bearings, joints of an extreme ``kn`` -- and each part's own estimate
``2 sqrt(m / k)`` (its mass on its spring) names it. :func:`describe` is what a warning or a refusal
about a run's number of steps says of its cause (``simulate``'s :class:`~pycolfrag.solver.run.StepWarning`,
the grid's pre-run check).
"""
from __future__ import annotations

import math

__all__ = ["MAX_RUN_STEPS", "part_steps", "describe", "run_steps_warning"]

#: Solver steps above which ``simulate`` warns that a run will be long (the grid's MAX_ROW_STEPS:
#: ~2000 times a default row, minutes per run at 3 us per step).
MAX_RUN_STEPS = 5e7


def _parts(model):
    """(columns, beams, bearings, dowels) of a structure: its parts (the Structure contract)."""
    p = model.scene_parts()
    return [c for c, _, _ in p.columns], p.beams, p.bearings, p.dowels


def part_steps(model) -> list[tuple[float, str, str]]:
    """Each part's estimate of its stable step, ``2 sqrt(m / k)`` s, with what it is and what would
    lengthen it: the joints of the first column (kn x the joint's area on the lighter block it
    joins), every dowel law (its k_shear and k_axial on the lighter block of its joint), every
    epistyle (its mass on its bearings' kn x area). Sorted shortest first."""
    cols, beams, bearings, dowels = _parts(model)
    col = cols[0]
    masses = col.block_masses
    out = []
    for j in range(col.n_blocks):
        m = masses[j] if j == 0 else min(masses[j], masses[j - 1])
        seg = col.blocks[j].segments[0]
        area = 0.5 * seg.n_sides * seg.r_bottom ** 2 * math.sin(2 * math.pi / seg.n_sides) * seg.aspect
        k = col.joint(j).kn * area
        out.append((2.0 * math.sqrt(m / k), f"joint {j} of the column (kn = {col.joint(j).kn:.3g} Pa/m over "
                    f"{area:.3g} m^2 on a block of {m:.4g} kg)", "a lower joint kn"))
    nb = col.n_blocks
    seen = set()
    for j, _, _, law in dowels:
        jj = j % nb
        m = masses[jj] if jj == 0 else min(masses[jj], masses[jj - 1])
        k = max(law.k_shear, law.k_axial)
        if k > 0 and (law, jj) not in seen:
            seen.add((law, jj))
            out.append((2.0 * math.sqrt(m / k), f"a dowel{' (law ' + law.name + ')' if law.name else ''} in joint {jj} "
                        f"(k_shear = {law.k_shear:.3g} N/m, k_axial = {law.k_axial:.3g} N/m on a block of {m:.4g} kg)",
                        "a softer dowel law (k_shear, k_axial)"))
    for b, beam in enumerate(beams):
        m = beam.density * beam.length * beam.width * beam.height
        k = sum(g.joints.kn * g.kn_factor * g.side ** 2 for g in bearings if g.beam == b)
        out.append((2.0 * math.sqrt(m / k), f"epistyle {b} ({m:.4g} kg, density {beam.density:.4g} kg/m^3, on "
                    f"bearings of {k:.3g} N/m together)", "a heavier epistyle (its density) or softer bearings (the "
                    "epistyle's joints kn)"))
    out.sort(key=lambda t: t[0])
    return out


def describe(model) -> str:
    """The part that sets the model's step, its estimate and what would lengthen it (one clause)."""
    dt, what, fix = part_steps(model)[0]
    return f"the step is set by {what}, whose own limit 2 sqrt(m / k) is {dt:.3g} s: {fix} lengthens it"


def run_steps_warning(model, steps: float, dt: float, duration: float, caller: str) -> str | None:
    """The warning ``caller`` gives for a run of ``steps`` solver steps of ``dt`` s over ``duration`` s
    (record and tail), or None when they are within :data:`MAX_RUN_STEPS`."""
    if not steps > MAX_RUN_STEPS:
        return None
    return (f"{caller}: this run needs about {steps:.3g} solver steps of {dt:.3g} s for {duration:.4g} s of record and "
            f"tail (over {MAX_RUN_STEPS:.0e}; {steps * 3e-6 / 3600:.2g} h at the default column's 3 us per step, a "
            "scene's steps cost more): "
            f"{describe(model)}")
