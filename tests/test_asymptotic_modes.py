"""Tests of synth.physics.asymptotic_modes (the dynamic edge effect method) and of the
crossover in synth.physics.modes that hands large free and clamped bands to it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss
from reference import ritz_frequencies

from synth.errors import ParameterError
from synth.physics import asymptotic_modes as AM
from synth.physics import modes as P
from synth.physics.asymptotic_modes import ritz as edge_ritz
from synth.physics.asymptotic_modes import roots
from synth.physics.materials import LossFactor, Material
from synth.physics.modes import crossover, ritz
from synth.physics.scene import Plate

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    P.clear_memory_cache()
    yield
    P.clear_memory_cache()


# Euler-Bernoulli beam roots k L (free-free elastic modes and clamped-clamped modes
# share them): cos(kL) cosh(kL) = 1 (Blevins, Formulas for Natural Frequency and Mode
# Shape, Table 8-1).
BEAM = [4.730040745, 7.853204624, 10.99560784, 14.13716549, 17.27875966]


@pytest.mark.slow
@pytest.mark.parametrize("free", [True, False])
def test_one_dimensional_roots_are_the_beam_roots_without_transverse_wavenumber(free):
    """With ``s_y = 0`` the one-dimensional equations are the beam's: its roots k L to
    1e-9 (closed-form beam limit)."""
    h = 0.5
    found = [math.sqrt(roots._root(n, 0.0, h, free, 0.3)) for n in range(2, 7)]
    np.testing.assert_allclose(found, BEAM, rtol=1e-9)


def test_one_dimensional_root_rejects_nothing_for_the_free_low_family():
    """Free index 0 (the beam-like family) with a transverse wavenumber: the root is the
    anticlastic one, ``s < 0``, and satisfies the equation."""
    so, h = 100.0, 0.05
    s = roots._root(0, so, h, True, 0.3)
    assert -2.0 * so < s < 0.0
    assert abs(roots._characteristic(s, so, h, True, False, 0.3)) < 1e-6 * so**2.5


def _hybrid(boundary, aspect, omega, low_unknowns=200):
    low = crossover.band_of_unknowns(aspect, low_unknowns, omega)
    low_band = ritz.solve_ritz(boundary, 0.3, aspect, low)
    edge = AM.solve(boundary, 0.3, aspect, omega)
    return crossover.HybridSolution(low_band, low, edge, omega)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("boundary", "aspect", "worst"),
    [
        ("clamped", 1.37, 5e-4),
        ("clamped", 18.4, 5e-4),
        ("free", 1.37, 5e-3),
        ("free", 18.4, 5e-3),
    ],
)
def test_edge_effect_frequencies_agree_with_ritz_in_their_overlap(boundary, aspect, worst):
    """Above a small Ritz low band (200 unknowns per class: the lowest 27 to 112 modes,
    where the method's corner and beam-like errors reach several per cent), every edge
    effect frequency (with the Rayleigh-Ritz step) agrees with the converged Ritz solution
    of the same rank: measured worst 0.012 % (clamped, the Rayleigh quotients of shapes
    that meet the clamped conditions) and 0.43 % (free); asserted 0.05 % and 0.5 % (the
    the stated target). Counts agree exactly (no mode lost or doubled at the seam)."""
    omega = 6000.0 if aspect < 2 else 40000.0
    hyb = _hybrid(boundary, aspect, omega)
    ref = ritz_frequencies(boundary, 0.3, aspect, omega * 1.05, omega)
    assert hyb.omega.size == ref.size
    err = np.abs(hyb.omega - ref) / ref
    assert np.all(err[: hyb.n_low] < 1e-4)  # the Ritz band itself
    assert np.max(err[hyb.n_low :]) < worst


@pytest.mark.slow
@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_square_pairs_split_by_the_rayleigh_ritz_step(boundary):
    """Square plate: the corners split the degenerate pairs ``(m, n)``, ``(n, m)`` of one
    symmetry class, which the edge effect method alone leaves equal (0.61 % from the
    nearest Ritz mode, free). With the 2 x 2 Rayleigh-Ritz step, measured 0.28 % (free)
    and 0.014 % (clamped); asserted 0.5 % (the the stated target) and 0.05 %, median 0.1 %.
    Counts may differ by the Ritz modes within 0.5 % of the band's top (a mode that close
    may fall on either side of the cut)."""
    hyb = _hybrid(boundary, 1.0, 6000.0)
    ref = ritz_frequencies(boundary, 0.3, 1.0, 6300.0, 6300.0)
    near_top = int(np.sum(np.abs(ref - 6000.0) <= 0.005 * 6000.0))
    ref = ref[ref <= 6000.0]
    assert abs(hyb.omega.size - ref.size) <= near_top
    assert hyb.edge.n_paired > 0.4 * hyb.omega.size
    a = hyb.omega[hyb.n_low :]
    j = np.searchsorted(ref, a).clip(1, ref.size - 1)
    near = np.where(np.abs(ref[j] - a) < np.abs(ref[j - 1] - a), ref[j], ref[j - 1])
    err = np.abs(a - near) / near
    assert np.max(err) < (5e-3 if boundary == "free" else 5e-4)
    assert np.median(err) < 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_paired_shapes_are_orthonormal(boundary):
    """The modes of the Rayleigh-Ritz step have mean square 1 and a pair's two modes are
    orthogonal: Gram matrix on a fine Gauss-Legendre grid (exact to about 1e-12 for these
    smooth shapes) within 1e-9 there, so the step's closed-form integrals agree with the
    quadrature. Other modes are orthogonal only as far as the method is exact (measured
    at most 0.44 %; asserted 1 %)."""
    sol = AM.solve(boundary, 0.3, 1.0, 1500.0)
    assert sol.n_paired > 0
    t, w = leggauss(40)
    edges = np.linspace(-1.0, 1.0, 17)
    xs = np.concatenate([0.5 * (lo + hi) + 0.5 * (hi - lo) * t for lo, hi in zip(edges, edges[1:])])
    ws = np.concatenate([0.5 * (hi - lo) * w for lo, hi in zip(edges, edges[1:])])
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    weight = np.outer(ws, ws).ravel() / 4.0
    n = sol.omega.size
    phi = sol.shapes(X.ravel(), Y.ravel(), n)
    gram = phi.T @ (phi * weight[:, None])
    np.testing.assert_allclose(np.diag(gram), 1.0, atol=1e-9)
    slot = {int(t): k for k, t in enumerate(sol.trial)}
    pairs = [(k, slot[int(u)]) for k, u in enumerate(sol.partner) if u >= 0 and int(u) in slot]
    assert pairs
    assert max(abs(gram[k, j]) for k, j in pairs) < 1e-9
    assert np.max(np.abs(gram - np.eye(n))) < 1e-2


def test_pairs_are_nearest_neighbours_of_one_class():
    """Pairing: ascending, each unpaired trial takes the next one of its class within the
    gap; a class's lone trial and trials farther apart stay alone."""
    omega = np.array([100.0, 100.5, 100.6, 101.0, 200.0, 200.1])
    cls = np.array([0, 1, 0, 0, 2, 3])
    partner = edge_ritz.near_pairs(omega, cls, 0.01)
    np.testing.assert_array_equal(partner, [2, -1, 0, -1, -1, -1])


@pytest.mark.slow  # the edge effect solve's kernels compile on its first use
@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_edge_effect_factors_have_unit_mean_square(boundary):
    """Each factor ``X_k`` has mean square 1 on [-1, 1] (64-point Gauss-Legendre panels,
    exact to 1e-9 for these smooth functions): the modal mass stays ``rho h a b``."""
    sol = AM.solve(boundary, 0.3, 1.6, 3000.0)
    t, w = leggauss(64)
    edges = np.linspace(-1.0, 1.0, 9)
    xs = np.concatenate([0.5 * (lo + hi) + 0.5 * (hi - lo) * t for lo, hi in zip(edges, edges[1:])])
    ws = np.concatenate([0.5 * (hi - lo) * w for lo, hi in zip(edges, edges[1:])])
    fx, fy = sol.factors(xs, xs, sol.omega.size)
    np.testing.assert_allclose(ws @ fx**2 / 2.0, 1.0, rtol=1e-9)
    np.testing.assert_allclose(ws @ fy**2 / 2.0, 1.0, rtol=1e-9)


@pytest.mark.slow  # the edge effect solve's kernels compile on its first use
def test_clamped_edge_effect_shapes_vanish_on_the_edges():
    """Clamped factors satisfy ``X(+-1) = 0`` (the edge condition, to rounding)."""
    sol = AM.solve("clamped", 0.3, 1.6, 3000.0)
    fx, fy = sol.factors(np.array([-1.0, 1.0]), np.array([-1.0, 1.0]), sol.omega.size)
    assert np.max(np.abs(fx)) < 1e-9 and np.max(np.abs(fy)) < 1e-9


@pytest.mark.slow
def test_crossover_keeps_small_bands_on_ritz_and_hands_large_ones_over():
    """A band within the crossover is the Ritz solution; a large one is the hybrid, whose
    modes are ascending, below the band, and whose tolerance is stated."""
    small = P.modes(Plate(STEEL, 0.002, 0.3, 0.2, "clamped"), max_frequency=5000.0)
    assert small.tolerance == P.TOLERANCE
    big = P.modes(Plate(STEEL, 0.001, 1.5, 1.0, "free"), max_frequency=11025.0)
    assert big.tolerance == P.EDGE_EFFECT_TOLERANCE
    f = big.frequencies
    assert len(big) > 3000 and np.all(np.diff(f) >= 0.0) and f[-1] <= 11025.0
    # the seam: the first modes are the Ritz ones
    assert big._solution.n_low > 100
    phi = big.shapes(np.array([[0.3, 0.2], [1.1, 0.7]]))
    assert phi.shape == (2, len(big)) and np.all(np.isfinite(phi))


def test_crossover_rejects_absurd_band():
    """A band of more than two million modes is refused, naming the count."""
    plate = Plate(STEEL, 0.001, 2.0, 2.0, "free")
    with pytest.raises(ParameterError, match=r"modes, more than 2000000"):
        P.modes(plate, max_frequency=5e7)


def test_every_preset_band_stays_below_the_crossover():
    """The crossover only sets the cost (every crossed-over plate has its edge effect modes
    above the same low band), and it lies above every free or clamped preset's band to the
    Nyquist frequency at 48 kHz (or the preset's own rate if higher): their modes, and so
    their recorded renders, are the Ritz ones."""
    from synth.io import presets

    for name, path in presets.available().items():
        scene, options = presets.scene_from_dict(presets.read(path))
        plate = scene.plate
        if plate.boundary == "simply-supported":
            continue
        length = max(plate.length, plate.width)
        omega = (
            math.pi
            * max(options.get("samplerate", 48000), 48000)
            * length**2
            * math.sqrt(plate.surface_density / plate.flexural_rigidity)
        )
        unknowns = ritz.ritz_unknowns(plate.length / plate.width, omega)
        assert unknowns <= crossover.CROSSOVER_UNKNOWNS, (name, unknowns)
