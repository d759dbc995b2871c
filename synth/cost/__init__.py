"""What a render will cost, known before the work starts, and the budget it must fit.

Every size the engine's work follows from is estimated from the scene and the render
options before the plate's modes, the radiation gains or the bounce series are computed,
so that work beyond the budget is refused before it starts (docs/cli.md, "The cost of a
render, and its budget"):

* **modes** (:mod:`~synth.cost.modal`): the lattice of the plate's wavenumbers, whose area
  term is the asymptotic modal density ``N(omega) = S omega / (4 pi) sqrt(rho h / D)``
  (Cremer, Heckl & Petersson, *Structure-Borne Sound*, 3rd ed., eq. 5.118); the mode
  solver's unknowns and floating-point operations by LAPACK's counts (Golub & Van Loan,
  *Matrix Computations*, 4th ed., 8.3), a cold solve only (the modes are cached on disk).
* **the longest contact and the audio** (:mod:`~synth.cost.contact`): the first impact
  solved alone by the impedance model, later bounces by Hertz' ``tau ~ v^(-1/5)`` law, a
  resting ball's settling; the pulse grid (8 points a period of the highest mode), and
  the audio's length from the bounce series and the slowest mode's ring-down.
* **the radiation stage** (:mod:`~synth.cost.radiation`, a microphone): the points and
  terms of the rule the render takes (:func:`synth.sound.radiation.rules.choose_rule`),
  counted from the rule's own panel builders (:mod:`synth.sound.radiation.work`) in
  rectangle-term equivalents (:func:`rule_weights`, from the rates file shipped with the
  package, so a scene's cut does not depend on the machine); the budget holds the rules
  whose summed work fits, and a scene whose first rule and one refinement do not fit is
  refused.
* **memory** (:class:`MemoryParts`): the largest arrays the render holds at once, sized by
  the quantities the code allocates them by; an upper estimate of the traced peak.

:func:`body_cost` is the same estimate for a live body (:meth:`synth.Engine.add`, checked
by :func:`check_body`), :func:`estimate_render` a render's from its options (``synth info
--cost``, a bank's plan). :class:`Budget` bounds them (``$SYNTH_MAX_MODES``,
``$SYNTH_MAX_PULSE_POINTS``, ``$SYNTH_MAX_MEMORY_BYTES``, ``$SYNTH_MAX_SOLVER_FLOPS``,
``$SYNTH_MAX_RADIATION_WORK``, or the keywords of :func:`synth.render`), with a message
naming what is too big and what to change; a contact longer than ``max_duration`` is
refused whatever the budget. :mod:`~synth.cost.records` holds the estimates' records,
:mod:`~synth.cost.rates` the measured rates, :mod:`~synth.cost.estimates` a render's and a
live body's whole estimate.
"""

from __future__ import annotations

from synth.cost.budget import (
    DEFAULT_MAX_MEMORY_BYTES,
    DEFAULT_MAX_MODES,
    DEFAULT_MAX_PULSE_POINTS,
    DEFAULT_MAX_RADIATION_WORK,
    DEFAULT_MAX_SOLVER_FLOPS,
    ENVIRONMENT,
    Budget,
    modes_excess,
)
from synth.cost.contact import FirstContact, hertz_contact_time
from synth.cost.estimates import RENDER_OPTIONS, body_cost, check_body, estimate, estimate_render
from synth.cost.modal import modal_count, solver_cost
from synth.cost.radiation import radiation_work
from synth.cost.rates import RATES, Rates, rule_weights, time_row, weighted_counts
from synth.cost.records import (
    AUDIO_BYTES_PER_SAMPLE,
    BODY_MEMORY_ADVICE,
    CHECK_SQUARES,
    MODE_VALUES,
    RADIATION_CHUNKS,
    RADIATION_TOL,
    RENDER_MEMORY_ADVICE,
    REST,
    SOLVER_SQUARES,
    BodyCost,
    CostEstimate,
    MemoryParts,
    RadiationWork,
    SolverCost,
)

__all__ = [
    "AUDIO_BYTES_PER_SAMPLE",
    "BODY_MEMORY_ADVICE",
    "BodyCost",
    "Budget",
    "CHECK_SQUARES",
    "CostEstimate",
    "DEFAULT_MAX_MEMORY_BYTES",
    "DEFAULT_MAX_MODES",
    "DEFAULT_MAX_PULSE_POINTS",
    "DEFAULT_MAX_RADIATION_WORK",
    "DEFAULT_MAX_SOLVER_FLOPS",
    "ENVIRONMENT",
    "FirstContact",
    "MODE_VALUES",
    "MemoryParts",
    "RADIATION_CHUNKS",
    "RADIATION_TOL",
    "RATES",
    "RENDER_MEMORY_ADVICE",
    "RENDER_OPTIONS",
    "REST",
    "RadiationWork",
    "Rates",
    "SOLVER_SQUARES",
    "SolverCost",
    "body_cost",
    "check_body",
    "estimate",
    "estimate_render",
    "hertz_contact_time",
    "modal_count",
    "modes_excess",
    "radiation_work",
    "rule_weights",
    "solver_cost",
    "time_row",
    "weighted_counts",
]
