"""The work of each radiation rule, counted from the rule's own panel builders before any
mode is solved (for :func:`synth.cost.radiation_work`).

Each count is per rule of the refinement (:mod:`~synth.sound.radiation.refinement`), from
the panels and orders the rule itself builds for the band's largest bending wavenumber
``kb`` and acoustic one ``qa = omega_max / c`` (rad/m), so the counts follow the code. The
unit is a *term*: a multiply-add, or one exponential, Bessel value or shape factor value.
Rectangle: per grid point and mode an exponential and a shape value's ``terms``. Polar and
summed: per angular point the factor values and angular products, per radius and mode an
exponential and a ``J_0`` (or the Ritz coefficients' combination), once the in-phase
bounds' rule. Boundary: per row of each band the radial grid's exponentials and Bessel
values, cumulative integrals and boundary nodes. A rule's *points* are what its
``max_points`` counts. The counts bound the work from above (selective refinements sum
only the modes still failing).
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
