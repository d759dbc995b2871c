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
  sets, :func:`synth.sound.modes.solver_sizes`) and their floating-point operations by
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
  the terms each shape value costs, :func:`synth.sound.modes.shape_terms`: the Ritz basis'
  degrees along one axis, 1 for the closed-form modes). An upper bound: a rule that
  converges at the first refinement takes ``(1 + REFINE^2) / sum_l REFINE^(2 l)`` of it.
  The budget (``max_radiation_work``) holds the rules whose summed work fits: a render
  stops refining there (its gains then carry the convergence warning, with the error
  each mode reached), and a scene whose first rule and one refinement (the fewest the
  convergence test needs) do not fit is refused.
  The plates whose rectangle-rule work passes the engine's switch-over to the polar,
  summed or boundary rules (:mod:`synth.sound.radiation`; also a cut of the rectangle rule
  that switches edge effect modes to the boundary rule) take those instead, whose cost
  grows with the plate's perimeter rather than its area: their radii, angular points or
  radial grids are counted from their own builders in the same way
  (:mod:`synth.sound.radiation.work`), and the budget holds their rules alike.
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
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth import checks
from synth.errors import ParameterError

#: Default budget: modes of the plate below the highest rendered frequency (each costs
#: its shape, its radiation gain and its share of every impact's transform).
DEFAULT_MAX_MODES = 100_000
#: Default budget: points of the longest force pulse's grid (``4 omega_max tau / pi``:
#: about 10 s of contact at 24 kHz).
DEFAULT_MAX_PULSE_POINTS = 2_000_000
#: Default budget: memory of the arrays the estimate sizes, bytes.
DEFAULT_MAX_MEMORY_BYTES = 2 * 1024**3
#: Default budget: floating-point operations of a cold mode solve (the budget of time in
#: machine-independent units: a dense symmetric eigensolver runs at a few GFLOP/s on one
#: core, so minutes; about four times the costliest shipped preset's solve).
DEFAULT_MAX_SOLVER_FLOPS = 10**12
#: Default budget: rectangle-term equivalents of the radiation stage's sums
#: (:class:`RadiationWork`: each rule's shape terms and Rayleigh terms, each a multiply-add
#: or an exponential, weighted by :func:`rule_weights` to the rectangle rule's time). Every
#: shipped preset's first four rules fit at 48 kHz (tests/test_cost.py).
DEFAULT_MAX_RADIATION_WORK = 2 * 10**11

#: Hertz' contact time on a rigid plate, ``tau = TAU_HERTZ delta_max / v`` with
#: ``delta_max = (15 m v^2 / (16 E* sqrt(R)))^(2/5)`` (Johnson, Contact Mechanics, 11.4).
TAU_HERTZ = 2.9433

#: The environment variables of :meth:`Budget.from_environment`, with their defaults.
ENVIRONMENT = {
    "SYNTH_MAX_MODES": DEFAULT_MAX_MODES,
    "SYNTH_MAX_PULSE_POINTS": DEFAULT_MAX_PULSE_POINTS,
    "SYNTH_MAX_MEMORY_BYTES": DEFAULT_MAX_MEMORY_BYTES,
    "SYNTH_MAX_SOLVER_FLOPS": DEFAULT_MAX_SOLVER_FLOPS,
    "SYNTH_MAX_RADIATION_WORK": DEFAULT_MAX_RADIATION_WORK,
}


@dataclass(frozen=True)
class Budget:
    """The most work a render may take on: ``max_modes`` (plate modes),
    ``max_pulse_points`` (points of one force pulse's grid), ``max_memory_bytes`` (bytes
    of the arrays :class:`CostEstimate` sizes) and ``max_solver_flops`` (floating-point
    operations of a cold mode solve: its time, in units that do not depend on the
    machine) and ``max_radiation_work`` (rectangle-term equivalents of a microphone's
    Rayleigh sums, :class:`RadiationWork`: the radiation stage's time in the same way,
    whichever rule it takes)."""

    max_modes: int = DEFAULT_MAX_MODES
    max_pulse_points: int = DEFAULT_MAX_PULSE_POINTS
    max_memory_bytes: int = DEFAULT_MAX_MEMORY_BYTES
    max_solver_flops: int = DEFAULT_MAX_SOLVER_FLOPS
    max_radiation_work: int = DEFAULT_MAX_RADIATION_WORK

    def __post_init__(self):
        names = (
            "max_modes", "max_pulse_points", "max_memory_bytes", "max_solver_flops",
            "max_radiation_work",
        )  # fmt: skip
        for name in names:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ParameterError(f"budget.{name}={value!r} must be an integer >= 1")

    @classmethod
    def from_environment(cls) -> Budget:
        """The budget of ``$SYNTH_MAX_MODES``, ``$SYNTH_MAX_PULSE_POINTS``,
        ``$SYNTH_MAX_MEMORY_BYTES``, ``$SYNTH_MAX_SOLVER_FLOPS`` and
        ``$SYNTH_MAX_RADIATION_WORK`` (each defaulting to this module's constant)."""
        values = [
            checks.environment_integer(name, default, 1) for name, default in ENVIRONMENT.items()
        ]
        return cls(*values)


#: Bytes per audio sample held at once: the synthesis' float64 buffer, the scaled copy
#: the level makes (:func:`synth.io.audio.normalize`) and the float32 :class:`Render`.
AUDIO_BYTES_PER_SAMPLE = 8 + 8 + 4

#: Complex values per mode that the modal model and the synthesis hold besides the
#: transform's workspace: the poles, their one-sample step and the response
#: coefficients (:func:`synth.sound.modal_bank.coefficients.bank_coefficients`, each also
#: as real and imaginary parts), the excitation and output gains, the modes'
#: frequencies, decay rates and masses, the ring bank's state and masks.
MODE_VALUES = 20

#: Dense n x n float64 arrays alive in a Rayleigh-Ritz solve with vectors
#: (:func:`synth.sound.modes.basis.solve_class`): the stiffness matrix, the Fortran-ordered
#: copy LAPACK's dpotrf/dpotri factor and invert in place, the eigenvectors, and dsyevd's
#: workspace of ``1 + 6 n + 2 n^2`` doubles (LAPACK Users' Guide, 3rd ed., DSYEVD).
SOLVER_SQUARES = 5
#: The same for the check basis, eigenvalues only: the matrix and its copy (the
#: workspace is ``1 + 2 n``).
CHECK_SQUARES = 2

#: Chunks of shape values (points x modes, float64, at most ``CHUNK_BYTES`` each, see
#: :mod:`synth.sound.radiation.common`) alive at once while a microphone's gains are
#: summed: the chunk the worker threads add up and the next one being evaluated
#: (the pipeline of :func:`synth.sound.radiation.rectangle.apply_rule`), and the shape
#: evaluation's temporaries of the same size (the two factor tables taken at the modes'
#: indices and their product, :mod:`synth.sound.modes.closed_form`).
RADIATION_CHUNKS = 5

#: Tolerance of the microphone's gains (:func:`synth.sound.radiation.plate_gains`'
#: default, which a render uses).
RADIATION_TOL = 1e-6


@dataclass(frozen=True)
class MemoryParts:
    """The bytes of the largest arrays a render holds (see the module docstring):
    ``audio``, ``impacts`` (modal amplitudes and the transform's workspace), ``pulse``,
    ``solver`` (the cold mode solve's matrices), ``shapes`` (its eigenvectors kept),
    ``radiation`` (the Rayleigh sums' chunks; 0 for an accelerometer)."""

    audio: int
    impacts: int
    pulse: int
    solver: int
    shapes: int
    radiation: int

    @property
    def total(self) -> int:
        """Bytes: the stages that run one after the other (the solve, the radiation
        sums, the synthesis) counted at their largest, plus what stays held."""
        stages = max(self.solver, self.radiation, self.audio + self.impacts + self.pulse)
        return stages + self.shapes


@dataclass(frozen=True)
class RadiationWork:
    """The radiation stage's work for a microphone (see the module docstring and
    :mod:`synth.sound.radiation.work`).

    Attributes
    ----------
    rule : str
        The rule the engine takes: "rectangle", "polar", "summed" or "boundary" (the
        edge effect modes'; the Ritz modes below them take the rectangle rule), "none"
        (an accelerometer: no radiation).
    first_points : int
        Points of the first rule (in ``unit``).
    rules : int
        Rules the refinement may take within the budget (at most ``MAX_RULES``).
    points : int
        Points of those rules, summed.
    max_points : int or None
        Points of the last of them when the budget stops the refinement before
        ``MAX_RULES`` (the ``max_points`` a render passes to the sums), else None.
    rule_points : tuple of int
        Points of each of the ``MAX_RULES`` rules.
    shape_terms : int
        Terms one shape value costs per mode (:func:`synth.sound.modes.shape_terms`).
    evaluations : float
        ``points`` times the modes.
    rule_work : tuple of float
        Work of each of the ``MAX_RULES`` rules, rectangle-term equivalents (its terms
        times the rule's weight, :func:`rule_weights`).
    fixed_work : float
        Work outside the refinement (the polar rules' in-phase bounds, the boundary
        rule's Ritz modes, which take the rectangle rule), rectangle-term equivalents.
    unit : str
        What the points count: the rectangle rule's "points", the polar rules' "angular
        points", the boundary rule's "radial nodes".
    """

    rule: str = "none"
    first_points: int = 0
    points: int = 0
    shape_terms: int = 0
    evaluations: float = 0.0
    rules: int = 0
    max_points: int | None = None
    rule_points: tuple = ()
    rule_work: tuple = ()
    fixed_work: float = 0.0
    unit: str = "points"

    def work_of(self, rules: int) -> float:
        """Rectangle-term equivalents of the first ``rules`` rules (and of the work outside
        the refinement)."""
        if self.rule == "none":
            return 0.0
        return self.fixed_work + float(sum(self.rule_work[:rules]))

    @property
    def work(self) -> float:
        """Rectangle-term equivalents of the rules the budget holds."""
        return self.work_of(self.rules)

    def excess(self, modes: int, budget: Budget) -> str | None:
        """Why the first rule and one refinement (the fewest the convergence test needs)
        are beyond ``budget`` and what to change, or None."""
        if self.rule == "none" or self.rules >= 2:
            return None
        closed = (
            "" if self.rule == "polar" else ", or a simply supported plate (closed-form shapes)"
        )
        return (
            f"the microphone's Rayleigh sums need about {self.work_of(2):.3g} rectangle-term "
            f"equivalents for their "
            f"first rule and one refinement ({self.rule} rule: {sum(self.rule_points[:2])} "
            f"{self.unit} for {modes} modes), more than the budget of "
            f"{budget.max_radiation_work:.3g} (SYNTH_MAX_RADIATION_WORK); lower max_frequency "
            f"or the samplerate, use an accelerometer listener{closed}"
        )

    def row(self) -> str:
        """One line for ``synth info --cost``."""
        from synth.sound.radiation.common import MAX_RULES

        if self.rule == "none":
            return "none (accelerometer)"
        cut = "" if self.max_points is None else f" (the budget's; of {MAX_RULES})"
        shape = f", {self.shape_terms} shape terms" if self.rule == "rectangle" else ""
        return (
            f"{self.rule} rule, {self.first_points} {self.unit}, {self.points} in up to "
            f"{self.rules} rules{cut}{shape}, {self.work:.3g} rectangle-term equivalents"
        )


@dataclass(frozen=True)
class CostEstimate:
    """The sizes of one render's work (see the module docstring for each estimate).

    Attributes
    ----------
    max_frequency : float
        Highest rendered frequency, Hz.
    modes : int
        Plate modes below it (the wavenumber lattice, :func:`modal_count`).
    impact_speed : float
        First impact's speed, m/s.
    hertz_contact : float
        Hertz' contact time of the first impact on a rigid plate, s (a hollow ball's: its
        shell law's at small deflection, :func:`hertz_contact_time`).
    longest_contact : float
        Longest contact the series can have, s.
    settles : bool
        The first impact does not separate (the ball comes to rest on the plate).
    pulse_points : int
        Points of the longest force pulse's grid.
    audio_seconds : float
        Audio length, s (estimated: see the module docstring).
    audio_samples : int
        Its samples.
    memory_bytes : int
        Bytes of the largest arrays held at once (:attr:`MemoryParts.total`).
    max_duration : float
        The render's longest bounce series, s.
    solver_unknowns : int
        Unknowns of the mode solver's largest problem (0: closed-form modes).
    solver_flops : float
        Floating-point operations of a cold mode solve.
    """

    max_frequency: float
    modes: int
    impact_speed: float
    hertz_contact: float
    longest_contact: float
    settles: bool
    pulse_points: int
    audio_seconds: float
    audio_samples: int
    memory_bytes: int
    max_duration: float
    solver_unknowns: int = 0
    solver_flops: float = 0.0
    impacts: int = 1
    memory: MemoryParts | None = None
    radiation: RadiationWork = RadiationWork()
    #: What the memory message calls the owner of the arrays.
    subject = "render"

    def excess(self, budget: Budget) -> list[str]:
        """What is too big for ``budget`` or for the render itself, each with what to
        change (empty: the render fits)."""
        out = []
        if self.longest_contact > self.max_duration:
            out.append(
                f"the ball {'comes to rest on' if self.settles else 'stays on'} the plate: "
                f"its contact lasts about {self.longest_contact:.4g} s, longer than "
                f"max_duration={self.max_duration:g} s (the render could not hold its force "
                f"pulse); lower ball.mass or use a stiffer or heavier plate"
            )
        too_many = modes_excess(self.modes, self.max_frequency, budget)
        if too_many:
            out.append(too_many)
        if self.pulse_points > budget.max_pulse_points:
            out.append(
                f"the longest force pulse ({self.longest_contact:.4g} s) needs "
                f"{self.pulse_points} grid points up to {self.max_frequency:.6g} Hz, more than "
                f"the budget of {budget.max_pulse_points} (SYNTH_MAX_PULSE_POINTS); lower "
                f"max_frequency or ball.mass"
            )
        out += _stage_excess(self, budget, RENDER_MEMORY_ADVICE)
        return out

    def check(self, budget: Budget) -> None:
        """Raise ``ParameterError`` naming everything :meth:`excess` finds."""
        too_big = self.excess(budget)
        if too_big:
            raise ParameterError("refused before any work: " + "; ".join(too_big))

    def rows(self) -> list[tuple[str, str]]:
        """(name, value with unit) rows, for ``synth info --cost``."""
        return [
            ("highest frequency", f"{self.max_frequency:.6g} Hz"),
            ("plate modes", f"{self.modes}"),
            ("first impact speed", f"{self.impact_speed:.4g} m/s"),
            ("contact on a rigid plate", f"{self.hertz_contact:.4g} s"),
            ("longest contact", f"{self.longest_contact:.4g} s" + (REST if self.settles else "")),
            ("pulse grid", f"{self.pulse_points} points"),
            (
                "mode solver (cold)",
                f"{self.solver_unknowns} unknowns, {self.solver_flops:.3g} flop",
            ),
            ("radiation (microphone)", self.radiation.row()),
            ("audio", f"{self.audio_seconds:.4g} s, {self.audio_samples} samples"),
            ("impacts (estimated)", f"{self.impacts}"),
            ("memory (largest arrays)", f"{self.memory_bytes / 2**20:.1f} MiB"),
        ] + ([] if self.memory is None else [
            (f"  {name}", f"{getattr(self.memory, name) / 2**20:.1f} MiB")
            for name in ("audio", "impacts", "pulse", "solver", "shapes", "radiation")
        ]) + [time_row(self, Rates.load())]  # fmt: skip


#: The rates of the estimate's work (:class:`Rates`), measured by ``synth bench cost
#: --record`` on the machine named in it and shipped with the package: the seconds of
#: ``synth info --cost`` and the radiation rules' weights (:func:`rule_weights`).
RATES = Path(__file__).with_name("cost_rates.json")


@dataclass(frozen=True)
class Rates:
    """Measured rates of the estimate's work: ``solver`` (floating-point operations per
    second of a cold mode solve), ``radiation`` (terms per second of each rule, by name),
    and ``measured`` (the command, date, machine and load that measured them)."""

    solver: float
    radiation: dict
    measured: str

    @classmethod
    def load(cls, path: Path = RATES) -> Rates | None:
        """The rates in ``path`` (default :data:`RATES`), or None if none were measured."""
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            return None
        return cls(
            float(data["solver_flops_per_second"]),
            {k: float(v) for k, v in data["radiation_terms_per_second"].items()},
            str(data["measured"]),
        )

    def seconds(self, cost) -> tuple[float, float, float]:
        """Estimated wall seconds of the cold mode solve and of the radiation stage of
        ``cost`` (a :class:`CostEstimate` or :class:`BodyCost`), their work over these
        rates (the synthesis is not included): the solve, the radiation's first rule and
        one refinement (the fewest the convergence test takes) and every rule the budget
        holds (the most)."""
        r = cost.radiation
        if r.rule == "none":
            return cost.solver_flops / self.solver, 0.0, 0.0
        rate = self.radiation["rectangle"]  # the work is in rectangle-term equivalents
        fewest = r.work_of(min(2, r.rules))
        return cost.solver_flops / self.solver, fewest / rate, r.work / rate


@functools.cache
def rule_weights() -> dict[str, float]:
    """Rectangle-term equivalents of one term of each radiation rule, by name: the
    rectangle rule's terms per second over the rule's, in the rates file shipped with
    the package (:data:`RATES`). A constant of the package, read from that file and not
    measured where it runs, so the budget's cut of a scene's refinement (and the bytes
    of its render) do not depend on the machine; recording new rates (``synth bench cost
    --record``) changes the package's weights. The rectangle rule's weight is 1."""
    rates = Rates.load()
    if rates is None:
        raise FileNotFoundError(
            f"{RATES} is missing: the radiation budget weighs each rule's terms by its "
            f"rates (synth bench cost --record)"
        )
    rectangle = rates.radiation["rectangle"]
    return {rule: rectangle / rate for rule, rate in rates.radiation.items()}


def weighted_counts(counts):
    """``counts`` (:class:`synth.sound.radiation.work.RuleWork`, terms) in rectangle-term
    equivalents (:func:`rule_weights`): each rule's work times its rule's weight, and the
    work outside the refinement too, except the boundary rule's, which is the rectangle
    rule of its Ritz modes (weight 1)."""
    weight = rule_weights()[counts.rule]
    fixed_weight = 1.0 if counts.rule == "boundary" else weight
    return dataclasses.replace(
        counts,
        work=tuple(weight * float(w) for w in counts.work),
        fixed=fixed_weight * float(counts.fixed),
    )


def time_row(cost, rates: Rates | None) -> tuple[str, str]:
    """The ``synth info --cost`` row of the estimated time of ``cost``'s mode solve and
    radiation stage (:class:`Rates`)."""
    name = "time, cold (estimated)"
    if rates is None:
        return name, "rates not measured (synth bench cost --record)"
    solver, fewest, most = rates.seconds(cost)
    return name, (
        f"{solver + fewest:.3g} to {solver + most:.3g} s: mode solver {solver:.3g} s, "
        f"radiation {fewest:.3g} s (two rules) to {most:.3g} s ({cost.radiation.rules} rules; "
        f"without the synthesis; rates of {rates.measured})"
    )


#: What to change when a render's arrays are beyond the memory budget.
RENDER_MEMORY_ADVICE = "lower max_tail, max_duration, max_frequency or the samplerate"
#: The same for a live body's.
BODY_MEMORY_ADVICE = "lower the engine's max_frequency or samplerate, or max_voices"


def _stage_excess(cost, budget: Budget, memory_advice: str) -> list[str]:
    """What of the mode solver, the radiation stage and the memory of ``cost`` (a
    :class:`CostEstimate` or a :class:`BodyCost`) is beyond ``budget``, each with what
    to change: one message for a render and a live body."""
    out = []
    if cost.solver_flops > budget.max_solver_flops:
        out.append(
            f"a cold solve of the plate's modes takes about {cost.solver_flops:.3g} "
            f"floating-point operations ({cost.solver_unknowns} unknowns), more than the "
            f"budget of {budget.max_solver_flops:.3g} (SYNTH_MAX_SOLVER_FLOPS); lower "
            f"max_frequency or the samplerate, or use a simply supported plate (closed-form "
            f"modes)"
        )
    too_much = cost.radiation.excess(cost.modes, budget)
    if too_much:
        out.append(too_much)
    if cost.memory_bytes > budget.max_memory_bytes:
        out.append(
            f"the {cost.subject}'s largest arrays take about {cost.memory_bytes / 2**20:.0f} MiB"
            f"{_largest_part(cost.memory)}, more than the budget of "
            f"{budget.max_memory_bytes / 2**20:.0f} MiB (SYNTH_MAX_MEMORY_BYTES); "
            f"{memory_advice}"
        )
    return out


def _largest_part(memory) -> str:
    """`` (most of it the <part>: N MiB)`` for the largest part of ``memory``."""
    if memory is None:
        return ""
    parts = vars(memory)
    name = max(parts, key=parts.get)
    return f" (most of it the {name}: {parts[name] / 2**20:.0f} MiB)"


REST = " (the ball comes to rest)"


def modes_excess(modes: int, max_frequency: float, budget: Budget) -> str | None:
    """Why ``modes`` plate modes below ``max_frequency`` (Hz) are beyond ``budget`` and what
    to change, or None if they fit."""
    if modes <= budget.max_modes:
        return None
    f_fit = max_frequency * budget.max_modes / modes
    return (
        f"the plate has about {modes} modes below {max_frequency:.6g} Hz, more than the "
        f"budget of {budget.max_modes} (SYNTH_MAX_MODES); lower max_frequency to "
        f"{f_fit:.4g} Hz or the samplerate, or use a smaller or thicker plate"
    )


def check_modes(plate, max_frequency: float, budget: Budget | None = None) -> int:
    """The modes of ``plate`` below ``max_frequency`` (Hz, :func:`modal_count`), counted
    before any is solved; ``ParameterError`` if they are beyond ``budget`` (default: the
    environment's, :meth:`Budget.from_environment`): the mode count alone (a render is
    checked by :meth:`CostEstimate.check`, a live body by :func:`check_body`, a bank's rows
    by :func:`estimate_render`)."""
    budget = Budget.from_environment() if budget is None else budget
    modes = modal_count(plate, max_frequency)
    too_many = modes_excess(modes, max_frequency, budget)
    if too_many:
        raise ParameterError("refused before any work: " + too_many)
    return modes


def modal_count(plate, max_frequency: float) -> int:
    """Modes of ``plate`` below ``max_frequency`` (Hz): the wavenumber lattice of the
    rectangle, ``(m pi / a)^2 + (n pi / b)^2 <= k^2`` with ``k^4 = omega^2 rho h / D``,
    counted exactly (``m, n >= 1`` for simply supported edges, where it is the exact count).
    Its area term is the asymptotic modal density ``S omega / (4 pi) sqrt(rho h / D)``
    (Cremer, Heckl & Petersson, eq. 5.118); the lattice adds the edges' share, which
    dominates for a strip (a beam's ``k a / pi`` modes where the area term counts few).
    Clamped edges are counted as simply supported (their wavenumbers lie half a step
    higher). Free edges: :func:`_free_modal_count`."""
    omega = 2.0 * math.pi * max_frequency
    k = math.sqrt(omega * math.sqrt(plate.surface_density / plate.flexural_rigidity))  # rad/m
    if plate.boundary == "free":
        return _free_modal_count(plate, k)
    kx, ky = k * plate.length / math.pi, k * plate.width / math.pi  # lattice radii
    n = np.arange(1, int(math.floor(ky)) + 1, dtype=float)
    rows = np.floor(kx * np.sqrt(np.maximum(1.0 - (n / ky) ** 2, 0.0)))
    return int(np.sum(np.maximum(rows, 0.0)))


def _free_modal_count(plate, k: float) -> int:
    """Modes of a free ``plate`` whose bending wavenumber ``k`` (rad/m) is the band's top.

    Along each side the free beam's functions, as in Warburton's approximation of the
    free plate's modes by their products (Warburton, "The vibration of rectangular
    plates", Proc. Inst. Mech. Eng. 168, 371 (1954)): a uniform one, a rigid rotation, and
    the elastic ones of ``cos(q L) cosh(q L) = 1``, ``q_j = (j - 1/2) pi / L`` for ``j >=
    2`` to within ``1e-3`` relative (Blevins, "Formulas for Natural Frequency and Mode
    Shape", table of single-span beams). Two families:

    * bending: products of a uniform or elastic function along each side, counted on the
      lattice ``q_x^2 + q_y^2 <= k^2``;
    * twisting: the rotation across one side times a function ``cos(m pi x / a)`` along the
      other (``m >= 0``), ``w = y theta(x)``. Kirchhoff's energy of that shape on a strip of
      width ``b`` (Timoshenko & Woinowsky-Krieger, "Theory of Plates and Shells", the
      bending energy's twist term ``2 (1 - nu) w_xy^2``) is that of a bar in torsion, stiffness
      ``G J = 2 (1 - nu) D b = G b h^3 / 3`` (Saint-Venant's thin strip), plus the bending
      of the cross lines, ``D b^3 / 12``, over the polar inertia ``rho h b^3 / 12``:
      ``omega^2 = (D / rho h) (g q^2 + q^4)``, ``g = 24 (1 - nu) / b^2``, so ``q <= q_T``,
      ``q_T^2 = (sqrt(g^2 + 4 k^4) - g) / 2``. On a strip (``k b < pi``) these are the
      torsional modes, which no product of bending wavenumbers counts; on a wide plate
      ``q_T`` nears ``k`` and they are the lattice's first row. The shape ``w = x y`` is
      both families' first elastic mode: counted once.
    """
    a, b = plate.length, plate.width
    nu = plate.material.poisson
    qx, qy = _free_beam_wavenumbers(k, a), _free_beam_wavenumbers(k, b)
    reach = np.sqrt(np.maximum(k * k - qy * qy, 0.0))
    bending = int(np.sum(np.searchsorted(qx, reach, side="right")))
    twist_x = _twisting_count(k, a, 24.0 * (1.0 - nu) / (b * b))
    twist_y = _twisting_count(k, b, 24.0 * (1.0 - nu) / (a * a))
    return bending + twist_x + twist_y - (1 if twist_x >= 2 and twist_y >= 2 else 0)


def _free_beam_wavenumbers(k: float, length: float) -> np.ndarray:
    """The free beam's wavenumbers up to ``k`` (rad/m) on ``length`` m, rigid rotation
    left out (:func:`_free_modal_count`): 0, then ``(j - 1/2) pi / length``, ``j >= 2``."""
    j = np.arange(2, int(k * length / math.pi + 0.5) + 1, dtype=float)
    return np.concatenate(([0.0], (j - 0.5) * math.pi / length))


def _twisting_count(k: float, length: float, g: float) -> int:
    """Twisting modes ``q = m pi / length <= q_T`` (``m >= 0``) of :func:`_free_modal_count`,
    ``g`` (1/m^2) the torsional term of their dispersion."""
    q_t = math.sqrt(0.5 * (math.sqrt(g * g + 4.0 * k**4) - g))
    return int(math.floor(q_t * length / math.pi)) + 1


def hertz_contact_time(ball, plate, speed: float) -> float:
    """Hertz' contact time (s) of ``ball`` on a rigid flat of ``plate``'s material at
    ``speed`` (m/s): ``2.9433 (15 m v^2 / (16 E* sqrt(R)))^(2/5) / v``. For a hollow ball
    (:class:`~synth.physics.scene.HollowBall`), the thin-shell law's at small deflection,
    where it is linear: the half period ``pi sqrt(m / k0)`` (docs/physics.md, "Hollow
    balls"), at any speed."""
    from synth.physics.contact_law import effective_modulus, shell_law
    from synth.physics.scene import HollowBall

    if isinstance(ball, HollowBall):
        return math.pi * math.sqrt(ball.mass / shell_law(ball).stiffness)

    e_star = effective_modulus(ball, plate)
    depth = (15.0 * ball.mass * speed**2 / (16.0 * e_star * math.sqrt(ball.radius))) ** 0.4
    return TAU_HERTZ * depth / speed


def _series_longest(first_contact: float, speed: float, gravity: float) -> float:
    """The longest contact of a bouncing series whose first contact at ``speed`` (m/s)
    lasts ``first_contact`` (s): ``tau ~ v^(-1/5)`` (Hertz) down to the slowest impact,
    where the series ends: the flight ``2 v / g`` as short as the contact, or the kinetic
    energy ``floor_db`` below the first impact's (:func:`simulate_bounces`' rules), s."""

    slowest = _slowest_speed(first_contact, speed, gravity)
    return first_contact * max(1.0, (speed / slowest) ** 0.2)


def _slowest_speed(first_contact: float, speed: float, gravity: float) -> float:
    """The slowest impact of the series of :func:`_series_longest`, m/s."""
    from synth.physics.bounces import DEFAULT_FLOOR_DB

    by_flight = (gravity * first_contact * speed**0.2 / 2.0) ** (5.0 / 6.0)
    by_energy = speed * 10.0 ** (DEFAULT_FLOOR_DB / 20.0)
    return max(by_flight, by_energy)


def _impact_count(first: FirstContact, speed: float, gravity: float, max_duration: float) -> int:
    """Impacts of the series: speeds ``v e^n`` of the first impact's restitution ``e``
    down to the slowest (:func:`_slowest_speed`), or, for ``e`` near 1, as many as the
    flights ``2 v / g`` fit in ``max_duration``; at most the bounce simulation's
    ``max_impacts``."""
    from synth.physics.bounces import DEFAULT_MAX_IMPACTS as most

    if first.settled:
        return 1
    e = first.restitution
    slowest = _slowest_speed(first.contact_time, speed, gravity)
    by_speed = math.log(slowest / speed) / math.log(e) if 0.0 < e < 1.0 else math.inf
    by_time = max_duration * gravity / (2.0 * speed * max(e, 1e-300))
    return int(min(most, 1 + math.ceil(min(by_speed, max(by_time, 1.0)))))


@dataclass(frozen=True)
class FirstContact:
    """The first impact by the impedance model: ``contact_time`` (s, to separation: the
    span the renderer integrates), ``settled`` (the ball comes to rest), ``restitution``."""

    contact_time: float
    settled: bool
    restitution: float


def _first_contact(scene) -> FirstContact:
    """The first impact by the impedance model; for the modal plate, a ball that comes to
    rest gets the modal contact's longest (``SETTLE_FACTOR`` impedance contact times)."""
    from synth.physics.contact import ContactSolver
    from synth.physics.modal_contact.contact import SETTLE_FACTOR, impedance_contact_time

    c = scene.contact
    options = c.options()
    solver = ContactSolver.for_pair(
        scene.ball, scene.plate, gravity=scene.gravity, law=c.law, rtol=c.rtol, **options
    )
    speed = math.sqrt(2.0 * scene.gravity * scene.drop_height)
    first = solver.solve(speed, position=scene.position)
    if not first.success:  # the render would fail at this impact: say so before any work
        given = [f"contact.law={c.law!r}"]
        given += [f"contact.{k}={v!r}" for k, v in options.items() if k != "surface"]
        raise ParameterError(
            f"the first impact (at {speed:.4g} m/s) could not be solved with "
            f"{', '.join(given)}: {first.message} The scene is outside what the contact "
            f"solver handles"
        )
    e = 0.0 if first.settled else float(first.restitution)
    if c.plate == "impedance" or not first.settled:
        return FirstContact(first.separation_time, bool(first.settled), e)
    tau = impedance_contact_time(scene.ball, scene.plate, speed, law=c.law, **options)
    return FirstContact(SETTLE_FACTOR * tau, True, e)


def _series_seconds(scene, first: FirstContact, longest: float, max_duration: float) -> float:
    """Length of the bounce series from release, s: the fall, then the flights
    ``2 v e^n / g`` of a constant restitution ``e`` (the first impact's) summed,
    ``2 v e / (g (1 - e))``, and the longest contact; at most ``max_duration``."""
    g = scene.gravity
    fall = math.sqrt(2.0 * scene.drop_height / g)
    speed = g * fall
    e = first.restitution
    flights = math.inf if e >= 1.0 else 2.0 * speed * e / (g * (1.0 - e))
    return min(max_duration, fall + flights + longest)


def _tail_seconds(plate, floor_db: float, max_tail: float) -> float:
    """How long the slowest-decaying mode rings before falling ``floor_db`` (dB, < 0)
    below its start, s, at most ``max_tail``: every damping law's decay rate grows with
    frequency, so the slowest is the lowest mode, at the lattice's first wavenumber
    ``k = pi / max(a, b)`` (rad/m)."""
    k = math.pi / max(plate.length, plate.width)
    omega = k * k * math.sqrt(plate.flexural_rigidity / plate.surface_density)
    sigma = float(plate.damping_law().decay_rate(omega))
    nepers = -floor_db / 20.0 * math.log(10.0)
    return min(max_tail, nepers / sigma) if sigma > 0.0 else max_tail


#: The options of :func:`synth.render` the estimate depends on (:func:`estimate_render`).
RENDER_OPTIONS = (
    "samplerate", "max_frequency", "preroll", "max_duration", "max_tail", "pulse_points",
    "floor_db",
)  # fmt: skip


def estimate_render(scene, options: dict, budget: Budget | None = None) -> CostEstimate:
    """:func:`estimate` of ``scene`` with the render options in ``options`` (a preset's
    ``[render]`` section or a bank row's: ``samplerate`` required, the others of
    :data:`RENDER_OPTIONS` when given and not None, any other key ignored)."""
    given = {k: options[k] for k in RENDER_OPTIONS if options.get(k) is not None}
    return estimate(scene, budget=budget, **given)


@dataclass(frozen=True)
class SolverCost:
    """The cold mode solve (see the module docstring): ``unknowns`` of its largest
    problem, ``flops``, and the ``memory`` of its matrices and of the shapes it keeps,
    bytes."""

    unknowns: int
    flops: float
    solver_bytes: int
    shapes_bytes: int


def solver_cost(plate, f_max: float, modes: int) -> SolverCost:
    """The :class:`SolverCost` of ``plate``'s ``modes`` modes up to ``f_max`` (Hz)."""
    from synth.sound import modes as plate_modes

    main, check = plate_modes.solver_sizes(plate, f_max)
    flops = sum(n**3 / 3 + 2 * n**3 / 3 + 9 * n**3 for n in main)
    flops += sum(n**3 / 3 + 2 * n**3 / 3 + 4 * n**3 / 3 for n in check)
    return SolverCost(
        unknowns=max(main + check, default=0),
        flops=float(flops),
        solver_bytes=8 * max(SOLVER_SQUARES * max(main, default=0) ** 2,
                             CHECK_SQUARES * max(check, default=0) ** 2),
        shapes_bytes=8 * max(main, default=0) * modes,
    )  # fmt: skip


def estimate(
    scene,
    *,
    samplerate: int,
    max_frequency: float | None = None,
    preroll: float = 0.005,
    max_duration: float = 30.0,
    max_tail: float = 60.0,
    pulse_points: int = 65,
    floor_db: float = -80.0,
    budget: Budget | None = None,
) -> CostEstimate:
    """The :class:`CostEstimate` of rendering ``scene`` with these options of
    :func:`synth.render` (``samplerate`` in Hz, ``max_frequency`` in Hz, times in s);
    ``budget`` (default: the environment's) sets the radiation rules that fit."""
    budget = Budget.from_environment() if budget is None else budget
    from synth.sound.modal_bank.pulse import _grid_size
    from synth.sound.modal_bank.transform_kernels import WORK_ROWS

    f_max = 0.5 * samplerate if max_frequency is None else min(max_frequency, 0.5 * samplerate)
    modes = modal_count(scene.plate, f_max)
    speed = math.sqrt(2.0 * scene.gravity * scene.drop_height)
    first = _first_contact(scene)
    settles = first.settled
    longest = (
        first.contact_time if settles else _series_longest(first.contact_time, speed, scene.gravity)
    )
    points = _grid_size(longest, 2.0 * math.pi * f_max, pulse_points)
    series = _series_seconds(scene, first, longest, max_duration)
    seconds = preroll + series + _tail_seconds(scene.plate, floor_db, max_tail)
    samples = int(math.ceil(seconds * samplerate))
    solver = solver_cost(scene.plate, f_max, modes)
    impacts = _impact_count(first, speed, scene.gravity, max_duration)
    memory = MemoryParts(
        audio=AUDIO_BYTES_PER_SAMPLE * samples,
        impacts=16 * modes * (impacts + WORK_ROWS + MODE_VALUES),
        pulse=16 * points,
        solver=solver.solver_bytes,
        shapes=solver.shapes_bytes,
        radiation=_radiation_bytes(scene.plate, scene.listener, modes, f_max),
    )
    return CostEstimate(
        max_frequency=f_max,
        modes=modes,
        impact_speed=speed,
        hertz_contact=hertz_contact_time(scene.ball, scene.plate, speed),
        longest_contact=longest,
        settles=settles,
        pulse_points=points,
        audio_seconds=seconds,
        audio_samples=samples,
        memory_bytes=memory.total,
        max_duration=max_duration,
        solver_unknowns=solver.unknowns,
        solver_flops=solver.flops,
        impacts=impacts,
        memory=memory,
        radiation=radiation_work(scene.plate, scene.listener, modes, f_max, budget),
    )


@dataclass(frozen=True)
class BodyCost:
    """What preparing a live body costs (:meth:`synth.Engine.add`: its modes, their cold
    solve, a microphone's radiation gains; then its voices' modal states), the same
    estimates as a render's (:class:`CostEstimate`) for what a body has of a render.

    Attributes
    ----------
    max_frequency : float
        Highest rendered frequency, Hz.
    modes : int
        Plate modes below it (:func:`modal_count`).
    solver_unknowns, solver_flops
        The cold mode solve (as :class:`CostEstimate`).
    radiation : RadiationWork
        The listener's radiation stage (none for an accelerometer).
    memory : MemoryParts
        The largest arrays (``impacts``: the voices' modal states and the per-mode
        vectors; no audio or pulse).
    memory_bytes : int
        Their total (:attr:`MemoryParts.total`).
    """

    max_frequency: float
    modes: int
    solver_unknowns: int
    solver_flops: float
    radiation: RadiationWork
    memory: MemoryParts
    memory_bytes: int
    #: What the memory message calls the owner of the arrays.
    subject = "body"

    def excess(self, budget: Budget) -> list[str]:
        """What is too big for ``budget``, each with what to change (the messages of
        :meth:`CostEstimate.excess`; empty: the body fits)."""
        out = []
        too_many = modes_excess(self.modes, self.max_frequency, budget)
        if too_many:
            out.append(too_many)
        return out + _stage_excess(self, budget, BODY_MEMORY_ADVICE)

    def check(self, budget: Budget) -> None:
        """Raise ``ParameterError`` naming everything :meth:`excess` finds."""
        too_big = self.excess(budget)
        if too_big:
            raise ParameterError("refused before any work: " + "; ".join(too_big))


def body_cost(
    plate, listener, max_frequency: float, voices: int = 1, budget: Budget | None = None
) -> BodyCost:
    """The :class:`BodyCost` of ``plate`` heard by ``listener`` (an Accelerometer or a
    Microphone) up to ``max_frequency`` (Hz) with ``voices`` voices; ``budget`` (default:
    the environment's) sets the radiation rules that fit. Nothing is solved."""
    budget = Budget.from_environment() if budget is None else budget
    modes = modal_count(plate, max_frequency)
    solver = solver_cost(plate, max_frequency, modes)
    memory = MemoryParts(
        audio=0,
        impacts=16 * modes * (voices + MODE_VALUES),
        pulse=0,
        solver=solver.solver_bytes,
        shapes=solver.shapes_bytes,
        radiation=_radiation_bytes(plate, listener, modes, max_frequency),
    )
    return BodyCost(
        max_frequency=max_frequency,
        modes=modes,
        solver_unknowns=solver.unknowns,
        solver_flops=solver.flops,
        radiation=radiation_work(plate, listener, modes, max_frequency, budget),
        memory=memory,
        memory_bytes=memory.total,
    )


def check_body(
    plate, listener, max_frequency: float, voices: int = 1, budget: Budget | None = None
) -> int | None:
    """Check a live body before any work (:func:`body_cost` against ``budget``, default
    the environment's): ``ParameterError`` naming what is too big and what to change, as
    a render's. Returns the ``radiation_max_points`` to pass to
    :func:`synth.sound.render.modal_model` (where the budget stops the sums' refinement;
    None: not stopped)."""
    budget = Budget.from_environment() if budget is None else budget
    cost = body_cost(plate, listener, max_frequency, voices, budget)
    cost.check(budget)
    return cost.radiation.max_points


def _bending(plate, f_max: float) -> float:
    """The bending wavenumber at ``f_max`` (Hz), rad/m."""
    omega = 2.0 * math.pi * f_max
    return math.sqrt(omega * math.sqrt(plate.surface_density / plate.flexural_rigidity))


def _acoustic(f_max: float) -> float:
    """The acoustic wavenumber at ``f_max`` (Hz), rad/m."""
    from synth.constants import SOUND_SPEED

    return 2.0 * math.pi * f_max / SOUND_SPEED


def _kappa(plate, f_max: float) -> float:
    """The rectangle rule's wavenumber at ``f_max`` (Hz): bending plus acoustic, rad/m
    (the highest mode's, which lies at or below ``f_max``)."""
    return _bending(plate, f_max) + _acoustic(f_max)


def _crossed(plate, f_max: float) -> bool:
    """Whether ``plate``'s modes up to ``f_max`` (Hz) pass the Ritz crossover (a free or
    clamped plate with dynamic edge effect modes, :func:`synth.sound.modes.modes`)."""
    from synth.sound.modes import CROSSOVER_UNKNOWNS, _dimensionless_band
    from synth.sound.modes.ritz import ritz_unknowns

    if plate.boundary == "simply-supported":
        return False
    omega = _dimensionless_band(plate, f_max)
    return ritz_unknowns(plate.length / plate.width, omega) > CROSSOVER_UNKNOWNS


def _boundary_forced(plate, f_max: float, max_points: int) -> bool:
    """Whether ``max_points`` switches the edge effect modes to the boundary rule: the
    rectangle rule's check rule (``REFINE^2`` times the first one's points) would exceed
    it (:func:`synth.sound.radiation._use_boundary`)."""
    from synth.sound import radiation as rad

    size = (plate.length, plate.width)
    return (
        rad.rectangle_points(size, _kappa(plate, f_max), RADIATION_TOL) * rad.REFINE**2 > max_points
    )


def _radiation_rule(plate, modes: int, f_max: float, max_points: int | None = None) -> str:
    """The rule :func:`synth.sound.radiation.plate_gains` takes for ``modes`` modes up to
    ``f_max`` (Hz) with ``max_points`` (default: the sums' own): its own switch-overs on
    the rectangle rule's work (modes times the points of
    :func:`~synth.sound.radiation.rectangle_points`), and for a plate with edge effect
    modes (beyond the Ritz crossover) its test of the boundary rule."""
    from synth.sound import radiation as rad

    max_points = rad.DEFAULT_MAX_POINTS if max_points is None else max_points
    size = (plate.length, plate.width)
    kappa = _kappa(plate, f_max)
    work = modes * rad.rectangle_points(size, kappa, RADIATION_TOL)
    if plate.boundary == "simply-supported":
        return "polar" if work > rad._POLAR_WORK else "rectangle"
    if _crossed(plate, f_max):
        a, b = size
        big = work > rad.BOUNDARY_RULE_WORK and kappa * a * b / (a + b) > rad.BOUNDARY_RULE_SIZE
        forced = _boundary_forced(plate, f_max, max_points)
        return "boundary" if big or forced else "rectangle"
    return "summed" if work > rad.SUMMED_RULE_WORK else "rectangle"


def _rules_taken(points, max_points: int | None) -> int:
    """Rules a refinement takes with ``max_points`` (None: no cut): after its first two it
    stops before a rule of more points (:mod:`synth.sound.radiation.refinement`)."""
    from synth.sound.radiation.common import MAX_RULES

    taken = 2
    while taken < MAX_RULES and (max_points is None or points[taken] <= max_points):
        taken += 1
    return taken


def _fitted(rule, modes: int, terms: int, budget: Budget) -> RadiationWork:
    """The :class:`RadiationWork` of the counts ``rule``
    (:class:`synth.sound.radiation.work.RuleWork`, terms) with the most rules whose summed
    work, in rectangle-term equivalents (:func:`weighted_counts`), fits ``budget``: the
    ``max_points`` that stops the refinement there (at least the rule's ``floor``) and the
    rules it then takes; one rule (refused) if not even two fit."""
    from synth.sound.radiation.common import MAX_RULES

    rule = weighted_counts(rule)

    rules, cut = 1, int(rule.points[0])
    for last in range(MAX_RULES, 1, -1):
        candidate = None if last == MAX_RULES else max(int(rule.points[last - 1]), rule.floor)
        taken = _rules_taken(rule.points, candidate)
        if rule.fixed + float(sum(rule.work[:taken])) <= budget.max_radiation_work:
            rules, cut = taken, candidate
            break
    points = int(sum(rule.points[:rules]))
    return RadiationWork(
        rule.rule, int(rule.points[0]), points, terms, float(points) * modes, rules, cut,
        tuple(int(p) for p in rule.points), tuple(float(w) for w in rule.work),
        float(rule.fixed), rule.unit,
    )  # fmt: skip


def radiation_work(plate, listener, modes: int, f_max: float, budget: Budget) -> RadiationWork:
    """The :class:`RadiationWork` of ``listener`` hearing ``plate``'s ``modes`` modes up to
    ``f_max`` (Hz), before any mode is solved, for the rule the render takes (also when the
    budget's cut of the rectangle rule switches edge effect modes to the boundary rule),
    with the rules whose summed work fits ``budget`` (at least the first; see the module
    docstring and :mod:`synth.sound.radiation.work`)."""
    from synth.physics.scene import Microphone
    from synth.sound.modes import shape_terms

    if not isinstance(listener, Microphone) or modes == 0:
        return RadiationWork()
    terms = shape_terms(plate, f_max)
    rule = _radiation_rule(plate, modes, f_max)
    fitted = _fitted(rule_counts(rule, plate, listener, modes, f_max), modes, terms, budget)
    cut = fitted.max_points
    if rule != "rectangle" or cut is None:
        return fitted
    if not (_crossed(plate, f_max) and _boundary_forced(plate, f_max, cut)):
        return fitted
    boundary = _fitted(rule_counts("boundary", plate, listener, modes, f_max), modes, terms, budget)
    if boundary.max_points is None:  # the rectangle rule's cut keeps the switch
        return dataclasses.replace(boundary, max_points=cut)
    return boundary


def rule_counts(rule: str, plate, listener, modes: int, f_max: float):
    """The counts (:class:`synth.sound.radiation.work.RuleWork`) of ``rule`` ("rectangle",
    "polar", "summed" or "boundary") for ``listener`` (a Microphone) hearing ``plate``'s
    ``modes`` modes up to ``f_max`` (Hz), whichever rule the engine would take."""
    from synth.sound.modes import shape_terms
    from synth.sound.radiation import work

    size, position = (plate.length, plate.width), listener.position
    kb, qa = _bending(plate, f_max), _acoustic(f_max)
    tol_panel = 0.1 * RADIATION_TOL
    terms = shape_terms(plate, f_max)
    if rule == "rectangle":
        return work.rectangle_work(size, position, kb + qa, modes, terms, tol_panel)
    if rule == "polar":
        n_x, n_y = (int(kb * side / math.pi) for side in size)
        return work.polar_work(size, position, kb, qa, modes, n_x, n_y, tol_panel)
    if rule == "summed":
        from synth.sound.modes import ritz_factors, solver_sizes

        n_x, n_y = ritz_factors(plate, f_max)
        basis = max(solver_sizes(plate, f_max)[0], default=1)
        return work.summed_work(size, position, kb, qa, modes, n_x, n_y, basis, terms, tol_panel)
    return _boundary_counts(plate, position, modes, f_max, terms)


def _ritz_band_frequency(plate, f_max: float) -> float:
    """The top of the Ritz low band of a plate past the crossover, Hz (its seam with the
    edge effect modes lies at or below it, :mod:`synth.sound.modes.crossover`)."""
    from synth.sound.modes import frequency_scale, ritz_band

    return ritz_band(plate, f_max) * frequency_scale(plate) / (2.0 * math.pi)


def _boundary_counts(plate, position, modes: int, f_max: float, terms: int):
    """The boundary rule's counts (:func:`synth.sound.radiation.work.boundary_work`) for
    the edge effect modes between the Ritz low band and ``f_max`` (Hz), in
    ``BOUNDARY_BANDS`` bands of frequency (each mode one row, or two for a pair: counted
    as two), plus, outside the refinement, every rule of the rectangle rule of the Ritz
    modes below them (at their own wavenumber)."""
    from synth.sound.radiation import work

    size = (plate.length, plate.width)
    tol_panel = 0.1 * RADIATION_TOL
    f_low = _ritz_band_frequency(plate, f_max)
    n_low = modal_count(plate, f_low)
    edges = f_low * (f_max / f_low) ** (np.arange(work.BOUNDARY_BANDS + 1) / work.BOUNDARY_BANDS)
    counts = [modal_count(plate, float(f)) for f in edges]
    bands = [
        work.RateBand(_bending(plate, lo), _bending(plate, hi), _acoustic(hi), 2 * (n1 - n0))
        for lo, hi, n0, n1 in zip(edges[:-1], edges[1:], counts[:-1], counts[1:])
    ]
    edge = work.boundary_work(size, position, bands, tol_panel)
    ritz = work.rectangle_work(size, position, _kappa(plate, f_low), n_low, terms, tol_panel)
    # the Ritz modes' rectangle rule takes the same max_points: at least its check rule's
    return dataclasses.replace(
        edge, fixed=edge.fixed + float(sum(ritz.work)), floor=ritz.points[1] if n_low else 0
    )


def _radiation_bytes(plate, listener, modes: int, f_max: float) -> int:
    """Bytes of the chunks of shape values a microphone's Rayleigh sums hold
    (:data:`RADIATION_CHUNKS`): each ``modes`` times the points of the check rule (the
    first rule refined once, ``REFINE^2`` its points, :func:`rectangle_points` at the
    bending plus acoustic wavenumber of ``f_max``), at most ``CHUNK_BYTES`` (the polar
    rules' blocks of radii and the boundary rule's Ritz modes are held to it too)."""
    from synth.physics.scene import Microphone
    from synth.sound.radiation import rectangle_points
    from synth.sound.radiation.common import CHUNK_BYTES, REFINE

    if not isinstance(listener, Microphone) or modes == 0:
        return 0
    size = (plate.length, plate.width)
    points = rectangle_points(size, _kappa(plate, f_max), RADIATION_TOL) * REFINE**2
    chunk = min(float(CHUNK_BYTES), 8.0 * modes * points)
    return int(RADIATION_CHUNKS * chunk)
