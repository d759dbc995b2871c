"""The radiation stage's work for a microphone: the rule the engine takes for a plate, the
points and terms of its rules, the rules the budget holds and the bytes of the sums.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from synth.cost.budget import Budget
from synth.cost.modal import modal_count
from synth.cost.rates import weighted_counts
from synth.cost.records import RADIATION_CHUNKS, RADIATION_TOL, RadiationWork


def bending_wavenumber(plate, f_max: float) -> float:
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
    return bending_wavenumber(plate, f_max) + _acoustic(f_max)


def _crossed(plate, f_max: float) -> bool:
    """Whether ``plate``'s modes up to ``f_max`` (Hz) pass the Ritz crossover (a free or
    clamped plate with dynamic edge effect modes, :func:`synth.physics.modes.modes`)."""
    from synth.physics.modes import CROSSOVER_UNKNOWNS, dimensionless_band
    from synth.physics.modes.ritz import ritz_unknowns

    if plate.boundary == "simply-supported":
        return False
    omega = dimensionless_band(plate, f_max)
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
        return "polar" if work > rad.POLAR_WORK else "rectangle"
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
    from synth.physics.modes import shape_terms
    from synth.physics.scene import Microphone

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
    from synth.physics.modes import shape_terms
    from synth.sound.radiation import work

    size, position = (plate.length, plate.width), listener.position
    kb, qa = bending_wavenumber(plate, f_max), _acoustic(f_max)
    tol_panel = 0.1 * RADIATION_TOL
    terms = shape_terms(plate, f_max)
    if rule == "rectangle":
        return work.rectangle_work(size, position, kb + qa, modes, terms, tol_panel)
    if rule == "polar":
        n_x, n_y = (int(kb * side / math.pi) for side in size)
        return work.polar_work(size, position, kb, qa, modes, n_x, n_y, tol_panel)
    if rule == "summed":
        from synth.physics.modes import ritz_factors, solver_sizes

        n_x, n_y = ritz_factors(plate, f_max)
        basis = max(solver_sizes(plate, f_max)[0], default=1)
        return work.summed_work(size, position, kb, qa, modes, n_x, n_y, basis, terms, tol_panel)
    return _boundary_counts(plate, position, modes, f_max, terms)


def _ritz_band_frequency(plate, f_max: float) -> float:
    """The top of the Ritz low band of a plate past the crossover, Hz (its seam with the
    edge effect modes lies at or below it, :mod:`synth.physics.modes.crossover`)."""
    from synth.physics.modes import frequency_scale, ritz_band

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
        work.RateBand(
            bending_wavenumber(plate, lo),
            bending_wavenumber(plate, hi),
            _acoustic(hi),
            2 * (n1 - n0),
        )
        for lo, hi, n0, n1 in zip(edges[:-1], edges[1:], counts[:-1], counts[1:])
    ]
    edge = work.boundary_work(size, position, bands, tol_panel)
    ritz = work.rectangle_work(size, position, _kappa(plate, f_low), n_low, terms, tol_panel)
    # the Ritz modes' rectangle rule takes the same max_points: at least its check rule's
    return dataclasses.replace(
        edge, fixed=edge.fixed + float(sum(ritz.work)), floor=ritz.points[1] if n_low else 0
    )


def radiation_bytes(plate, listener, modes: int, f_max: float) -> int:
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
