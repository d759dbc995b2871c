"""The rectangle rule band by band of wavenumber (plate_gains of a plate with dynamic edge
effect modes below the boundary rule's work threshold): each band's rule follows its own
fastest mode, and every gain still agrees with one rectangle rule for all the modes."""

from __future__ import annotations

import numpy as np
import pytest

from synth.physics.materials import LossFactor, Material
from synth.physics.scene import Plate
from synth.sound import modes as P
from synth.sound import radiation as R
from synth.sound.modes import crossover

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))


def test_wavenumber_bands_cover_the_modes_within_the_ratio():
    """Bands of a non-decreasing sequence are consecutive, cover every mode once, and hold
    the modes whose wavenumbers lie within the ratio of the band's first one."""
    kappa = np.cumsum(np.random.default_rng(1).uniform(0.0, 1.0, 500)) + 10.0
    bands = R._wavenumber_bands(kappa, 1.25)
    assert bands[0][0] == 0 and bands[-1][1] == kappa.size
    assert all(a[1] == b[0] for a, b in zip(bands[:-1], bands[1:]))
    for lo, hi in bands:
        assert hi > lo and kappa[hi - 1] <= 1.25 * kappa[lo]
    for a, b in zip(bands[:-1], bands[1:]):
        assert kappa[b[0]] > 1.25 * kappa[a[0]]  # a band ends at the first mode beyond
    assert R._wavenumber_bands(kappa, np.inf) == [(0, kappa.size)]
    assert R._wavenumber_bands(np.zeros(0), 1.25) == []


@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_banded_rectangle_rule_agrees_with_one_rule(monkeypatch, boundary):
    """A small plate past a lowered Ritz crossover (a few Ritz modes, then edge effect
    modes), the boundary rule never taken: plate_gains (rule "rectangle", several bands)
    converges and agrees with rayleigh_gains of every mode on one rule within 2 tol (each
    is within tol of the integral: the refinement test's bound); its in-phase bounds within
    10 % (they bound |H_k| and set the tolerance floor; |phi_k| has kinks on the nodal
    lines, which the two grids integrate differently)."""
    monkeypatch.setattr(P, "CROSSOVER_UNKNOWNS", 80)
    monkeypatch.setattr(crossover, "_LOW_BAND_UNKNOWNS", 50)
    monkeypatch.setattr(R, "BOUNDARY_RULE_WORK", np.inf)
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
    assert res.rule == "rectangle" and res.success, res.message
    assert "bands of wavenumber" in res.message and not res.message.startswith("1 bands")
    full = R.rayleigh_gains(
        m.shapes, (0.3, 0.2), listener, s, max_wavenumber=kb, tol=tol, full_output=True
    )
    allowed = 2 * tol * np.maximum(np.abs(full.gains), 1e-4 * full.coherent)
    assert np.all(np.abs(res.gains - full.gains) <= allowed)
    np.testing.assert_allclose(res.coherent, full.coherent, rtol=0.1)
