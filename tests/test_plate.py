"""Tests of synth.physics.modes: the finite plate's bending modes (docs/physics.md,
"Plate modes")."""

from __future__ import annotations

import functools
import math
import sys

import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss
from reference import ritz_frequencies

from synth.errors import ParameterError
from synth.physics import modes as P
from synth.physics.materials import LossFactor, Material, Rayleigh
from synth.physics.modes import cache as modes_cache
from synth.physics.modes import ritz
from synth.physics.scene import Plate

# A steel-like material with nu = 0.3, the Poisson ratio of the published tables.
STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    """Every test gets an empty memory cache and its own disk cache directory."""
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    P.clear_memory_cache()
    yield
    P.clear_memory_cache()


def _lam_scale(plate: Plate) -> float:
    """Leissa's frequency parameter per rad/s: lambda = omega a^2 sqrt(rho h / D)."""
    return plate.length**2 * math.sqrt(plate.surface_density / plate.flexural_rigidity)


def _modes_to_lambda(plate: Plate, lam_max: float, **kw):
    """Modes up to the frequency parameter ``lam_max``."""
    return P.modes(plate, max_frequency=lam_max / _lam_scale(plate) / (2 * math.pi), **kw)


def _gram(modes, n_nodes: int):
    """Int phi_k phi_l dA over the plate by an n_nodes^2 Gauss-Legendre rule."""
    x, w = leggauss(n_nodes)
    a, b = modes.plate.length, modes.plate.width
    xs, ys = 0.5 * a * (x + 1.0), 0.5 * b * (x + 1.0)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    W = np.outer(w, w).ravel() * (0.25 * a * b)
    phi = modes.shapes(np.column_stack([X.ravel(), Y.ravel()]))
    return phi.T @ (phi * W[:, None])


# --------------------------------------------------------------------------------------
# Simply supported: closed form
# --------------------------------------------------------------------------------------


def test_simply_supported_closed_form():
    plate = Plate(STEEL, 0.002, 0.53, 0.37, "simply-supported")
    fmax = 5000.0
    m = P.modes(plate, max_frequency=fmax)
    c = 0.5 * math.pi * math.sqrt(plate.flexural_rigidity / plate.surface_density)
    ref = sorted(
        c * ((i / 0.53) ** 2 + (j / 0.37) ** 2) for i in range(1, 60) for j in range(1, 60)
    )
    ref = np.array([f for f in ref if f <= fmax])
    # Closed form (Leissa 1969 eq. 4.21); the only error is rounding: 1e-9 relative.
    assert len(m) == ref.size
    np.testing.assert_allclose(m.frequencies, ref, rtol=1e-9)
    np.testing.assert_allclose(m.angular_frequencies, 2 * math.pi * ref, rtol=1e-9)
    assert m.tolerance == 0.0
    # Shapes are 2 sin(m pi x/a) sin(n pi y/b): identify (m, n) of each mode from
    # its frequency (no degeneracy for this aspect ratio) and compare to 1e-12.
    pts = np.array([[0.1, 0.05], [0.3, 0.2], [0.53, 0.11], [0.0, 0.37], [0.27, 0.3]])
    phi = m.shapes(pts)
    for k in range(len(m)):
        mm, nn = min(
            ((i, j) for i in range(1, 60) for j in range(1, 60)),
            key=lambda ij: abs(c * ((ij[0] / 0.53) ** 2 + (ij[1] / 0.37) ** 2) - m.frequencies[k]),
        )
        expect = 2 * np.sin(mm * np.pi * pts[:, 0] / 0.53) * np.sin(nn * np.pi * pts[:, 1] / 0.37)
        np.testing.assert_allclose(phi[:, k], expect, rtol=0, atol=1e-12)
    # Mean square 1 and modal mass rho h a b (invariants of the normalisation).
    np.testing.assert_allclose(m.modal_masses, plate.mass, rtol=1e-15)


@pytest.mark.parametrize("bad", [0.0, -100.0, math.nan, math.inf, -math.inf, "5000", None, True])
def test_simply_supported_closed_form_rejects_bad_max_frequency(bad):
    plate = Plate(STEEL, 0.002, 0.53, 0.37, "simply-supported")
    with pytest.raises(ParameterError, match="max_frequency"):
        P.modes(plate, max_frequency=bad)


# --------------------------------------------------------------------------------------
# Free and clamped: published values
# --------------------------------------------------------------------------------------


def test_free_square_leissa():
    plate = Plate(STEEL, 0.001, 0.3, 0.3, "free")
    m = _modes_to_lambda(plate, 40.0)
    lam = m.angular_frequencies * _lam_scale(plate)
    # Leissa 1969 (NASA SP-160) free square plate, nu = 0.3; 0.5 % covers the
    # rounding of the published values and their own method's error.
    np.testing.assert_allclose(lam, [13.47, 19.60, 24.27, 34.80, 34.80], rtol=5e-3)
    # The degenerate pair (modes odd in x / odd in y) is exactly degenerate by symmetry.
    assert abs(lam[3] - lam[4]) <= 1e-9 * lam[3]


@pytest.mark.parametrize("bad", [STEEL, "free", None, {"length": 0.3}, 0.3])
def test_free_square_leissa_rejects_non_plate(bad):
    with pytest.raises(ParameterError, match="plate"):
        P.modes(bad, max_frequency=1000.0)


def test_clamped_square_leissa():
    plate = Plate(STEEL, 0.001, 0.3, 0.3, "clamped")
    m = _modes_to_lambda(plate, 80.0)
    lam = m.angular_frequencies * _lam_scale(plate)
    # Leissa 1969 clamped square plate: 35.99, 73.41 (degenerate pair), within 0.5 %.
    np.testing.assert_allclose(lam, [35.99, 73.41, 73.41], rtol=5e-3)
    assert abs(lam[1] - lam[2]) <= 1e-9 * lam[1]


def test_clamped_square_leissa_rejects_band_too_large():
    # 1 GHz on a 0.3 m plate needs a dense eigenproblem far beyond memory: refused,
    # not clamped to a smaller band.
    plate = Plate(STEEL, 0.001, 0.3, 0.3, "clamped")
    with pytest.raises(ParameterError, match=r"max_frequency=1000000000.0 is too high"):
        P.modes(plate, max_frequency=1_000_000_000.0)


# Leissa 1973 (J. Sound Vib. 31, 257), nu = 0.3, lambda = omega a^2 sqrt(rho h / D) with
# a the side along x, for a / b = 0.4, 2/3, 1.5, 2.5: fundamental mode. His values are
# 36-term beam-function Ritz results, i.e. upper bounds.
CLAMPED_1973 = {0.4: 23.648, 2 / 3: 27.010, 1.5: 60.772, 2.5: 147.80}
FREE_1973 = {0.4: [3.463, 5.288, 9.622, 11.44], 2 / 3: [8.946, 9.602], 1.5: [20.128], 2.5: [21.643]}


@pytest.mark.parametrize("ratio", sorted(CLAMPED_1973))
def test_clamped_rectangle_leissa_1973(ratio):
    plate = Plate(STEEL, 0.001, 0.4 * ratio, 0.4, "clamped")
    m = _modes_to_lambda(plate, 1.05 * CLAMPED_1973[ratio])
    lam = m.angular_frequencies[0] * _lam_scale(plate)
    ref = CLAMPED_1973[ratio]
    # Beam functions suit clamped edges: his values are within 0.1 % of converged
    # ones, and above them (Ritz upper bounds).
    assert lam == pytest.approx(ref, rel=1e-3)
    assert lam <= ref * (1 + 1e-6)


@pytest.mark.parametrize("ratio", sorted(FREE_1973))
def test_free_rectangle_leissa_1973(ratio):
    plate = Plate(STEEL, 0.001, 0.4 * ratio, 0.4, "free")
    ref = np.array(FREE_1973[ratio])
    m = _modes_to_lambda(plate, 1.05 * ref[-1])
    lam = m.angular_frequencies[: ref.size] * _lam_scale(plate)
    # Beam functions have w'' = 0 at a free edge, which a free plate with nu != 0 does
    # not: his free-plate values converge slowly and lie up to 1 % high (his square
    # plate gives 13.489 against the converged 13.468). So: below his values, within 1.2 %.
    assert np.all(lam <= ref * (1 + 1e-6))
    np.testing.assert_allclose(lam, ref, rtol=1.2e-2)


def test_free_rectangle_leissa_1973_rejects_bad_cache_flag():
    plate = Plate(STEEL, 0.001, 0.6, 0.4, "free")
    with pytest.raises(ParameterError, match="cache"):
        P.modes(plate, max_frequency=1000.0, cache="yes")


# --------------------------------------------------------------------------------------
# Shapes: orthogonality, normalisation, evaluation paths
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("boundary", ["free", "clamped", "simply-supported"])
def test_shapes_orthonormal(boundary):
    plate = Plate(STEEL, 0.001, 0.5, 0.4, boundary)
    m = P.modes(plate, max_frequency=2000.0)
    assert len(m) > 30
    # Free / clamped shapes are polynomials of degree < 40 here (checked), which a
    # 60-node Gauss rule integrates exactly; sines of order < 15 to rounding.
    sol = m._solution
    if boundary != "simply-supported":
        assert max(int(ij[0].max()) for ij in sol.index) + 4 < 59
        assert max(int(ij[1].max()) for ij in sol.index) + 4 < 59
    g = _gram(m, 60)
    diag = np.diag(g)
    ab = plate.length * plate.width
    # Normalisation Int phi_k^2 dA = a b (mean square 1), to rounding.
    np.testing.assert_allclose(diag, ab, rtol=1e-10)
    # Orthogonality: eigenvectors of a symmetric matrix, different symmetry classes.
    off = np.abs(g - np.diag(diag)) / ab
    assert off.max() < 1e-8
    # Modal mass M_k = rho h Int phi_k^2 = rho h a b, consistent with the shapes.
    np.testing.assert_allclose(m.modal_masses, plate.surface_density * diag, rtol=1e-10)


def test_basis_normalisation_log_factorials_are_scipys_gammaln_to_the_bit():
    # The Jacobi basis' normalisation takes ln k! for k = alpha and 2 alpha + 1 (alpha 0 or
    # 4) without scipy.special: the same bits as gammaln(k + 1), so that the shapes, and
    # the renders, do not change with the module that computes it
    from scipy.special import gammaln

    from synth.physics.modes.basis import _log_factorial

    for k in range(12):
        assert _log_factorial(k) == gammaln(k + 1.0), k


def test_shapes_grid_equals_pointwise():
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "free")
    m = P.modes(plate, max_frequency=3000.0)
    xs, ys = np.linspace(0, 0.5, 17), np.linspace(0, 0.4, 13)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    grid = np.column_stack([X.ravel(), Y.ravel()])
    together = m.shapes(grid)  # shared sums along x (grid path)
    one_by_one = np.vstack([m.shapes(grid[i : i + 1]) for i in range(grid.shape[0])])
    # Same sums in another order: equal to rounding (shapes are O(1), up to ~4).
    np.testing.assert_allclose(together, one_by_one, rtol=0, atol=1e-11)
    # Symmetry classes: each mode is even or odd under x -> a - x (invariant).
    mirrored = m.shapes(np.column_stack([0.5 - grid[:, 0], grid[:, 1]]))
    parity = np.sign(np.sum(together * mirrored, axis=0))
    np.testing.assert_allclose(mirrored, together * parity, rtol=0, atol=1e-11)


@pytest.mark.parametrize(
    "points",
    [
        [[-1e-9, 0.1]],
        [[0.2, 0.4000001]],
        [[0.5 + 1e-12, 0.0]],
        [[0.1, 0.1], [0.2, -0.3]],
    ],
)
def test_shapes_rejects_points_off_plate(points):
    m = P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "free"), max_frequency=500.0)
    with pytest.raises(ParameterError, match=r"points\[\d+\]=.*off the plate"):
        m.shapes(points)


@pytest.mark.parametrize(
    "points",
    [
        [0.1, 0.1],
        [[0.1, 0.1, 0.0]],
        [[math.nan, 0.1]],
        [[0.1, math.inf]],
        "centre",
        [["a", "b"]],
    ],
)
def test_shapes_rejects_malformed_points(points):
    m = P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "free"), max_frequency=500.0)
    with pytest.raises(ParameterError, match="points"):
        m.shapes(points)


# --------------------------------------------------------------------------------------
# Convergence
# --------------------------------------------------------------------------------------


def test_ritz_values_decrease_monotonically_with_basis():
    # Nested bases (growing design band): Rayleigh-Ritz values are upper bounds that
    # can only decrease (Poincare / Courant-Fischer), up to rounding (1e-12 relative).
    omega_cut = 400.0
    runs = [
        ritz_frequencies("free", 0.3, 1.25, ob, omega_cut)[:25]
        for ob in (60.0, 120.0, 250.0, 500.0, 1000.0)
    ]
    for coarse, fine in zip(runs, runs[1:]):
        assert np.all(fine <= coarse * (1 + 1e-12))
    # ... towards a limit: the last step changes nothing beyond 1e-6, the first a lot.
    assert np.max(np.abs(runs[-1] / runs[-2] - 1)) < 1e-6
    assert np.max(runs[0] / runs[-1] - 1) > 1e-3


#: The convergence tests' plate and band: every mode below 3 kHz of a free 1 mm steel plate.
CONVERGED_PLATE = Plate(STEEL, 0.001, 0.5, 0.4, "free")
CONVERGED_FMAX = 3000.0


@functools.cache
def _converged_reference():
    """``(omega_req, values)``: the dimensionless band of CONVERGED_PLATE up to
    CONVERGED_FMAX, and the Ritz values up to 1.01 times it from a basis for 1.5 times it
    by a rule far larger than the engine's (c0 = 10, c1 = 3): the reference of both
    convergence tests, computed once (this file's largest solve)."""
    plate = CONVERGED_PLATE
    omega_req = (
        2 * math.pi * CONVERGED_FMAX * 0.5**2
        * math.sqrt(plate.surface_density / plate.flexural_rigidity)
    )  # fmt: skip
    values = ritz_frequencies("free", 0.3, 1.25, 1.5 * omega_req, 1.01 * omega_req, 10.0, 3.0)
    return omega_req, values


@pytest.mark.slow
def test_returned_modes_are_converged():
    plate = CONVERGED_PLATE
    fmax = CONVERGED_FMAX
    m = P.modes(plate, max_frequency=fmax)
    _, ref = _converged_reference()
    scale = math.sqrt(plate.flexural_rigidity / plate.surface_density) / 0.5**2
    ref_f = ref * scale / (2 * math.pi)
    ref_f = ref_f[ref_f <= fmax]
    # Every mode up to fmax, none above, each within the documented tolerance of a
    # much larger basis.
    assert len(m) == ref_f.size
    assert m.frequencies[-1] <= fmax
    np.testing.assert_allclose(m.frequencies, ref_f, rtol=P.TOLERANCE)
    assert np.all(np.diff(m.frequencies) >= 0)


def test_returned_modes_are_converged_rejects_bad_max_frequency_type():
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "free")
    with pytest.raises(ParameterError, match="max_frequency"):
        P.modes(plate, max_frequency=[3000.0])


@pytest.mark.slow
def test_unconverged_basis_is_enlarged(monkeypatch):
    # Starve the basis rule: the convergence check must notice, enlarge the basis
    # and still deliver every mode within the tolerance of a much larger basis (the
    # reference above: its band holds this one, its basis is at least as large).
    omega_req = 3000.0
    reference_band, ref = _converged_reference()
    assert reference_band >= omega_req
    monkeypatch.setattr(ritz, "_C0", 0.0)
    monkeypatch.setattr(ritz, "_C1", 0.5)
    sol = ritz.solve_ritz("free", 0.3, 1.25, omega_req)
    attempts = sol.info["attempts"]
    assert len(attempts) >= 2
    assert attempts[0]["worst_relative_change"] > P.TOLERANCE
    assert attempts[-1]["worst_relative_change"] <= P.TOLERANCE
    ref = ref[ref <= omega_req]
    assert sol.omega.size == ref.size
    np.testing.assert_allclose(sol.omega, ref, rtol=P.TOLERANCE)


def test_rigid_body_modes_excluded():
    plate = Plate(STEEL, 0.001, 0.3, 0.3, "free")
    m = _modes_to_lambda(plate, 20.0)
    lam = m.angular_frequencies * _lam_scale(plate)
    # The first returned mode is the first elastic one (13.47, Leissa 1969), not one
    # of the three zero-frequency rigid-body motions; 0.5 % as above.
    assert m.frequencies[0] > 0
    assert lam[0] == pytest.approx(13.47, rel=5e-3)
    np.testing.assert_allclose(lam, [13.47, 19.60], rtol=5e-3)


def test_rigid_body_modes_excluded_rejects_zero_band():
    with pytest.raises(ParameterError, match="max_frequency=0"):
        P.modes(Plate(STEEL, 0.001, 0.3, 0.3, "free"), max_frequency=0)


def test_band_below_first_mode_is_empty():
    m = P.modes(Plate(STEEL, 0.001, 0.3, 0.3, "free"), max_frequency=1.0)
    # The first elastic mode is at lambda = 13.47, i.e. about 50 Hz here: nothing below.
    assert len(m) == 0
    assert m.shapes([[0.1, 0.1]]).shape == (1, 0)


# --------------------------------------------------------------------------------------
# Damping
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("damping", [Rayleigh(35.0, 5e-7), LossFactor(0.02)])
def test_decay_rates_follow_damping_law(damping):
    mat = Material("damped", 700.0, 5.689e9, 0.4, damping)
    m = P.modes(Plate(mat, 0.018, 1.227, 0.49, "free"), max_frequency=3000.0)
    w = m.angular_frequencies
    expect = (
        0.5 * damping.alpha + 0.5 * damping.beta * w**2
        if isinstance(damping, Rayleigh)
        else 0.5 * damping.eta * w
    )
    # sigma = alpha/2 + beta omega^2/2 or eta omega/2 (docs/physics.md, "Plate modes"), to rounding.
    np.testing.assert_allclose(m.decay_rates, expect, rtol=1e-14)


def test_decay_rates_follow_damping_law_rejects_negative_max_frequency():
    mat = Material("damped", 700.0, 5.689e9, 0.4, Rayleigh(35.0, 5e-7))
    with pytest.raises(ParameterError, match="max_frequency=-3000"):
        P.modes(Plate(mat, 0.018, 1.227, 0.49, "free"), max_frequency=-3000.0)


def test_damping_does_not_change_eigen_solution():
    a = Material("a", 700.0, 5.689e9, 0.4, Rayleigh(35.0, 5e-7))
    b = Material("b", 700.0, 5.689e9, 0.4, LossFactor(0.05))
    m1 = P.modes(Plate(a, 0.018, 1.227, 0.49, "free"), max_frequency=2000.0)
    m2 = P.modes(Plate(b, 0.018, 1.227, 0.49, "free"), max_frequency=2000.0)
    # Same eigenproblem: solved once, reused (counter), identical frequencies.
    info = P.cache_info()
    assert info["solves"] == 1 and info["memory_hits"] == 1
    np.testing.assert_array_equal(m1.frequencies, m2.frequencies)
    assert not np.array_equal(m1.decay_rates, m2.decay_rates)


# --------------------------------------------------------------------------------------
# Cache
# --------------------------------------------------------------------------------------


def _cache_files(tmp_path):
    return sorted((tmp_path / "cache").glob("plate-modes-*.npz"))


def test_cache_memory_hit_and_lower_band():
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "free")
    m1 = P.modes(plate, max_frequency=3000.0)
    m2 = P.modes(plate, max_frequency=3000.0)
    info = P.cache_info()
    assert info["solves"] == 1 and info["memory_hits"] == 1
    np.testing.assert_array_equal(m1.frequencies, m2.frequencies)
    pts = [[0.1, 0.2], [0.33, 0.07]]
    np.testing.assert_array_equal(m1.shapes(pts), m2.shapes(pts))
    # A lower band is solved for itself, not cut from the stored wider one (whose larger
    # basis gives the same modes within the tolerance but not to the last bit): the very
    # arrays of a solve from an empty cache, whatever was solved before.
    m3 = P.modes(plate, max_frequency=1500.0)
    assert P.cache_info()["solves"] == 2
    assert m3.frequencies[-1] <= 1500.0 < m1.frequencies[len(m3)]
    np.testing.assert_allclose(m3.frequencies, m1.frequencies[: len(m3)], rtol=P.TOLERANCE)
    P.clear_memory_cache()
    cold = P.modes(plate, max_frequency=1500.0, cache=False)
    np.testing.assert_array_equal(m3.frequencies, cold.frequencies)
    np.testing.assert_array_equal(m3.shapes(pts), cold.shapes(pts))
    # A plate twice as thick at twice the frequency has the same dimensionless band:
    # reused, frequencies scaled by sqrt(D / rho h) ~ h.
    m4 = P.modes(Plate(STEEL, 0.002, 0.5, 0.4, "free"), max_frequency=6000.0)
    assert P.cache_info()["solves"] == 1 and P.cache_info()["disk_hits"] == 1
    np.testing.assert_allclose(m4.frequencies, 2 * m1.frequencies[: len(m4)], rtol=1e-14)


def test_cache_memory_hit_rejects_read_only_arrays():
    m = P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "free"), max_frequency=1000.0)
    # Cached results are shared between callers: their arrays cannot be written.
    with pytest.raises(ValueError):
        m.frequencies[0] = 1.0


def test_cache_disk_round_trip(tmp_path):
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "clamped")
    m1 = P.modes(plate, max_frequency=3000.0)
    assert len(_cache_files(tmp_path)) == 1
    P.clear_memory_cache()
    m2 = P.modes(plate, max_frequency=3000.0)
    info = P.cache_info()
    assert info["disk_hits"] == 1 and info["solves"] == 0
    np.testing.assert_array_equal(m1.frequencies, m2.frequencies)
    pts = [[0.1, 0.2], [0.33, 0.07], [0.5, 0.4]]
    np.testing.assert_array_equal(m1.shapes(pts), m2.shapes(pts))


def test_cache_memory_is_bounded(monkeypatch):
    # Least recently used solutions are dropped beyond the memory budget.
    monkeypatch.setattr(modes_cache.CACHE, "max_bytes", 1)
    P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "free"), max_frequency=500.0)
    P.modes(Plate(STEEL, 0.001, 0.5, 0.3, "free"), max_frequency=500.0)
    assert P.cache_info()["entries"] == 1


def test_cache_disk_round_trip_rejects_nothing_when_disabled(tmp_path):
    # cache=False neither reads nor writes: a fresh solve each time, no file.
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "free")
    P.modes(plate, max_frequency=1000.0, cache=False)
    P.modes(plate, max_frequency=1000.0, cache=False)
    info = P.cache_info()
    assert info["solves"] == 2 and info["memory_hits"] == 0 and info["entries"] == 0
    assert _cache_files(tmp_path) == []


@pytest.mark.parametrize("damage", ["garbage", "truncate", "wrong-key"])
def test_cache_corrupt_file_recovered(tmp_path, damage, damage_cache_file):
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "free")
    m1 = P.modes(plate, max_frequency=2000.0)
    (path,) = _cache_files(tmp_path)
    damage_cache_file(path, damage)
    P.clear_memory_cache()
    m2 = P.modes(plate, max_frequency=2000.0)
    # The bad file is ignored: solved again, same result, file rewritten and readable.
    assert P.cache_info()["solves"] == 1 and P.cache_info()["disk_hits"] == 0
    np.testing.assert_array_equal(m1.frequencies, m2.frequencies)
    P.clear_memory_cache()
    P.modes(plate, max_frequency=2000.0)
    assert P.cache_info()["disk_hits"] == 1


def test_cache_dir_follows_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert P.cache_dir() == tmp_path / "elsewhere"
    monkeypatch.delenv("SYNTH_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if sys.platform.startswith("linux"):
        assert P.cache_dir() == tmp_path / "xdg" / "synth"


def test_modes_repr_and_len():
    m = P.modes(Plate(STEEL, 0.001, 0.3, 0.3, "free"), max_frequency=500.0)
    assert len(m) == m.frequencies.size == m.decay_rates.size == m.modal_masses.size
    assert "free" in repr(m) and f"{len(m)} modes" in repr(m)


def test_shape_key_identifies_shapes():
    plate = Plate(STEEL, 0.001, 0.5, 0.4, "free")
    m1 = P.modes(plate, max_frequency=2000.0)
    m2 = P.modes(plate, max_frequency=2000.0)
    assert m1.shape_key == m2.shape_key
    pts = [[0.1, 0.2], [0.33, 0.07]]
    np.testing.assert_array_equal(m1.shapes(pts), m2.shapes(pts))
    # Another material of the same nu and E / rho has the same dimensionless band at the
    # same frequency: it reuses the solution, the same shapes under the same key (only a
    # solution of the very band is reused: see test_cache_memory_hit_and_lower_band).
    other = Material("other", 2 * STEEL.density, 2 * STEEL.young, 0.3, LossFactor(1e-4))
    m3 = P.modes(Plate(other, 0.001, 0.5, 0.4, "free"), max_frequency=2000.0)
    assert len(m3) == len(m1) and m3.shape_key == m1.shape_key
    np.testing.assert_array_equal(m3.shapes(pts), m1.shapes(pts))
    # Size, boundary, Poisson ratio, number of modes and the solution's band all count.
    keys = {
        m1.shape_key,
        P.modes(Plate(STEEL, 0.001, 0.5, 0.41, "free"), max_frequency=2000.0).shape_key,
        P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "clamped"), max_frequency=2000.0).shape_key,
        P.modes(
            Plate(Material("nu", 7800.0, 2.0e11, 0.25, LossFactor(1e-3)), 0.001, 0.5, 0.4, "free"),
            max_frequency=2000.0,
        ).shape_key,
        P.modes(plate, max_frequency=1500.0).shape_key,
        P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "simply-supported"), max_frequency=2000.0).shape_key,
    }
    assert len(keys) == 6
    # A band from the cache and a fresh solve of it are one solution: one key.
    assert (
        P.modes(plate, max_frequency=1500.0, cache=False).shape_key
        == P.modes(plate, max_frequency=1500.0).shape_key
    )


def test_shape_key_identifies_shapes_rejects_assignment():
    m = P.modes(Plate(STEEL, 0.001, 0.5, 0.4, "free"), max_frequency=500.0)
    with pytest.raises(AttributeError):
        m.shape_key = "something"
