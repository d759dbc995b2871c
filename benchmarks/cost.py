"""``synth bench cost``: this machine's rates of the cost estimate's work.

The cost estimate (:mod:`synth.cost`) counts work in machine-independent units: the mode
solver's floating-point operations and each radiation rule's terms
(:mod:`synth.sound.radiation.rules`). This benchmark times, once, a cold mode solve and each
radiation rule applied alone (memory caches off) on a scene of its own, and divides the
estimate's count of that work (of the rules the refinement took) by the wall time: the
rates ``synth info --cost`` turns the estimate into seconds with, and whose ratios weigh
each radiation rule's terms in the budget (:func:`synth.sound.radiation.rules.rule_weights`;
the counts timed here are the rules' own terms, unweighted). ``--record`` writes them to
:data:`synth.cost.RATES` with the date, the machine and its load (the figures are those of
one run; a loaded machine gives lower rates), which changes the package's weights.
"""

from __future__ import annotations

import math
import os
import platform
import time
from dataclasses import asdict, dataclass

import numpy as np

from benchmarks.common import markdown_table

#: The mode solve timed: the free 18 mm MDF board of 1.2 x 0.6 m to this frequency, Hz.
SOLVER_FREQUENCY = 16000.0

#: Each rule's scene: (material, thickness m, length m, width m, boundary, highest
#: frequency Hz, microphone (x, y, z) m). The summed rule's plate stays below the Ritz
#: crossover, the banded rule's lies past it (its whole plate is timed).
RULE_SCENES = {
    "rectangle": ("mdf-18", 0.018, 1.2, 0.6, "free", 16000.0, (0.4, 0.25, 0.2)),
    "polar": ("steel", 0.001, 1.0, 0.8, "simply-supported", 12000.0, (0.4, 0.3, 0.3)),
    "summed": ("mdf-18", 0.018, 1.2, 0.6, "free", 16000.0, (0.4, 0.25, 0.2)),
    "banded": ("steel", 0.0005, 0.6, 0.5, "free", 12000.0, (0.25, 0.2, 0.2)),
}


@dataclass(frozen=True)
class StageRate:
    """One timed stage: ``stage`` ("solver" or a rule), its ``modes``, the estimate's
    ``work`` of what it did (flop or terms), the wall ``seconds`` and ``rate`` (work/s)."""

    stage: str
    modes: int
    work: float
    seconds: float
    rate: float


def _plate(spec):
    from synth import Plate

    material, thickness, length, width, boundary, _, _ = spec
    return Plate(material, thickness=thickness, length=length, width=width, boundary=boundary)


def _timed(call) -> tuple[object, float]:
    start = time.perf_counter()
    out = call()
    return out, time.perf_counter() - start


def _solver_rate() -> StageRate:
    from synth import Plate, cost
    from synth.physics.modes import modes

    plate = Plate("mdf-18", thickness=0.018, length=1.2, width=0.6)
    m, seconds = _timed(lambda: modes(plate, max_frequency=SOLVER_FREQUENCY, cache=False))
    flops = cost.solver_cost(plate, SOLVER_FREQUENCY, len(m)).flops
    return StageRate("solver", len(m), flops, seconds, flops / seconds)


def _rule_call(rule, m, listener, s, kb):
    """The rule applied alone to the modes ``m`` (full output, no cache)."""
    from synth.constants import AIR_DENSITY, SOUND_SPEED
    from synth.sound import radiation as rad
    from synth.sound.radiation.rules import BandedRule

    size = (m.plate.length, m.plate.width)
    settings = dict(max_wavenumber=kb, full_output=True)
    if rule == "rectangle":
        return rad.rayleigh_gains(m.shapes, size, listener, s, **settings)
    if rule == "polar":
        return rad.separable_gains(m.separable(), listener, s, **settings)
    if rule == "summed":
        return rad.summed_gains(m.summed(), listener, s, **settings)
    return BandedRule().gains(
        m, listener, s, dict(max_wavenumber=kb, air_density=AIR_DENSITY,
        sound_speed=SOUND_SPEED, reference_distance=None, tol=1e-6,
        max_points=rad.DEFAULT_MAX_POINTS),
    )  # fmt: skip


def rule_counts(rule: str, plate, listener, modes: int, f_max: float):
    """The counts (:class:`synth.sound.radiation.rules.RuleWork`) of ``rule`` ("rectangle",
    "polar", "summed" or "banded", :mod:`synth.sound.radiation.rules`) for
    ``listener`` (a Microphone) hearing ``plate``'s ``modes`` modes up to ``f_max`` (Hz),
    whichever rule the engine would take."""
    from synth.cost.estimates import radiation_problem
    from synth.sound.radiation.rules import RULES

    problem = radiation_problem(plate, listener, modes, f_max)
    found = [r for r in RULES if r.name == rule and r.applies(problem)]
    if not found:
        raise ValueError(f"the {rule} rule does not take the shapes of {plate!r}")
    return found[0].counts(problem)


def _rule_rate(rule: str) -> StageRate:
    from synth import Microphone
    from synth.physics.modes import modes

    spec = RULE_SCENES[rule]
    plate, f_max, listener = _plate(spec), spec[5], spec[6]
    m = modes(plate, max_frequency=f_max)
    omega = np.asarray(m.angular_frequencies)
    s = np.asarray(m.decay_rates) + 1j * omega  # the render's mirror poles
    kb = (float(omega.max()) ** 2 * plate.surface_density / plate.flexural_rigidity) ** 0.25
    result, seconds = _timed(lambda: _rule_call(rule, m, listener, s, kb))
    counts = rule_counts(rule, plate, Microphone(listener), len(m), f_max)
    rules = result.refinements + 1
    work = float(sum(counts.work[:rules])) + counts.fixed
    return StageRate(rule, len(m), work, seconds, work / seconds)


def run_cost() -> dict:
    """Time the mode solve and each rule once (see the module docstring)."""
    from synth.physics import modes
    from synth.sound import radiation

    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    for rule in RULE_SCENES:  # warm-up: every rule's kernels compiled and loaded
        _rule_rate(rule)
    stages = [_solver_rate()] + [_rule_rate(rule) for rule in RULE_SCENES]
    return {
        "stages": [asdict(s) for s in stages],
        "machine": f"{platform.node()} ({platform.machine()}, {os.cpu_count()} CPUs)",
        "load": round(os.getloadavg()[0], 2),
        "date": time.strftime("%Y-%m-%d", time.gmtime()),
    }


#: What each stage's row is called in the table.
TITLES = {
    "solver": "cold mode solve (flop)",
    "rectangle": "rectangle rule (terms)",
    "polar": "polar rule (terms)",
    "summed": "summed polar rule (terms)",
    "banded": "banded rectangle rule (terms)",
}


def format_cost(result: dict) -> str:
    """A Markdown table of :func:`run_cost`'s stages and a line on what they are."""
    header = ["stage", "modes", "work (estimate)", "wall s", "rate per s"]
    cells = [
        [TITLES[s["stage"]], str(s["modes"]), f"{s['work']:.3g}", f"{s['seconds']:.2f}",
         f"{s['rate']:.3g}"]
        for s in result["stages"]
    ]  # fmt: skip
    lines = markdown_table(header, cells)
    lines += [
        "",
        f"One run on {result['machine']}, load {result['load']}: each stage timed once alone "
        "(wall time), its work the cost estimate's count of what it did (the rules its "
        "refinement took). The scenes: benchmarks.cost.RULE_SCENES.",
    ]
    return "\n".join(lines)


def record_rates(result: dict) -> str:
    """Write the rates of :func:`run_cost` to :data:`synth.cost.RATES`; returns its path."""
    import json

    from synth.cost import RATES

    stages = {s["stage"]: s["rate"] for s in result["stages"]}
    data = {
        "solver_flops_per_second": float(f"{stages.pop('solver'):.3g}"),
        "radiation_terms_per_second": {k: float(f"{v:.3g}") for k, v in stages.items()},
        "measured": f"synth bench cost, {result['date']}, {result['machine']}, load "
        f"{result['load']}",
    }
    if not all(math.isfinite(v) and v > 0 for v in data["radiation_terms_per_second"].values()):
        raise ValueError(f"a rate is not a positive number: {data}")
    RATES.write_text(json.dumps(data, indent=1) + "\n")
    return str(RATES)
