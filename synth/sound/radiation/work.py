"""The work of each radiation rule, counted from the rule's own panel builders before any
mode is solved, and its weight from the shipped rates (for
:func:`~synth.sound.radiation.rules.choose_rule` and :func:`synth.cost.radiation_work`).

Each count is per rule of the refinement (:mod:`~synth.sound.radiation.refinement`), for the
band's largest bending wavenumber ``kb`` and acoustic one ``qa = omega_max / c`` (rad/m). The
unit is a *term*: a multiply-add, or one exponential, Bessel value or shape factor value.
Rectangle: per grid point and mode an exponential and a shape value's ``terms``. Polar and
summed: per angular point the factor values and angular products, per radius and mode an
exponential and a ``J_0`` (or the Ritz coefficients' combination), once the in-phase
bounds' rule. The counts bound the work from above (selective refinements sum only the
modes still failing). :func:`weighted_counts` turns terms into rectangle-term equivalents
by the rates ``synth bench cost --record`` measured and ships (:data:`RATES`), so the choice
and the budget's cut do not depend on the machine.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.sound.radiation.common import MAX_ORDER, MAX_RULES, REFINE, half_phase

#: Terms per radius and mode of the polar rule's radial sums: the exponential and ``J_0``.
POLAR_RADIAL_TERMS = 2
#: The rates of the estimate's work, measured by ``synth bench cost --record`` on the machine
#: named in it and shipped with the package: the mode solver's and each radiation rule's
#: (terms per second, by the rule's name).
RATES = Path(__file__).parents[2] / "cost_rates.json"


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
    """Rectangle-term equivalents of one term of each radiation rule, by name: the
    rectangle rule's terms per second over the rule's, in :data:`RATES` (shipped, not
    measured where it runs)."""
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
    from synth.sound.radiation.angular import (
        arc_panels,
        circle_arcs,
        radial_nodes,
        radial_orders,
        radial_panels,
    )

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
    """Points along x and y of the in-phase rule (:func:`~.rectangle.in_phase_grid`)."""
    from synth.sound.radiation.rectangle import in_phase_grid

    xs, _, ys, _ = in_phase_grid(size, listener, kb, tol_panel)
    return xs.size, ys.size


def polar_work(size, listener, kb, qa, modes, n_x, n_y, tol_panel, basis=None, terms=0):
    """The polar rule's work for ``modes`` separable modes of ``n_x`` and ``n_y`` factors;
    with ``basis`` the summed rule's (Ritz modes of ``basis`` coefficients, shape values of
    ``terms`` terms)."""
    summed = basis is not None
    grid = _polar_grid(size, listener, kb, qa, tol_panel, shorter=not summed)
    radial = basis + 1 if summed else POLAR_RADIAL_TERMS
    work = [
        float(angular) * (n_x + n_y + n_x * n_y) + float(radii) * modes * radial
        for radii, angular in grid
    ]
    xs, ys = _in_phase_points(size, listener, kb, tol_panel)
    if summed:
        fixed = float(xs * ys) * modes * (1 + terms)
    else:
        fixed = float(xs * n_x + ys * n_y + xs * ys * n_y + xs * n_x * n_y)
    name = "summed" if summed else "polar"
    return RuleWork(name, tuple(a for _, a in grid), tuple(work), fixed, "angular points")
