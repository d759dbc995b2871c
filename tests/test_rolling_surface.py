"""Surface profiles: the roughness spectrum's statistics, reproducibility, bad input
(synth.physics.surface)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from synth import ParameterError
from synth.physics import surface

SPEC = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.7)


def test_spectrum_integrates_to_the_mean_square():
    """Int S(k) dk / 2 pi = sigma^2 (the density's normalisation), by quadrature to 1e-6."""
    from scipy.integrate import quad

    total, _ = quad(lambda k: SPEC.density(k) / math.pi, 0.0, np.inf, limit=400)
    assert total == pytest.approx(SPEC.rms_height**2, rel=1e-6)


def test_rough_profile_mean_square_matches_its_expectation():
    """The mean square of 64 seeded profiles against the spectral sum
    (``expected_mean_square``): within four standard errors of their mean."""
    kw = dict(length=0.01, spacing=2e-6)
    ms = np.array(
        [np.mean(surface.rough_profile(SPEC, seed=s, **kw).heights ** 2) for s in range(64)]
    )
    expected = surface.expected_mean_square(SPEC, **kw)
    assert abs(ms.mean() - expected) < 4.0 * ms.std(ddof=1) / math.sqrt(ms.size)
    # the grid holds almost all of the spectrum at this spacing (2 % of xi)
    assert expected == pytest.approx(SPEC.rms_height**2, rel=0.1)


def test_rough_profile_spectrum_matches_the_model():
    """The averaged periodogram of 32 profiles (Hann window) against S(k) over the 165
    wavenumbers between the roll-off and a tenth of Nyquist: the mean ratio within 5 %
    (32 x 165 chi-square ratios of two degrees of freedom: a standard error below 1 %; the
    window's leakage from the steeper low wavenumbers biases it by a few per cent at
    most), and the fitted log-log slope within 0.05 of the model's over the same band
    (which is within 10 % of the power law's -(2H + 1): (k xi)^2 / (1 + (k xi)^2) > 0.9)."""
    n, dx = 4096, 2e-6
    acc = np.zeros(n // 2 + 1)
    for s in range(32):
        h = surface.rough_profile(SPEC, length=(n - 1) * dx, spacing=dx, seed=s).heights
        acc += np.abs(np.fft.rfft(h * np.hanning(n))) ** 2
    window = np.sum(np.hanning(n) ** 2)
    psd = acc / 32 * dx / window  # two-sided density, m^3
    k = 2 * math.pi * np.fft.rfftfreq(n, dx)
    band = (k > 3.0 / SPEC.correlation_length) & (k < 0.1 * math.pi / dx)
    ratio = psd[band] / SPEC.density(k[band])
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.05)
    slope = np.polyfit(np.log(k[band]), np.log(psd[band]), 1)[0]
    model = np.polyfit(np.log(k[band]), np.log(SPEC.density(k[band])), 1)[0]
    assert slope == pytest.approx(model, abs=0.05)
    # the model's own slope there tends to the power law's -(2H + 1) from above
    assert -(2 * SPEC.hurst + 1) < model < -0.9 * (2 * SPEC.hurst + 1)


def test_rough_profile_is_reproducible_from_its_seed():
    a = surface.rough_profile(SPEC, length=0.01, spacing=2e-6, seed=11)
    b = surface.rough_profile(SPEC, length=0.01, spacing=2e-6, seed=11)
    c = surface.rough_profile(SPEC, length=0.01, spacing=2e-6, seed=12)
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    assert not a.heights.flags.writeable


def test_surface_rejects_bad_input():
    with pytest.raises(ParameterError, match="rms_height"):
        surface.RoughnessSpectrum(rms_height=-1.0, correlation_length=1e-4, hurst=0.5)
    with pytest.raises(ParameterError, match="hurst"):
        surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=1.5)
    with pytest.raises(ParameterError, match="seed"):
        surface.rough_profile(SPEC, length=0.01, spacing=1e-5, seed=-1)
    with pytest.raises(ParameterError, match="samples"):
        surface.rough_profile(SPEC, length=100.0, spacing=1e-6, seed=1)
    with pytest.raises(ParameterError, match="wavelength"):
        surface.sinusoidal_profile(amplitude=1e-6, wavelength=1e-5, length=0.01, spacing=1e-5)
    profile = surface.sinusoidal_profile(amplitude=1e-6, wavelength=1e-3, length=0.01,
                                         spacing=1e-5)  # fmt: skip
    with pytest.raises(ParameterError, match="radius"):
        surface.contact_envelope(profile, 0.0)
    with pytest.raises(ParameterError, match=r"heights\[2\]"):
        surface.Profile(np.array([0.0, 0.0, np.nan, 0.0]), 1e-5, "measured")
    with pytest.raises(ParameterError, match="heights"):
        surface.Profile(np.zeros((3, 3)), 1e-5, "measured")
    with pytest.raises(ParameterError, match="spacing"):
        surface.Profile(np.zeros(10), 0.0, "measured")


def _best_samples_by_full_scan(h, caps):
    """Every sample's best ``h_j - cap`` and its first sample, scanning every ``j`` within
    reach: the scan the envelope's pruned search must reproduce."""
    n, window = h.size, (caps.size - 1) // 2
    best, first = np.empty(n), np.empty(n, dtype=np.int64)
    for i in range(n):
        lo, hi = max(0, i - window), min(n - 1, i + window)
        g = h[lo : hi + 1] - caps[lo - i + window : hi - i + window + 1]
        first[i] = lo + int(np.argmax(g))  # argmax: the first of equal maxima
        best[i] = g[first[i] - lo]
    return best, first


@pytest.mark.parametrize("radius", [2e-4, 5e-3])
def test_envelope_search_skips_only_samples_that_cannot_win(radius):
    """The dilation's search, which skips runs of samples bounded below the best so far,
    finds every sample's best height and its first maximiser bit for bit as the full scan
    (a rough profile, and one with plateaus of equal heights, where ties decide)."""
    rough = surface.rough_profile(SPEC, length=0.02, spacing=2e-6, seed=3).heights
    plateaus = np.round(rough / 4e-7) * 4e-7
    for h in (rough, plateaus):
        span = float(np.ptp(h))
        window = min(int(math.ceil(math.sqrt(span * (2.0 * radius - span)) / 2e-6)) + 1, 400)
        caps = surface._cap_depths(2e-6, radius, window)
        best, first = np.empty(h.size), np.empty(h.size, dtype=np.int64)
        surface._best_samples(np.ascontiguousarray(h), caps, best, first)
        want_best, want_first = _best_samples_by_full_scan(h, caps)
        assert np.array_equal(best, want_best)
        assert np.array_equal(first, want_first)


@pytest.mark.parametrize("name", sorted(surface.MEASURED_ROUGHNESS))
def test_a_measured_surface_has_its_published_ra(name):
    """A profile of a measured surface's derived spectrum (``sigma = sqrt(pi/2) Ra``) over
    3000 correlation lengths has the published Ra as its mean absolute height: within 6 %,
    three standard deviations of that estimate (2 % over 12 seeds; the grid leaves out 0.2 %
    of the mean square)."""
    measured = surface.MEASURED_ROUGHNESS[name]
    xi = measured.correlation_length
    profile = surface.rough_profile(measured.spectrum(), length=3000 * xi, spacing=xi / 16, seed=1)
    assert np.mean(np.abs(profile.heights)) == pytest.approx(measured.ra, rel=0.06)
    assert measured.spectrum().hurst == surface.SELF_AFFINE_HURST == 0.85  # 3 - D_f, D_f 2.15


def test_the_measured_surfaces_are_those_of_the_docs_table():
    """docs/rolling.md's table of measured surfaces prints each entry's published Ra and
    cut-off and the derived sigma, xi and H (the figures the code uses, not typed apart)."""
    from pathlib import Path

    doc = (Path(__file__).parents[1] / "docs" / "rolling.md").read_text()
    for name, m in surface.MEASURED_ROUGHNESS.items():
        row = (
            f"| `{name}` | {m.ra * 1e6:.3g} | {m.cutoff * 1e3:.3g} | {m.rms_height * 1e6:.3g} "
            f"| {m.correlation_length * 1e6:.0f} | {surface.SELF_AFFINE_HURST:g} |"
        )
        assert row in doc, row


def test_the_thesis_rolling_preset_rolls_on_the_measured_mdf():
    """The thesis board's [rolling] roughness is the measured MDF's derived spectrum,
    printed in the preset to five significant digits."""
    import synth.io.presets

    scene = synth.io.presets.load_preset("thesis-steel10-mdf18-rolling")
    spectrum = surface.MEASURED_ROUGHNESS["mdf"].spectrum()
    assert scene.rolling.rms_height == pytest.approx(spectrum.rms_height, rel=1e-4)
    assert scene.rolling.correlation_length == pytest.approx(spectrum.correlation_length, rel=1e-4)
    assert scene.rolling.hurst == spectrum.hurst
