"""The rules of :func:`~synth.sound.radiation.plate_gains` behind one interface (:class:`Rule`) and
the choice among them (:func:`choose_rule`) by a cost in rectangle-term equivalents counted
before any mode is solved (:data:`RATES`; docs/physics.md, "Choosing a rule")."""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.sound.radiation.angular import (
    arc_panels,
    circle_arcs,
    radial_nodes,
    radial_rule,
    shorter_arcs,
)
from synth.sound.radiation.common import MAX_RULES, REFINE, RadiationResult
from synth.sound.radiation.polar import separable_gains, summed_gains
from synth.sound.radiation.rectangle import (
    ProductFactors,
    first_rule,
    in_phase_grid,
    product_gains,
    rayleigh_gains,
)

#: Largest ratio of the wavenumbers (bending plus acoustic) of the fastest and slowest mode of
#: a :class:`BandedRule` band: at most ``1.1^2`` times the points a mode needs (``~kappa^2``).
BAND_RATIO = 1.1
#: Bands of frequency, equal in ratio, of :class:`BandedRule`'s estimate (:func:`edge_split`).
EDGE_BANDS = 6
#: Terms per radius and mode of the polar rule's radial sums: the exponential and ``J_0``.
POLAR_RADIAL_TERMS = 2
#: The measured rates of the estimate's work, shipped with the package (``synth bench cost
#: --record``): the mode solver's and each radiation rule's (terms per second, by name).
RATES = Path(__file__).parents[2] / "cost_rates.json"
#: Each rule's orders relative to the first rule's.
LEVELS = [REFINE**level for level in range(MAX_RULES)]


@dataclass(frozen=True)
class RuleWork:
    """One rule's counts: ``points`` (``unit`` says what they count) and ``work`` (terms) of
    each of its ``MAX_RULES`` rules, ``fixed`` terms outside the refinement."""

    rule: str
    points: tuple
    work: tuple
    fixed: float
    unit: str


@functools.cache
def rule_weights() -> dict[str, float]:
    """Rectangle-term equivalents of one term of each rule, by name: the rectangle rule's
    terms per second over the rule's, in the shipped :data:`RATES`."""
    try:
        rates = json.loads(RATES.read_text())["radiation_terms_per_second"]
    except FileNotFoundError:
        raise FileNotFoundError(
            f"{RATES} is missing: the radiation rules are weighed by their rates "
            f"(synth bench cost --record)"
        ) from None
    return {rule: rates["rectangle"] / rate for rule, rate in rates.items()}


def weighted_counts(counts: RuleWork) -> RuleWork:
    """``counts`` (terms) in rectangle-term equivalents (times its :func:`rule_weights`)."""
    weight = rule_weights()[counts.rule]
    return dataclasses.replace(
        counts,
        work=tuple(weight * float(w) for w in counts.work),
        fixed=weight * float(counts.fixed),
    )


def rectangle_work(size, listener, kappa, modes, terms, tol_panel) -> RuleWork:
    """The rectangle rule's work at ``kappa`` (rad/m) for ``modes`` modes whose shape values
    cost ``terms``: its tensor grid's points, rule ``l`` at ``REFINE^l`` the first's orders."""
    _, _, px, py = first_rule(size[0], size[1], listener, kappa, tol_panel)
    points = [int(np.ceil(px * f).sum()) * int(np.ceil(py * f).sum()) for f in LEVELS]
    work = [float(n) * modes * (1 + terms) for n in points]
    return RuleWork("rectangle", tuple(points), tuple(work), 0.0, "points")


def _polar_grid(size, listener, kb, qa, tol_panel, shorter: bool) -> list[tuple[int, int]]:
    """Per rule: (radii, angular points) of the polar rules; at each radius the arcs on the
    plate (the summed rule), or with ``shorter`` the shorter of those on and off it."""
    edges = (*size, listener[0], listener[1])
    panels, orders = radial_rule(size, listener, kb, qa, tol_panel)
    out = []
    for f in LEVELS:
        radii, _ = radial_nodes(panels, np.ceil(orders * f).astype(np.int64))
        angular = 0
        for r in map(float, radii):
            arcs = shorter_arcs(r, *edges)[1] if shorter else circle_arcs(r, *edges)[0]
            angular += sum(n * p for _, _, n, p in arc_panels(r, kb, tol_panel, f, arcs))
        out.append((radii.size, angular))
    return out


@dataclass(frozen=True)
class EdgeBand:
    """``modes`` edge effect modes whose wavenumber (bending plus acoustic) is at most
    ``kappa``, rad/m."""

    kappa: float
    modes: int


@dataclass(frozen=True)
class EdgeSplit:
    """The Ritz modes ``0 <= k < ritz_modes`` of a plate past the Ritz crossover, of largest
    wavenumber ``ritz_kappa`` (bending plus acoustic, rad/m), and its edge effect modes above
    in ``bands`` (:class:`EdgeBand`)."""

    ritz_modes: int
    ritz_kappa: float
    bands: tuple


@dataclass(frozen=True)
class Problem:
    """What decides a rule's error bound and cost, known before any gain is computed:
    ``size`` (a, b) and ``listener`` (x, y, z), m; ``modes``; ``kb`` the highest bending and
    ``qa`` the largest acoustic wavenumber (``max |s| / c``), rad/m; ``shapes`` "separable"
    (``X_i(x) Y_j(y)``), "summed" (sums of those), "edge" (split by ``edge``) or "any";
    ``terms`` of one shape value, ``factors`` (n_x, n_y) and ``basis`` (Ritz coefficients)."""

    size: tuple
    listener: tuple
    modes: int
    kb: float
    qa: float
    shapes: str
    terms: int
    factors: tuple
    basis: int
    tol: float
    max_points: int
    edge: EdgeSplit | None = None

    @property
    def tol_panel(self) -> float:
        """The panels' own tolerance (a tenth of ``tol``, as every rule builds them)."""
        return 0.1 * self.tol


@dataclass(frozen=True)
class Estimate:
    """One rule on one :class:`Problem`: ``counts``, ``fits`` (its check rule, the first
    refined once, within ``max_points``), ``cost`` in rectangle-term equivalents."""

    rule: Rule
    counts: RuleWork
    fits: bool
    cost: float
    error_bound: float  # of each gain's relative error: tol where the check rule fits, else inf


class Rule:
    """One rule of the Rayleigh integral: the ``shapes`` it takes, its ``counts(problem)``
    (:class:`RuleWork` of each refinement) and ``gains(modes, listener, s, settings)`` (of a
    :class:`synth.physics.modes.Modes` at ``listener`` for the poles ``s``, rad/s, ``settings``
    the keywords of :func:`~.rectangle.rayleigh_gains`)."""

    name = ""
    shapes: tuple = ()

    def applies(self, problem: Problem) -> bool:
        return problem.shapes in self.shapes and problem.modes > 0

    def estimate(self, problem: Problem) -> Estimate:
        counts = self.counts(problem)
        weighted = weighted_counts(counts)
        cost = weighted.fixed + sum(weighted.work[:2])
        fits = counts.points[1] <= problem.max_points
        return Estimate(self, counts, fits, cost, problem.tol if fits else math.inf)


class RectangleRule(Rule):
    """Tensor Gauss-Legendre panels (:func:`~.rectangle.rayleigh_gains`), any shapes: per
    point and mode an exponential and a shape value."""

    name = "rectangle"
    shapes = ("separable", "summed", "any")

    def counts(self, p):
        return rectangle_work(p.size, p.listener, p.kb + p.qa, p.modes, p.terms, p.tol_panel)

    def gains(self, modes, listener, s, settings):
        size = (modes.plate.length, modes.plate.width)
        return rayleigh_gains(modes.shapes, size, listener, s, full_output=True, **settings)


class PolarRule(Rule):
    """Polar coordinates about the microphone (:func:`~.polar.separable_gains`): products
    ``X_i(x) Y_j(y)``; the angular sums are shared by all modes, the radial sums cost per
    mode an exponential and a ``J_0``."""

    name, shapes, summed = "polar", ("separable",), False

    def counts(self, p):
        """The angular sums (shared by every mode) over the factors along x and y, and per
        radius and mode the radial terms; outside the refinement the in-phase bounds."""
        (n_x, n_y), summed = p.factors, self.summed
        grid = _polar_grid(p.size, p.listener, p.kb, p.qa, p.tol_panel, shorter=not summed)
        radial = p.basis + 1 if summed else POLAR_RADIAL_TERMS
        work = [float(a) * (n_x + n_y + n_x * n_y) + float(r) * p.modes * radial for r, a in grid]
        in_phase = in_phase_grid(p.size, p.listener, p.kb, p.tol_panel)
        xs, ys = in_phase.xs.size, in_phase.ys.size
        if summed:
            fixed = float(xs * ys) * p.modes * (1 + p.terms)
        else:
            fixed = float(xs * n_x + ys * n_y + xs * ys * n_y + xs * n_x * n_y)
        return RuleWork(self.name, tuple(a for _, a in grid), tuple(work), fixed, "angular points")

    def gains(self, modes, listener, s, settings):
        if self.summed:
            return summed_gains(modes.summed(), listener, s, full_output=True, **settings)
        return separable_gains(modes.separable(), listener, s, full_output=True, **settings)


class SummedRule(PolarRule):
    """The polar rule for sums of products (:func:`~.polar.summed_gains`): per radius and
    mode the combination of its Ritz coefficients."""

    name, shapes, summed = "summed", ("summed",), True


class BandedRule(Rule):
    """Edge effect modes by the rectangle rule band by band of wavenumber, shapes formed from
    factor tables (:func:`~.rectangle.product_gains`), the Ritz modes below on one rule; its
    rate is measured on the whole (``synth bench cost``)."""

    name = "banded"
    shapes = ("edge",)

    def counts(self, p):
        e = p.edge
        ritz = rectangle_work(p.size, p.listener, e.ritz_kappa, e.ritz_modes, p.terms,
                                   p.tol_panel)  # fmt: skip
        points = list(ritz.points if e.ritz_modes else [0] * len(ritz.points))
        terms = list(ritz.work)
        for band in e.bands:
            if band.modes == 0:
                continue
            rule = rectangle_work(p.size, p.listener, band.kappa, band.modes, 2, p.tol_panel)
            points = [max(a, b) for a, b in zip(points, rule.points)]
            terms = [a + b for a, b in zip(terms, rule.work)]
        return RuleWork("banded", tuple(points), tuple(terms), 0.0, "points")

    def gains(self, modes, listener, s, settings):
        """Each band's rule for its own fastest mode (every mode passes the same convergence
        test as on one rule for all)."""
        n_low = modes.edge_effect().first_mode
        qa = np.abs(s[n_low:]) / settings["sound_speed"]
        bands = mode_bands(modes.angular_frequencies[n_low:], settings["max_wavenumber"], qa)
        parts = [_band_rectangle(modes, n_low + lo, n_low + hi, listener, s, settings)
                 for lo, hi in bands]  # fmt: skip
        failed = sum(not p.success for p in parts)
        message = (
            f"{len(parts)} bands of wavenumber, {failed} not converged; the largest rule "
            f"{max(parts, key=lambda p: p.n_points).message}"
        )
        if n_low:
            parts.insert(0, _band_rectangle(modes, 0, n_low, listener, s, settings))
            message = (
                f"Ritz modes 0-{n_low - 1}: {parts[0].message}; edge effect modes {n_low}-"
                f"{len(modes) - 1} (banded rule): {message}"
            )
        return combined(parts, message)


#: The rules :func:`choose_rule` chooses among.
RULES = (RectangleRule(), PolarRule(), SummedRule(), BandedRule())


def choose_rule(problem: Problem) -> Estimate:
    """The :class:`Estimate` of the cheapest rule that takes the shapes and whose check rule
    fits ``max_points`` (it holds ``tol``); if none fits, the one of fewest check points."""
    return _cheapest(problem, RULES)


@functools.lru_cache(maxsize=256)  # warm renders choose again for every cached gain
def _cheapest(problem: Problem, rules: tuple) -> Estimate:
    estimates = [rule.estimate(problem) for rule in rules if rule.applies(problem)]
    holding = [e for e in estimates if e.error_bound <= problem.tol]
    if holding:
        return min(holding, key=lambda e: e.cost)
    return min(estimates, key=lambda e: e.counts.points[1])


def wavenumber_bands(kappa: np.ndarray, ratio: float) -> list:
    """Consecutive bands ``(start, stop)`` of modes (indices of ``kappa``, the modes in
    frequency order): a band starts at the first mode past the previous one and holds the
    following modes while their ``kappa`` stays within ``ratio`` times its first one's."""
    bands, start = [], 0
    while start < kappa.size:
        limit = kappa[start] * ratio
        stop = start + 1 + int(np.argmax(np.append(kappa[start + 1 :] > limit, True)))
        bands.append((start, stop))
        start = stop
    return bands


def mode_bands(omega: np.ndarray, kb: float, qa: np.ndarray) -> list:
    """:func:`wavenumber_bands` (:data:`BAND_RATIO`) of modes of ascending ``omega`` (rad/s):
    ``kappa`` = bending (``kb``, rad/m, at the highest, as ``sqrt(omega)``) plus acoustic
    ``qa`` (rad/m), made non-decreasing."""
    kappa = kb * np.sqrt(omega / omega[-1]) + qa
    return wavenumber_bands(np.maximum.accumulate(kappa), BAND_RATIO)


def _band_rectangle(modes, start, stop, listener, s, settings):
    """The rectangle rule of modes ``start <= k < stop`` alone at their largest bending
    wavenumber; edge effect modes with their factor tables."""
    omega = modes.angular_frequencies
    index = np.arange(start, stop)
    size = (modes.plate.length, modes.plate.width)
    settings = dict(settings)
    settings["max_wavenumber"] *= math.sqrt(omega[stop - 1] / omega[-1])
    edge = modes.edge_effect()
    if edge is not None and start >= edge.first_mode:

        def factors(x, y):
            return ProductFactors(*edge.product_factors(x, y, size[0], size[1], index))

        return product_gains(factors, size, listener, s[start:stop], **settings)
    shapes = lambda points: modes.shapes(points, index=index)  # noqa: E731
    return rayleigh_gains(shapes, size, listener, s[start:stop], full_output=True, **settings)


def combined(parts, message: str) -> RadiationResult:
    """One "banded" :class:`RadiationResult` of consecutive blocks of modes ``parts``
    (``n_points``, ``panels`` those of the block with the most points)."""
    status = max(p.status for p in parts)
    largest = max(parts, key=lambda p: p.n_points)
    return RadiationResult(
        *(np.concatenate([getattr(p, f) for p in parts]) for f in ("gains", "error", "coherent")),
        n_points=largest.n_points,
        refinements=max(p.refinements for p in parts),
        panels=largest.panels,
        success=status == 0,
        status=status,
        message=message,
        rule="banded",
    )


def edge_split(kb, f_low, f_max, ritz_modes, count_below, sound_speed) -> EdgeSplit:
    """The :class:`EdgeSplit` of ``ritz_modes`` Ritz modes up to ``f_low`` (Hz) and edge effect
    modes up to ``f_max`` (Hz, bending wavenumber ``kb``, rad/m; ``count_below(f)`` the modes
    below ``f``): :data:`EDGE_BANDS` bands, each at the wavenumber of its top."""
    ratios = np.arange(EDGE_BANDS + 1) / EDGE_BANDS
    edges = f_low * (f_max / f_low) ** ratios
    counts = [int(count_below(float(f))) for f in edges]
    bands = tuple(
        EdgeBand(kb * math.sqrt(hi / f_max) + 2.0 * math.pi * hi / sound_speed, n1 - n0)
        for hi, n0, n1 in zip(edges[1:], counts[:-1], counts[1:])
    )
    ritz_kappa = kb * math.sqrt(f_low / f_max) + 2.0 * math.pi * f_low / sound_speed
    return EdgeSplit(ritz_modes, ritz_kappa, bands)


def plate_problem(plate, f_max, *, shapes=None, **fields) -> Problem:
    """The :class:`Problem` of ``plate``'s modes up to ``f_max`` (Hz), ``fields`` its other
    fields (``edge`` past the Ritz crossover); ``shapes`` by default from the boundary."""
    from synth.physics.modes import ritz_factors, shape_terms, solver_sizes

    size = (plate.length, plate.width)
    edge, kb = fields.get("edge"), float(fields["kb"])
    if shapes is None:
        simply = plate.boundary == "simply-supported"
        shapes = "edge" if edge is not None else "separable" if simply else "summed"
    factors, basis = (0, 0), 1
    if shapes == "separable":
        factors = tuple(int(kb * s / math.pi) for s in size)
    elif shapes == "summed":
        factors = tuple(ritz_factors(plate, f_max))
        basis = max(solver_sizes(plate, f_max)[0], default=1)
    return Problem(
        size=size,
        listener=tuple(float(v) for v in fields["listener"]),
        modes=int(fields["modes"]),
        kb=kb,
        qa=float(fields["qa"]),
        shapes=shapes,
        terms=shape_terms(plate, f_max),
        factors=factors,
        basis=basis,
        tol=float(fields["tol"]),
        max_points=int(fields["max_points"]),
        edge=edge,
    )
