"""The measured rates of the estimate's work (:class:`Rates`, read from the file shipped
with the package, :data:`~synth.sound.radiation.work.RATES`, which also weighs the radiation
rules, :func:`~synth.sound.radiation.work.rule_weights`) and the seconds they turn an
estimate into.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from synth.sound.radiation.work import RATES

__all__ = ["RATES", "Rates", "time_row"]


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
