"""What a render will cost, known before the work starts, and the budget it must fit.

Every size the engine's work follows from is estimated from the scene and the render
options, before the plate's modes, the radiation gains or the bounce series are computed:

* **modes**: the plate's modes below the highest rendered frequency, from the lattice of
  its wavenumbers (:func:`modal_count`), whose area term is the asymptotic modal density
  ``N(omega) = S omega / (4 pi) sqrt(rho h / D)`` (Cremer, Heckl & Petersson,
  *Structure-Borne Sound*, 3rd ed., eq. 5.118; ``S`` the area, ``rho h`` the surface
  density, ``D`` the bending stiffness) and whose edge term counts a strip's beam modes.
* **the longest contact**: the first impact's contact, solved alone by the impedance model
  (the ball on the infinite plate, the plate's modes not needed: milliseconds), and the
  longest a later bounce can have by Hertz' ``tau ~ v^(-1/5)`` law down to the speed where
  the flight ``2 v / g`` is as short as the contact (where the series ends). A ball that
  comes to rest (it does not separate) has a contact as long as its settling: the
  impedance model's own, or for the modal plate up to
  ``SETTLE_FACTOR`` times the impedance model's contact time without gravity.
* **the pulse grid**: the points of the longest force pulse's uniform grid, 8 a period of
  the highest mode (see :mod:`synth.sound.modal_bank.pulse`).
* **the mode solver**: the unknowns of its Rayleigh-Ritz problems (the solver's own index
  sets, :func:`synth.physics.modes.solver_sizes`) and their floating-point operations by
  LAPACK's counts (Golub & Van Loan, *Matrix Computations*, 4th ed., 8.3: Cholesky
  ``n^3 / 3``, its inverse ``2 n^3 / 3``, the symmetric eigen-solution ``4 n^3 / 3``
  for the values and ``9 n^3`` with the vectors); a cold solve only (the modes are
  cached on disk).
* **the radiation stage** (a microphone): the Rayleigh sums of the rectangle rule
  (:func:`synth.sound.radiation.rayleigh_gains`) on the panels and orders of its first
  rule (:func:`synth.sound.radiation.rectangle.first_rule`, at the wavenumber of the
  highest rendered frequency, before any mode is solved) and of every refinement the
  convergence test may ask for (``MAX_RULES`` rules, ``REFINE`` times the points per axis
  each): its *evaluations* (points times modes) and *work* (evaluations times one plus
  the terms each shape value costs, :func:`synth.physics.modes.shape_terms`: the Ritz basis'
  degrees along one axis, 1 for the closed-form modes). An upper bound: a rule that
  converges at the first refinement takes ``(1 + REFINE^2) / sum_l REFINE^(2 l)`` of it.
  The budget (``max_radiation_work``) holds the rules whose summed work fits: a render
  stops refining there (its gains then carry the convergence warning, with the error
  each mode reached), and a scene whose first rule and one refinement (the fewest the
  convergence test needs) do not fit is refused.
  The rule counted is the one the render takes
  (:func:`synth.sound.radiation.rules.choose_rule`, the cheapest that holds the error
  bound): the other rules' radii, angular points or radial grids are counted from their
  own builders in the same way (:mod:`synth.sound.radiation.work`), and the budget holds
  their rules alike.
  The rules' terms cost different times (a boundary-rule term, Bessel values and
  cumulative integrals, takes many rectangle-rule terms' time, a multiply-add in a matrix
  product), so each rule's work is counted in *rectangle-term equivalents*: its terms
  times the rectangle rule's rate over its own (:func:`rule_weights`, the terms per second
  of :data:`RATES`), and the budget is the same time whichever rule a scene takes. The
  weights are read from the rates file shipped with the package, a constant file (not
  measured where the render runs), so a scene's cut, and the bytes of its render, do not
  depend on the machine it runs on.
* **the audio**: the preroll, the bounce series (the fall, the flights of the first
  impact's restitution summed as a geometric series, at most ``max_duration``) and the
  slowest mode's ring-down to the floor (``floor_db``; the lowest mode, at most
  ``max_tail``), at the sample rate.
* **memory**: the largest arrays the render holds at once, sized by the same quantities
  the code allocates them by (:class:`MemoryParts`): the audio (its float64 buffer, the
  level's scaled copy and the float32 result), the impacts' modal amplitudes (impacts of
  a constant-restitution series times modes, complex), the transform's workspace
  (:data:`~synth.sound.modal_bank.transform_kernels.WORK_ROWS` complex rows per mode) and
  the model's per-mode vectors (:data:`MODE_VALUES`),
  the pulse grid, the cold mode solver's dense matrices (:data:`SOLVER_SQUARES`) and its
  eigenvectors kept as the modes' shapes, and for a microphone the chunks of shape
  values the Rayleigh sums hold (:data:`RADIATION_CHUNKS` chunks of at most
  ``CHUNK_BYTES``, of the rectangle rule's points, :func:`synth.sound.radiation.rectangle_points`).
  An upper estimate of the traced peak (tests/test_cost.py bounds it within a factor),
  without the interpreter's fixed overhead.

:func:`body_cost` is the same estimate for a live body (:meth:`synth.Engine.add`,
which :func:`check_body` checks), :func:`estimate_render` a render's from its options
(``synth info --cost``, a bank's plan).

:class:`Budget` bounds them (``$SYNTH_MAX_MODES``, ``$SYNTH_MAX_PULSE_POINTS``,
``$SYNTH_MAX_MEMORY_BYTES``, ``$SYNTH_MAX_SOLVER_FLOPS``, ``$SYNTH_MAX_RADIATION_WORK``,
or the keywords of :func:`synth.render`): work beyond it is
refused before it starts, with a message naming what is too big and what to change. A
contact longer than ``max_duration`` is refused whatever the budget (the render could not
hold the pulse). ``synth info --cost`` prints the estimate.

Modules: :mod:`~synth.cost.budget` (the budget), :mod:`~synth.cost.modal` (modes and the
mode solver), :mod:`~synth.cost.contact` (the longest contact, the audio's length),
:mod:`~synth.cost.radiation` (the radiation rules' work), :mod:`~synth.cost.records` (the
estimates' records and what of them exceeds a budget), :mod:`~synth.cost.rates` (measured
rates) and :mod:`~synth.cost.estimates` (a render's and a live body's whole estimate).
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
from synth.cost.contact import TAU_HERTZ, FirstContact, hertz_contact_time
from synth.cost.estimates import RENDER_OPTIONS, body_cost, check_body, estimate, estimate_render
from synth.cost.modal import check_modes, modal_count, solver_cost
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
    "TAU_HERTZ",
    "body_cost",
    "check_body",
    "check_modes",
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
