"""Tests of synth.sound.radiation.summed_gains: the Rayleigh integral of free and clamped
plates' Ritz shapes (sums of products X_i(x) Y_j(y)) by the polar rule about the
microphone, checked against the rectangle rule of rayleigh_gains; the crossover of
plate_gains; the Ritz solve on one BLAS thread."""

from __future__ import annotations

import numpy as np
import pytest

from synth.errors import ParameterError
from synth.physics import modes as P
from synth.physics.materials import LossFactor, Material
from synth.physics.modes import ritz
from synth.physics.scene import Plate
from synth.sound import radiation as R

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))


#: every test gets empty memory caches and its own disk cache directory
pytestmark = pytest.mark.usefixtures("empty_caches")


def _modes(boundary="free", a=0.3, b=0.2, h=0.002, max_frequency=5000.0, cache=True):
    return P.modes(Plate(STEEL, h, a, b, boundary), max_frequency=max_frequency, cache=cache)


def _poles(m):
    s = -m.decay_rates + 1j * m.angular_frequencies
    kb = (
        m.angular_frequencies.max() ** 2 * m.plate.surface_density / m.plate.flexural_rigidity
    ) ** 0.25
    return s, kb


def test_summed_shapes_equal_shapes():
    """combine() of the factors' products at single points is the shape there."""
    for boundary in ("free", "clamped"):
        m = _modes(boundary)
        sh = m.summed()
        assert sh.n_modes == len(m)
        pts = np.random.default_rng(1).uniform([0, 0], [0.3, 0.2], (40, 2))
        sums = sh.x_values(pts[:, 0])[:, :, None] * sh.y_values(pts[:, 1])[:, None, :]
        ref = m.shapes(pts)
        assert np.allclose(sh.combine(sums), ref, rtol=0, atol=1e-12 * np.abs(ref).max())
        assert np.array_equal(sh.values(pts), ref)
    ss = _modes("simply-supported")
    assert ss.summed() is None


# Microphone above the middle, off the middle and close (the 1/R peak), above an edge's
# line, outside the plate.
LISTENERS = [
    ("free", (0.15, 0.1, 0.2)),
    ("free", (0.08, 0.13, 0.02)),
    ("clamped", (0.3, 0.0, 0.1)),
    ("free", (0.5, -0.2, 0.05)),
]


@pytest.mark.slow
@pytest.mark.parametrize("boundary, listener", LISTENERS)
def test_summed_rule_equals_rectangle_rule(boundary, listener):
    """Both rules estimate the same integral to tol (relative to max(|H|, 1e-4 S)): they
    differ by at most the sum of their errors, 2 tol, here with tol = 1e-6 (measured:
    1e-10). The in-phase bound S_k of the polar rule comes from a rectangle rule that
    resolves the shapes but not the acoustic phase (|phi| has kinks on the nodal lines):
    within 5 % of the rectangle rule's at tol = 1e-9 (itself within 1 %)."""
    m = _modes(boundary)
    s, kb = _poles(m)
    mirror = -np.conj(s)
    r0 = R.distance(listener, (0.15, 0.1))
    kw = dict(max_wavenumber=kb, reference_distance=r0, full_output=True)
    rect = R.rayleigh_gains(m.shapes, (0.3, 0.2), listener, mirror, **kw)
    polar = R.summed_gains(m.summed(), listener, mirror, **kw)
    assert rect.success and polar.success and polar.rule == "polar"
    scale = np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
    assert np.max(np.abs(polar.gains - rect.gains) / scale) <= 2e-6
    fine = R.rayleigh_gains(m.shapes, (0.3, 0.2), listener, mirror, **kw, tol=1e-9)
    assert np.allclose(polar.coherent, fine.coherent, rtol=0.05)


def test_plate_gains_crossover(monkeypatch):
    """A free plate's Ritz modes by the rectangle rule and by the summed polar rule (each
    alone in choose_rule's list) agree within 2 tol (each within tol of the integral);
    the summed rule's gains are cached on disk under its own key."""
    from synth.sound.radiation import rules

    m = _modes()
    s, kb = _poles(m)
    listener = (0.1, 0.05, 0.2)
    monkeypatch.setattr(rules, "RULES", (rules.RectangleRule(),))
    res = R.plate_gains(m, listener, s, max_wavenumber=kb, full_output=True)
    assert res.rule == "rectangle"
    monkeypatch.setattr(rules, "RULES", (rules.SummedRule(),))
    polar = R.plate_gains(m, listener, s, max_wavenumber=kb, full_output=True)
    assert polar.rule == "polar" and polar.success
    scale = np.maximum(np.abs(res.gains), 1e-4 * res.coherent)
    assert np.max(np.abs(polar.gains - res.gains) / scale) <= 2e-6
    R.clear_memory_cache()
    loaded = R.plate_gains(m, listener, s, max_wavenumber=kb, full_output=True)
    assert loaded.rule == "polar" and np.array_equal(loaded.gains, polar.gains)
    assert R.cache_info()["disk_hits"] == 1


def test_summed_gains_bad_input():
    m = _modes()
    s, kb = _poles(m)
    with pytest.raises(ParameterError, match="shapes"):
        R.summed_gains(m.shapes, (0.1, 0.1, 0.1), s, max_wavenumber=kb)
    with pytest.raises(ParameterError, match="poles"):
        R.summed_gains(m.summed(), (0.1, 0.1, 0.1), s[:-1], max_wavenumber=kb)
    with pytest.raises(ParameterError, match="listener_position.z"):
        R.summed_gains(m.summed(), (0.1, 0.1, 0.0), s, max_wavenumber=kb)


def test_one_thread_ritz_solve_equals_threaded(monkeypatch):
    """The Ritz solve on one BLAS thread (large classes) gives the same modes as with
    BLAS's threads, to rounding: frequencies to 1e-12 relative, shapes to 1e-9 of their
    peak (a shape is defined up to rounding of its eigenvector)."""
    ref = _modes("clamped", max_frequency=8000.0, cache=False)
    monkeypatch.setattr(ritz, "ONE_THREAD_UNKNOWNS", 0)
    one = _modes("clamped", max_frequency=8000.0, cache=False)
    assert len(one) == len(ref)
    np.testing.assert_allclose(one.frequencies, ref.frequencies, rtol=1e-12)
    pts = np.random.default_rng(2).uniform([0, 0], [0.3, 0.2], (30, 2))
    a, b = one.shapes(pts), ref.shapes(pts)
    sign = np.sign(np.sum(a * b, axis=0))
    assert np.max(np.abs(a * sign - b)) <= 1e-9 * np.abs(b).max()


def test_combine_of_some_modes_equals_their_columns():
    """combine(sums, modes) gives the columns ``modes`` of combine(sums) (the same dot
    products, up to the rounding of BLAS's blocking: 1e-13 of the largest value)."""
    sh = _modes("free").summed()
    sums = np.random.default_rng(3).normal(size=(7, sh.n_x, sh.n_y))
    every = sh.combine(sums)
    some = np.array([0, 3, 4, 17, sh.n_modes - 1])
    assert np.allclose(
        sh.combine(sums, some), every[:, some], rtol=0, atol=1e-13 * np.abs(every).max()
    )


def test_summed_rule_refines_only_the_failing_modes(monkeypatch):
    """For this microphone the summed rule needs a second refinement: the rules after the
    first check take only the modes still failing, and the gains still agree with the
    rectangle rule within 2 tol (tol = 1e-6)."""
    from synth.sound.radiation import polar

    m = _modes("free")
    s, kb = _poles(m)
    listener = (0.2, 0.15, 0.4)
    sizes = []
    apply = polar._apply_summed_rule

    def recorded(*args):
        sizes.append(args[-1].size)
        return apply(*args)

    monkeypatch.setattr(polar, "_apply_summed_rule", recorded)
    polar = R.summed_gains(m.summed(), listener, s, max_wavenumber=kb, full_output=True)
    assert polar.success and polar.refinements >= 2
    assert sizes[:2] == [len(m), len(m)] and 0 < sizes[2] < len(m)
    rect = R.rayleigh_gains(m.shapes, (0.3, 0.2), listener, s, max_wavenumber=kb, full_output=True)
    scale = np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
    assert np.max(np.abs(polar.gains - rect.gains) / scale) <= 2e-6
