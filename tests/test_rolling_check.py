"""The rolling's validation figures (benchmarks.rolling_check; docs/validation.md,
"Rolling"): energy balances and the spectral centroid's rise with speed."""

from __future__ import annotations

import pytest

from benchmarks import rolling_check


@pytest.mark.slow
def test_energy_balance_of_rolling_with_and_without_losses():
    """The energy's change equals the drive's work less what the contact's loss, the plate
    and the rolling resistance take: the contact solver's local tolerance (1e-6 per step)
    leaves a residual far below 1e-3 of the largest term. Without loss on a rigid plate
    nothing is lost; the impedance takes energy; Hunt-Crossley loses some; the path's
    resistance does work."""
    rows = {r["case"].split(" (")[0]: r for r in rolling_check.energy_rows()}
    for name, r in rows.items():
        assert r["residual"] < 1e-3, name
    lossless = rows["elastic, rigid plate"]
    assert lossless["loss"] == 0.0 and lossless["plate"] == 0.0
    assert lossless["change"] == pytest.approx(lossless["supplied"], rel=1e-3)
    assert rows["elastic, plate impedance"]["plate"] > 0.0
    assert rows["Hunt-Crossley, rigid plate"]["loss"] > 0.0
    path = rows["path of thesis-steel10-mdf18-rolling"]
    assert path["resistance"] > 0.0 and path["change"] < 0.0


@pytest.mark.slow
def test_spectral_centroid_rises_with_speed():
    """One profile swept at a higher speed puts its features at higher frequencies
    (f = v k / 2 pi): the force's and the acceleration's centroids rise at each doubling of
    the speed."""
    rows = rolling_check.centroid_rows(speeds=(0.05, 0.1, 0.2, 0.4), seconds=0.25)
    for key in ("force_centroid", "acceleration_centroid"):
        values = [r[key] for r in rows]
        assert all(b > a for a, b in zip(values, values[1:])), (key, values)


def test_spectral_centroid_of_a_sinusoid_is_its_frequency():
    """The centroid's estimator on a pure tone (1 kHz, 0.1 s at 48 kHz, Hann window): its
    frequency within the window's spread over whole bins (a 10 Hz bin: 1 %)."""
    import numpy as np

    t = np.arange(4800) / 48000
    assert rolling_check.spectral_centroid(np.sin(2e3 * np.pi * t), 48000) == pytest.approx(
        1000.0, rel=1e-2
    )


@pytest.mark.slow
def test_spectral_centroid_falls_with_ball_size():
    """A larger ball bridges more of the roughness and rests on a softer contact (its
    natural frequency falls as R^(-5/6)): at one speed the force's and the acceleration's
    centroids fall at each doubling of the radius."""
    rows = rolling_check.centroid_rows(speeds=(0.1,), seconds=0.25, radii=rolling_check.SIZE_RADII)
    for key in ("force_centroid", "acceleration_centroid"):
        values = [r[key] for r in rows]
        assert all(b < a for a, b in zip(values, values[1:])), (key, values)


def _beyond_the_spread(a, b, key) -> float:
    """``b``'s figure less ``a``'s, less the sum of the two means' standard errors (their
    spread over the rough profiles / sqrt(profiles)): positive when the change outruns the
    profile draw."""
    error = (a[f"{key}_spread"] + b[f"{key}_spread"]) / a["profiles"] ** 0.5
    return b[key] - a[key] - error


@pytest.mark.slow
def test_rolling_sound_follows_the_published_measurement_of_speed_and_size():
    """Houben, Kohlrausch & Hermes (2004) recorded wooden balls rolling on a wooden plate:
    the faster ball's sound lies higher and is louder, the larger ball's lies lower. The
    engine's microphone signal of oak balls on MDF of the measured roughness (0.5 s each,
    means over eight rough profiles of the one spectrum) follows each direction at each
    doubling of the speed and of the radius, by more than the two means' standard errors
    (the figures' spread over the profiles / sqrt(8)): the trend is the physics', not the draw's."""
    rows = rolling_check.published_rows()
    for radius in rolling_check.PUBLISHED_RADII:
        line = [r for r in rows if r["radius"] == radius]
        for a, b in zip(line, line[1:]):
            assert _beyond_the_spread(a, b, "centroid") > 0.0, (radius, a, b)
            assert _beyond_the_spread(a, b, "level") > 0.0, (radius, a, b)
    for v in rolling_check.PUBLISHED_SPEEDS:
        column = [r for r in rows if r["speed"] == v]
        for small, large in zip(column, column[1:]):
            assert _beyond_the_spread(large, small, "centroid") > 0.0, (v, small, large)
