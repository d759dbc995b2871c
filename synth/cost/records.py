"""The cost estimates' records, the :class:`Budget` they must fit and the measured
:class:`Rates` that turn them into seconds."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

from synth import checks
from synth.errors import ParameterError
from synth.sound.radiation.rules import RATES

#: Default budget: plate modes below the highest rendered frequency.
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
#: (:func:`synth.sound.radiation.rules.rule_weights`); every shipped preset's first four rules
#: fit at 48 kHz.
DEFAULT_MAX_RADIATION_WORK = 2 * 10**11
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
    """The most work a render may take on: ``max_modes`` (plate modes), ``max_pulse_points``
    (of one force pulse's grid), ``max_memory_bytes`` (of the arrays :class:`CostEstimate`
    sizes), ``max_solver_flops`` (of a cold mode solve) and ``max_radiation_work``
    (rectangle-term equivalents of a microphone's sums): times in machine-free units."""

    max_modes: int = DEFAULT_MAX_MODES
    max_pulse_points: int = DEFAULT_MAX_PULSE_POINTS
    max_memory_bytes: int = DEFAULT_MAX_MEMORY_BYTES
    max_solver_flops: int = DEFAULT_MAX_SOLVER_FLOPS
    max_radiation_work: int = DEFAULT_MAX_RADIATION_WORK

    def __post_init__(self):
        for name in (f.name for f in dataclasses.fields(self)):
            checks.integer_at_least(f"budget.{name}", getattr(self, name), 1)

    @classmethod
    def from_environment(cls) -> Budget:
        """The budget of the variables of :data:`ENVIRONMENT` (each with its default)."""
        return cls(*(checks.environment_integer(n, d, 1) for n, d in ENVIRONMENT.items()))


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
        """Estimated wall seconds (s) of ``cost``'s cold mode solve and radiation stage: the
        fewest rules the convergence test takes (two) and every rule the budget holds."""
        r = cost.radiation
        rate = self.radiation["rectangle"]  # the work is in rectangle-term equivalents
        fewest = r.work_of(min(2, r.rules))
        return cost.solver_flops / self.solver, fewest / rate, r.work / rate


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


#: Bytes per audio sample held at once: the synthesis' float64 buffer, the scaled copy
#: the level makes (:func:`synth.store.audio.normalize`) and the float32 :class:`Render`.
AUDIO_BYTES_PER_SAMPLE = 8 + 8 + 4
#: Complex values per mode the modal model and the synthesis hold besides the transform's
#: workspace (poles, steps, response coefficients, gains, state and masks).
MODE_VALUES = 20
#: Dense n x n float64 arrays alive in a Rayleigh-Ritz solve with vectors
#: (:func:`synth.physics.modes.basis.solve_class`): the stiffness matrix, the Fortran-ordered
#: copy LAPACK's dpotrf/dpotri factor and invert in place, the eigenvectors, and dsyevd's
#: workspace of ``1 + 6 n + 2 n^2`` doubles (LAPACK Users' Guide, 3rd ed., DSYEVD).
SOLVER_SQUARES = 5
#: The same for the check basis, eigenvalues only: the matrix and its copy (the
#: workspace is ``1 + 2 n``).
CHECK_SQUARES = 2
#: Chunks of shape values (at most ``CHUNK_BYTES`` each) alive at once while a microphone's
#: gains are summed: the one being added, the next being evaluated
#: (:func:`synth.sound.radiation.rectangle.apply_rule`) and the evaluation's temporaries.
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
    """The radiation stage's work for a microphone (:mod:`synth.sound.radiation.rules`; rule
    "none" for an accelerometer): the rules the refinement may take within the budget, their
    points and work in rectangle-term equivalents, and ``max_points`` where the budget stops
    the refinement (None: it does not)."""

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
        the refinement; none for an accelerometer)."""
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


#: What to change when a render's arrays are beyond the memory budget.
RENDER_MEMORY_ADVICE = "lower max_tail, max_duration, max_frequency or the samplerate"
#: The same for a live body's.
BODY_MEMORY_ADVICE = "lower the engine's max_frequency or samplerate, or max_voices"
REST = " (the ball comes to rest)"


@dataclass(frozen=True)
class BodyCost:
    """What preparing a live body costs (:meth:`synth.Engine.add`), SI units (frequencies Hz,
    memory bytes): the plate's ``modes``, its cold mode solve (``solver_unknowns`` 0 for
    closed-form modes), the ``radiation`` stage and the ``memory`` (``memory.impacts``: the
    voices' states)."""

    max_frequency: float
    modes: int
    solver_unknowns: int
    solver_flops: float
    radiation: RadiationWork
    memory: MemoryParts
    memory_bytes: int
    #: What the memory message calls the owner of the arrays, and what it says to change.
    subject = "body"
    memory_advice = BODY_MEMORY_ADVICE

    def check(self, budget: Budget) -> None:
        """Raise ``ParameterError`` naming everything :meth:`excess` finds."""
        too_big = self.excess(budget)
        if too_big:
            raise ParameterError("refused before any work: " + "; ".join(too_big))

    def excess(self, budget: Budget, more: list | tuple = ()) -> list[str]:
        """What is too big for ``budget`` (the plate's modes, ``more``, the mode solver, the
        radiation stage, the memory), each with what to change (empty: it fits)."""
        out = [modes_excess(self.modes, self.max_frequency, budget), *more]
        if self.solver_flops > budget.max_solver_flops:
            out.append(
                f"a cold solve of the plate's modes takes about {self.solver_flops:.3g} "
                f"floating-point operations ({self.solver_unknowns} unknowns), more than the "
                f"budget of {budget.max_solver_flops:.3g} (SYNTH_MAX_SOLVER_FLOPS); lower "
                f"max_frequency or the samplerate, or use a simply supported plate (closed-form "
                f"modes)"
            )
        out.append(self.radiation.excess(self.modes, budget))
        if self.memory_bytes > budget.max_memory_bytes:
            parts = vars(self.memory)
            top = max(parts, key=parts.get)
            out.append(
                f"the {self.subject}'s largest arrays take about {self.memory_bytes / 2**20:.0f} "
                f"MiB (most of it the {top}: {parts[top] / 2**20:.0f} MiB), more than the "
                f"budget of {budget.max_memory_bytes / 2**20:.0f} MiB (SYNTH_MAX_MEMORY_BYTES); "
                f"{self.memory_advice}"
            )
        return [m for m in out if m]


@dataclass(frozen=True)
class CostEstimate(BodyCost):
    """The sizes of one render's work (:mod:`synth.cost.estimates`), those of
    :class:`BodyCost` and the render's own, SI units: speeds m/s, times s; ``settles``: the
    first impact does not separate."""

    impact_speed: float
    hertz_contact: float
    longest_contact: float
    settles: bool
    pulse_points: int
    audio_seconds: float
    audio_samples: int
    max_duration: float
    impacts: int
    subject = "render"
    memory_advice = RENDER_MEMORY_ADVICE

    def excess(self, budget: Budget, more: list | tuple = ()) -> list[str]:
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
        pulse = list(more)
        if self.pulse_points > budget.max_pulse_points:
            pulse.append(
                f"the longest force pulse ({self.longest_contact:.4g} s) needs "
                f"{self.pulse_points} grid points up to {self.max_frequency:.6g} Hz, more than "
                f"the budget of {budget.max_pulse_points} (SYNTH_MAX_PULSE_POINTS); lower "
                f"max_frequency or ball.mass"
            )
        return out + super().excess(budget, pulse)

    def rows(self) -> list[tuple[str, str]]:
        """(name, value with unit) rows, for ``synth info --cost``."""
        parts = ("audio", "impacts", "pulse", "solver", "shapes", "radiation")
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
            *((f"  {name}", f"{getattr(self.memory, name) / 2**20:.1f} MiB") for name in parts),
            time_row(self, Rates.load()),
        ]


@dataclass(frozen=True)
class SolverCost:
    """The cold mode solve (see the module docstring): ``unknowns`` of its largest
    problem, ``flops``, and the ``memory`` of its matrices and of the shapes it keeps,
    bytes."""

    unknowns: int
    flops: float
    solver_bytes: int
    shapes_bytes: int
