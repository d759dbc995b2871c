"""The rectangle rule band by band of wavenumber (plate_gains of a plate with dynamic edge
effect modes): each band's rule follows its own fastest mode, and every gain still agrees
with one rectangle rule for all the modes."""

from __future__ import annotations

import numpy as np
import pytest

from synth.physics import modes as P
from synth.physics.materials import LossFactor, Material
from synth.physics.modes import crossover
from synth.physics.scene import Plate
from synth.sound import radiation as R
from synth.sound.radiation import rules

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))


def test_wavenumber_bands_cover_the_modes_within_the_ratio():
    """Bands of a non-decreasing sequence are consecutive, cover every mode once, and hold
    the modes whose wavenumbers lie within the ratio of the band's first one."""
    kappa = np.cumsum(np.random.default_rng(1).uniform(0.0, 1.0, 500)) + 10.0
    bands = rules.wavenumber_bands(kappa, 1.25)
    assert bands[0][0] == 0 and bands[-1][1] == kappa.size
    assert all(a[1] == b[0] for a, b in zip(bands[:-1], bands[1:]))
    for lo, hi in bands:
        assert hi > lo and kappa[hi - 1] <= 1.25 * kappa[lo]
    for a, b in zip(bands[:-1], bands[1:]):
        assert kappa[b[0]] > 1.25 * kappa[a[0]]  # a band ends at the first mode beyond
    assert rules.wavenumber_bands(kappa, np.inf) == [(0, kappa.size)]
    assert rules.wavenumber_bands(np.zeros(0), 1.25) == []


@pytest.mark.slow
@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_banded_rectangle_rule_agrees_with_one_rule(monkeypatch, boundary):
    """A small plate past a lowered Ritz crossover (a few Ritz modes, then edge effect
    modes): plate_gains (rule "banded", several bands)
    converges and agrees with rayleigh_gains of every mode on one rule within 2 tol (each
    is within tol of the integral: the refinement test's bound); its in-phase bounds within
    10 % (they bound |H_k| and set the tolerance floor; |phi_k| has kinks on the nodal
    lines, which the two grids integrate differently)."""
    monkeypatch.setattr(crossover, "CROSSOVER_UNKNOWNS", 80)
    monkeypatch.setattr(crossover, "LOW_BAND_UNKNOWNS", 50)
    m = P.modes(Plate(STEEL, 0.002, 0.3, 0.2, boundary), max_frequency=8000.0, cache=False)
    part = m.edge_effect()
    assert part is not None and 0 < part.first_mode < len(m) - 50
    s = -m.decay_rates + 1j * m.angular_frequencies
    kb = (
        m.angular_frequencies.max() ** 2 * m.plate.surface_density / m.plate.flexural_rigidity
    ) ** 0.25
    listener = (0.11, 0.08, 0.1)
    tol = 1e-6
    res = R.plate_gains(m, listener, s, max_wavenumber=kb, tol=tol, full_output=True, cache=False)
    assert res.rule == "banded" and res.success, res.message
    assert "bands of wavenumber" in res.message and not res.message.startswith("1 bands")
    full = R.rayleigh_gains(
        m.shapes, (0.3, 0.2), listener, s, max_wavenumber=kb, tol=tol, full_output=True
    )
    allowed = 2 * tol * np.maximum(np.abs(full.gains), 1e-4 * full.coherent)
    assert np.all(np.abs(res.gains - full.gains) <= allowed)
    np.testing.assert_allclose(res.coherent, full.coherent, rtol=0.1)


def _product_case(paired):
    """Shapes of two products per mode (or one) on a 0.3 x 0.2 m plate, as a function of
    points and as factor tables, their poles and settings."""
    from synth.sound.radiation.rectangle import ProductFactors

    a, b = 0.3, 0.2
    kx = np.array([1.0, 3.0, 4.0, 7.0]) * np.pi / a
    ky = np.array([2.0, 1.0, 5.0, 3.0]) * np.pi / b
    weight = 0.5 if paired else 0.0

    def shape_fn(points):
        x, y = points[:, :1], points[:, 1:]
        return np.sin(kx * x) * np.sin(ky * y) + weight * np.cos(ky * x) * np.cos(kx * y)

    def factor_fn(x, y):
        own = (np.sin(np.outer(x, kx)), np.sin(np.outer(y, ky)))
        if not paired:
            return ProductFactors(*own)
        return ProductFactors(*own, weight * np.cos(np.outer(x, ky)), np.cos(np.outer(y, kx)))

    s = -5.0 + 1j * 2.0 * np.pi * np.array([900.0, 2100.0, 3000.0, 5200.0])
    kb = float(np.hypot(kx, ky).max())
    return (a, b), shape_fn, factor_fn, s, kb


@pytest.mark.parametrize("paired", [False, True])
def test_product_sums_equal_the_rectangle_sums_of_the_same_shapes(paired):
    """apply_product_rule forms the shapes from factor tables inside the sums: on one grid
    its integrals and in-phase integrals equal apply_rule's (to rounding: the same terms,
    summed in another order)."""
    from synth.sound.radiation.common import Poles
    from synth.sound.radiation.rectangle import apply_product_rule, apply_rule, panel_grid

    (a, b), shape_fn, factor_fn, s, _ = _product_case(paired)
    grid = panel_grid(np.linspace(0.0, a, 7), np.linspace(0.0, b, 5), np.full(6, 11),
                      np.full(4, 13))  # fmt: skip
    listener, poles, r_mid = (0.12, 0.07, 0.05), Poles.of(s / 343.0, 0), 0.2
    want = apply_rule(shape_fn, grid, listener, r_mid, poles, 100)
    got = apply_product_rule(factor_fn, grid, listener, r_mid, poles)
    np.testing.assert_allclose(got[0], want[0], rtol=1e-12, atol=1e-13 * np.abs(want[0]).max())
    np.testing.assert_allclose(got[1], want[1], rtol=1e-12)


@pytest.mark.parametrize("paired", [False, True])
def test_product_rule_agrees_with_the_rectangle_rule(paired):
    """product_gains (each panel's orders for its own acoustic phase, each mode refined
    alone) and rayleigh_gains of the same shapes converge and agree within 2 tol (each is
    within tol of the integral: the refinement test's bound), their in-phase bounds within
    5 % (|phi_k| has kinks on the nodal lines, which the two grids integrate differently),
    with fewer points for the first (the microphone 5 cm above the plate: the phase's rate
    falls under it)."""
    from synth.sound.radiation.rectangle import product_gains

    size, shape_fn, factor_fn, s, kb = _product_case(paired)
    settings = dict(max_wavenumber=kb, reference_distance=0.1, tol=1e-6)
    listener = (0.12, 0.07, 0.05)
    want = R.rayleigh_gains(shape_fn, size, listener, s, full_output=True, **settings)
    got = product_gains(factor_fn, size, listener, s, **settings)
    assert got.success and want.success
    allowed = 2e-6 * np.maximum(np.abs(want.gains), 1e-4 * want.coherent)
    assert np.all(np.abs(got.gains - want.gains) <= allowed)
    np.testing.assert_allclose(got.coherent, want.coherent, rtol=0.05)
    assert got.n_points < want.n_points


def _sheet_problem(side, f_max, max_points=None):
    """The radiation problem of a 1 mm steel sheet ``side`` x ``side`` m past the Ritz
    crossover to ``f_max`` Hz, microphone 0.3 m above its middle (nothing solved)."""
    from synth import Microphone, Plate
    from synth.cost import modal_count
    from synth.cost.estimates import radiation_problem

    plate = Plate("steel", thickness=0.001, length=side, width=side)
    microphone = Microphone((side / 2, side / 2, 0.3))
    return radiation_problem(plate, microphone, modal_count(plate, f_max), f_max, max_points)


def test_edge_effect_modes_take_the_banded_rule_and_state_its_bound():
    """Edge effect modes take the banded rule, the only rule of their shapes: its error
    bound is tol while its check rule fits max_points, and none (inf) below it, where it
    is still taken (it stops at max_points and says so)."""
    for side, f_max in ((1.0, 12000.0), (3.0, 24000.0), (5.0, 6000.0)):
        problem = _sheet_problem(side, f_max)
        assert problem.shapes == "edge"
        chosen = rules.choose_rule(problem)
        assert chosen.rule.name == "banded" and chosen.error_bound == problem.tol
    problem = _sheet_problem(1.0, 12000.0)
    cut = rules.BandedRule().counts(problem).points[1] - 1
    tight = rules.choose_rule(_sheet_problem(1.0, 12000.0, cut))
    assert tight.rule.name == "banded" and tight.error_bound == np.inf
