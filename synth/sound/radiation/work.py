"""The work of each radiation rule, counted from the rule's own panel builders before any
mode is solved (for :func:`synth.cost.radiation_work`).

Every rule refines by ``REFINE`` (:mod:`~synth.sound.radiation.refinement`, at most
``MAX_RULES`` rules); each count below is per rule, from the panels and orders the rule
itself builds for the band's largest wavenumbers (the bending wavenumber ``kb`` of the
highest rendered frequency and the acoustic one ``qa = omega_max / c``, rad/m): the
same functions, so the counts follow the code. The unit of work is a *term*: a
multiply-add, or one exponential, Bessel value or shape factor value.

* **rectangle** (:func:`rectangle_work`): the points of the tensor rule
  (:func:`~synth.sound.radiation.rectangle.first_rule`, orders times ``REFINE^l``), each
  costing per mode one exponential and the ``terms`` of a shape value.
* **polar** (:func:`polar_work`, the separable shapes of
  :func:`~synth.sound.radiation.separable_gains`): the radii of the radial panels
  (:func:`~synth.sound.radiation.radial.radial_orders`) and at each the angular points of
  the shorter set of arcs (:func:`~synth.sound.radiation.angular.arc_panels`); per angular
  point the ``n_x + n_y`` factor values and the ``n_x n_y`` products of the angular sums,
  per radius and mode an exponential and a ``J_0``; once, the in-phase bounds' rectangle
  rule at ``2 kb`` refined once (factor values and its two matrix products).
* **summed** (:func:`summed_work`, the Ritz shapes of
  :func:`~synth.sound.radiation.summed_gains`): the same radii and angular points; per
  angular point the factor values and products of the ``n_x x n_y`` angular sums, per
  radius and mode the combination of its class's ``basis`` coefficients and an
  exponential; once, the in-phase bounds' rectangle rule (as the rectangle rule's terms).
* **boundary** (:func:`boundary_work`, the edge effect modes of
  :func:`~synth.sound.radiation.boundary.boundary_rule`): per row (a mode's trial, two
  for a pair) the radial grid of its rate (:class:`~synth.sound.radiation.boundary_grid.RadialGrid`,
  built for the top of each band of rates): per radial node an exponential and the two
  Bessel values of each of the three Helmholtz parts, per panel the parts' two
  cumulative integrals (``p^2`` each), per boundary node the trial's parts and slopes.

A rule's *points* are what its ``max_points`` counts: the rectangle rule's grid points,
the polar rules' angular points, the boundary rule's radial nodes (of its finest grid).
An upper bound of the work a rule takes: the selective refinements
(:func:`~synth.sound.radiation.refinement.refine_selective`) evaluate only the modes still
failing, and a rule that converges early stops there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.sound.radiation.common import MAX_ORDER, MAX_RULES, REFINE, half_phase

#: Terms per radius and mode of the polar rule's radial sums: the exponential and ``J_0``.
POLAR_RADIAL_TERMS = 2
#: Terms per row and radial node of the boundary rule: the row's exponential and two
#: Bessel values for each of the three Helmholtz parts.
BOUNDARY_NODE_TERMS = 7
#: Cumulative integrals per row and panel of the boundary rule (two per Helmholtz part),
#: each ``p^2`` multiply-adds on a panel of ``p`` nodes.
BOUNDARY_CUMULATIONS = 6
#: Terms per row and boundary node: the trial's two parts and two slopes along the edge
#: and the nine products of the three parts.
BOUNDARY_EDGE_TERMS = 13
#: Bands of rate the boundary rule's rows are counted in (each on the grid of its top).
BOUNDARY_BANDS = 6


@dataclass(frozen=True)
class RuleWork:
    """One rule's counts: ``points`` and ``work`` (terms) of each of its ``MAX_RULES``
    rules, ``fixed`` terms outside the refinement (the in-phase bounds), ``unit``, what
    its points count, and ``floor``, the fewest ``max_points`` the render may pass (the
    boundary rule's Ritz modes take the rectangle rule with the same ``max_points``,
    which must hold its check rule); ``check_fixed``, where the work outside the
    refinement refines too (those Ritz modes), its terms up to the check rule."""

    rule: str
    points: tuple
    work: tuple
    fixed: float
    unit: str
    floor: int = 0
    check_fixed: float | None = None


def _levels():
    return [REFINE**level for level in range(MAX_RULES)]


def rectangle_work(size, listener, kappa, modes, terms, tol_panel) -> RuleWork:
    """The rectangle rule's work at the wavenumber ``kappa`` (rad/m) for ``modes`` modes
    whose shape values cost ``terms``: the points of its tensor grid, each rule's orders
    ``REFINE^l`` times the first rule's."""
    from synth.sound.radiation.rectangle import first_rule

    _, _, px, py = first_rule(size[0], size[1], listener, kappa, tol_panel)
    points = [int(np.ceil(px * f).sum()) * int(np.ceil(py * f).sum()) for f in _levels()]
    work = [float(n) * modes * (1 + terms) for n in points]
    return RuleWork("rectangle", tuple(points), tuple(work), 0.0, "points")


def _polar_grid(size, listener, kb, qa, tol_panel, shorter: bool) -> list[tuple[int, int]]:
    """Per rule: (radii, angular points) of the polar rules (:func:`polar_setup`'s
    panels); at each radius the arcs on the plate (the summed rule's
    :func:`angular_rule`), or with ``shorter`` the shorter of those on and off it (the
    separable rule's :func:`_circle_points`)."""
    from synth.sound.radiation.angular import arc_panels, circle_arcs
    from synth.sound.radiation.radial import radial_nodes, radial_orders, radial_panels

    a, b = size
    xl, yl, _ = listener
    kappa = kb + qa
    h = 2.0 * half_phase(MAX_ORDER, tol_panel) / kappa
    panels, orders = radial_orders(
        radial_panels(a, b, listener, h), size, listener, kb, qa, tol_panel
    )
    out = []
    for f in _levels():
        radii, _ = radial_nodes(panels, np.ceil(orders * f).astype(np.int64))
        angular = 0
        for r in radii:
            on, off = circle_arcs(float(r), a, b, xl, yl)
            if shorter and sum(v - u for u, v in off) < sum(v - u for u, v in on):
                on = off
            angular += sum(n * p for _, _, n, p in arc_panels(float(r), kb, tol_panel, f, on))
        out.append((radii.size, angular))
    return out


def _in_phase_points(size, listener, kb, tol_panel) -> tuple[int, int]:
    """Points along x and y of the polar rules' in-phase rectangle rule (``2 kb``,
    refined once)."""
    from synth.sound.radiation.rectangle import first_rule

    _, _, px, py = first_rule(size[0], size[1], listener, 2.0 * kb, tol_panel)
    return int(np.ceil(px * REFINE).sum()), int(np.ceil(py * REFINE).sum())


def polar_work(size, listener, kb, qa, modes, n_x, n_y, tol_panel) -> RuleWork:
    """The polar rule's work for ``modes`` separable modes of ``n_x`` and ``n_y`` factors."""
    grid = _polar_grid(size, listener, kb, qa, tol_panel, shorter=True)
    work = [
        float(angular) * (n_x + n_y + n_x * n_y) + float(radii) * modes * POLAR_RADIAL_TERMS
        for radii, angular in grid
    ]
    xs, ys = _in_phase_points(size, listener, kb, tol_panel)
    fixed = float(xs * n_x + ys * n_y + xs * ys * n_y + xs * n_x * n_y)
    return RuleWork("polar", tuple(a for _, a in grid), tuple(work), fixed, "angular points")


def summed_work(size, listener, kb, qa, modes, n_x, n_y, basis, terms, tol_panel) -> RuleWork:
    """The summed polar rule's work for ``modes`` Ritz modes (``n_x``, ``n_y`` factors,
    ``basis`` coefficients per mode, shape values of ``terms`` terms)."""
    grid = _polar_grid(size, listener, kb, qa, tol_panel, shorter=False)
    work = [
        float(angular) * (n_x + n_y + n_x * n_y) + float(radii) * modes * (basis + 1)
        for radii, angular in grid
    ]
    xs, ys = _in_phase_points(size, listener, kb, tol_panel)
    fixed = float(xs * ys) * modes * (1 + terms)
    return RuleWork("summed", tuple(a for _, a in grid), tuple(work), fixed, "angular points")


@dataclass(frozen=True)
class RateBand:
    """Rows of the boundary rule whose modes lie between the bending wavenumbers ``k_lo``
    and ``k_hi`` (rad/m): ``rows`` terms (a mode's trial, two for a pair), of acoustic
    wavenumber at most ``qa`` (rad/m)."""

    k_lo: float
    k_hi: float
    qa: float
    rows: int


def _boundary_grid(size, listener, band: RateBand, tol_panel, refine):
    """The radial grid :func:`boundary_integrals` builds for the band's top rate: its
    oscillating rate ``k + |q|`` and the edge parts' decay (at most ``sqrt(2) k`` along an
    edge), the decaying parts' ``sqrt(3) k`` and the band's lowest ``k`` (the tail)."""
    from synth.sound.radiation import boundary_grid as bg

    w_max = half_phase(MAX_ORDER, tol_panel)
    k_osc = bg.on_ladder(band.k_hi + band.qa)
    k_dec = max(k_osc, bg.on_ladder(math.sqrt(2.0) * band.k_hi))
    kappa_max = bg.on_ladder(math.sqrt(3.0) * band.k_hi)
    kappa_min = bg.below_ladder(band.k_lo)
    if kappa_min * 2.0 * w_max / k_dec <= 2.0:
        kappa_min = 0.0
    return bg.RadialGrid(size, listener, k_dec, kappa_max, kappa_min, tol_panel, refine)


def boundary_row_terms(grid) -> float:
    """Terms of one row of the boundary rule on ``grid`` (a
    :class:`~synth.sound.radiation.boundary_grid.RadialGrid`; see the module docstring)."""
    return (
        BOUNDARY_NODE_TERMS * grid.rho.size
        + BOUNDARY_CUMULATIONS * float(np.sum(grid.orders.astype(float) ** 2))
        + BOUNDARY_EDGE_TERMS * grid.edge_arrays[4].size
    )


def boundary_work(size, listener, bands, tol_panel) -> RuleWork:
    """The boundary rule's work for its rows in ``bands`` (:class:`RateBand`)."""
    points, work = [], []
    for f in _levels():
        nodes, terms = 0, 0.0
        for band in bands:
            if band.rows == 0:
                continue
            grid = _boundary_grid(size, listener, band, tol_panel, f)
            nodes = max(nodes, grid.rho.size)
            terms += band.rows * boundary_row_terms(grid)
        points.append(nodes)
        work.append(terms)
    return RuleWork("boundary", tuple(points), tuple(work), 0.0, "radial nodes")
