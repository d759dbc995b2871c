"""What a render will cost, estimated before any work, and the budget it must fit (docs/cli.md,
"The cost of a render, and its budget"), so that work beyond it is refused up front.

Sources: modal density, Cremer, Heckl & Petersson, *Structure-Borne Sound*, 3rd ed., eq. 5.118;
the solver's flops, Golub & Van Loan, *Matrix Computations*, 4th ed., 8.3.
"""

from synth.lazy import lazy_names

#: Where each public name lives, imported on first use (PEP 562).
_LAZY = {
    name: module
    for module, names in {
        "estimates": "RENDER_OPTIONS FirstContact body_cost check_body estimate estimate_render "
        "hertz_contact_time modal_count radiation_work solver_cost",
        "records": "AUDIO_BYTES_PER_SAMPLE BODY_MEMORY_ADVICE CHECK_SQUARES "
        "DEFAULT_MAX_MEMORY_BYTES DEFAULT_MAX_MODES DEFAULT_MAX_PULSE_POINTS "
        "DEFAULT_MAX_RADIATION_WORK DEFAULT_MAX_SOLVER_FLOPS ENVIRONMENT MODE_VALUES "
        "RADIATION_CHUNKS RADIATION_TOL RATES RENDER_MEMORY_ADVICE REST SOLVER_SQUARES BodyCost "
        "Budget CostEstimate MemoryParts RadiationWork Rates SolverCost modes_excess time_row",
    }.items()
    for name in names.split()
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
