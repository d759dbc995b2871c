"""The budget a render's or a live body's work must fit (:class:`Budget`): its defaults and the
environment variables that set them.
"""

from __future__ import annotations

from dataclasses import dataclass

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
#: or an exponential, weighted to the rectangle rule's time by
#: :func:`synth.sound.radiation.work.rule_weights`). Every shipped preset's first four rules
#: fit at 48 kHz (tests/test_cost.py).
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
