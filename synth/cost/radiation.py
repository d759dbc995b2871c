"""The radiation stage's work for a microphone: the rule the engine takes for a plate, the
points and terms of its rules, the rules the budget holds and the bytes of the sums.
"""

from __future__ import annotations

import math

from synth.constants import SOUND_SPEED
from synth.cost.modal import bending_wavenumber, modal_count
from synth.cost.records import RADIATION_CHUNKS, RADIATION_TOL, Budget, RadiationWork
from synth.sound.radiation.rules import weighted_counts


def _acoustic(f_max: float) -> float:
    """The acoustic wavenumber at ``f_max`` (Hz), rad/m."""
    return 2.0 * math.pi * f_max / SOUND_SPEED


def _crossed(plate, f_max: float) -> bool:
    """Whether ``plate``'s modes up to ``f_max`` (Hz) pass the Ritz crossover (a free or
    clamped plate with dynamic edge effect modes, :func:`synth.physics.modes.modes`)."""
    from synth.physics.modes import CROSSOVER_UNKNOWNS, dimensionless_band
    from synth.physics.modes.ritz import ritz_unknowns

    if plate.boundary == "simply-supported":
        return False
    omega = dimensionless_band(plate, f_max)
    return ritz_unknowns(plate.length / plate.width, omega) > CROSSOVER_UNKNOWNS


def radiation_problem(plate, listener, modes: int, f_max: float, max_points=None):
    """The :class:`synth.sound.radiation.rules.Problem` of ``listener`` (a Microphone)
    hearing ``plate``'s ``modes`` modes up to ``f_max`` (Hz) with ``max_points`` (default:
    the sums' own), before any mode is solved (past the Ritz crossover, its Ritz low band
    and edge effect modes counted by :func:`modal_count`)."""
    from synth.sound import radiation as rad
    from synth.sound.radiation.rules import edge_split, plate_problem

    max_points = rad.DEFAULT_MAX_POINTS if max_points is None else max_points
    kb = bending_wavenumber(plate, f_max)
    edge = None
    if _crossed(plate, f_max):
        f_low = _ritz_band_frequency(plate, f_max)
        n_low = modal_count(plate, f_low)
        edge = edge_split(kb, f_low, f_max, n_low, lambda f: modal_count(plate, f), SOUND_SPEED)
    return plate_problem(
        plate,
        listener.position,
        modes,
        f_max,
        kb=kb,
        qa=_acoustic(f_max),
        tol=RADIATION_TOL,
        max_points=max_points,
        edge=edge,
    )


def _rules_taken(points, max_points: int | None) -> int:
    """Rules a refinement takes with ``max_points`` (None: no cut): after its first two it
    stops before a rule of more points."""
    from synth.sound.radiation.common import MAX_RULES

    taken = 2
    while taken < MAX_RULES and (max_points is None or points[taken] <= max_points):
        taken += 1
    return taken


def _fitted(rule, modes: int, terms: int, budget: Budget) -> RadiationWork:
    """The :class:`RadiationWork` of the counts ``rule`` with the most rules whose summed
    work (rectangle-term equivalents) fits ``budget``: the ``max_points`` that stops the
    refinement there and the rules it then takes; one rule (refused) if not even two fit."""
    from synth.sound.radiation.common import MAX_RULES

    rule = weighted_counts(rule)

    rules, cut = 1, int(rule.points[0])
    for last in range(MAX_RULES, 1, -1):
        candidate = None if last == MAX_RULES else int(rule.points[last - 1])
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
    ``f_max`` (Hz), before any mode is solved, for the rule the render takes, with the rules
    whose summed work fits ``budget`` (at least the first)."""
    from synth.physics.modes import shape_terms
    from synth.physics.scene import Microphone
    from synth.sound.radiation.rules import choose_rule

    if not isinstance(listener, Microphone) or modes == 0:
        return RadiationWork()
    terms = shape_terms(plate, f_max)
    problem = radiation_problem(plate, listener, modes, f_max)
    return _fitted(choose_rule(problem).counts, modes, terms, budget)


def _ritz_band_frequency(plate, f_max: float) -> float:
    """The top of the Ritz low band of a plate past the crossover, Hz (its seam with the
    edge effect modes lies at or below it, :mod:`synth.physics.modes.crossover`)."""
    from synth.physics.modes import frequency_scale, ritz_band

    return ritz_band(plate, f_max) * frequency_scale(plate) / (2.0 * math.pi)


def radiation_bytes(plate, listener, modes: int, f_max: float) -> int:
    """Bytes of the chunks of shape values a microphone's Rayleigh sums hold
    (:data:`RADIATION_CHUNKS`): each ``modes`` times the points of the check rule at the
    bending plus acoustic wavenumber of ``f_max`` (Hz), at most ``CHUNK_BYTES``."""
    from synth.physics.scene import Microphone
    from synth.sound.radiation import rectangle_points
    from synth.sound.radiation.common import CHUNK_BYTES, REFINE

    if not isinstance(listener, Microphone) or modes == 0:
        return 0
    size = (plate.length, plate.width)
    kappa = bending_wavenumber(plate, f_max) + _acoustic(f_max)
    points = rectangle_points(size, kappa, RADIATION_TOL) * REFINE**2
    chunk = min(float(CHUNK_BYTES), 8.0 * modes * points)
    return int(RADIATION_CHUNKS * chunk)
