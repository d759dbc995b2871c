"""The measured rates of the estimate's work (:class:`Rates`, read from the file shipped
with the package), the radiation rules' weights they give and the seconds they turn an
estimate into.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from pathlib import Path

#: The rates of the estimate's work (:class:`Rates`), measured by ``synth bench cost
#: --record`` on the machine named in it and shipped with the package: the seconds of
#: ``synth info --cost`` and the radiation rules' weights (:func:`rule_weights`).
RATES = Path(__file__).parent.parent / "cost_rates.json"


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
    check = None if counts.check_fixed is None else fixed_weight * float(counts.check_fixed)
    return dataclasses.replace(
        counts,
        work=tuple(weight * float(w) for w in counts.work),
        fixed=fixed_weight * float(counts.fixed),
        check_fixed=check,
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
