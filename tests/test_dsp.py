"""Tests of synth.dsp: linear prediction, the Schur-Cohn test and the noise floor shared by the
analysis and the alteration of recordings."""

import numpy as np
import pytest

from synth import dsp


def test_covariance_matrix_over_blocks_is_the_direct_sum():
    # C[i, j] = sum over the targets n of the blocks of x[n-i] x[n-j]: the FFT row and the
    # edge recursion equal the direct sums to rounding (1e-12 of the zero lag).
    x = np.random.default_rng(1).normal(size=3000)
    p = 11
    blocks = [(40, 700), (900, 905), (1500, 2999)]
    n = np.concatenate([np.arange(a, b) for a, b in blocks])
    direct = np.array([[np.dot(x[n - i], x[n - j]) for j in range(p + 1)] for i in range(p + 1)])
    C = dsp.covariance_matrix(x, p, blocks)
    assert np.allclose(C, direct, rtol=0.0, atol=1e-12 * direct[0, 0])
    assert np.array_equal(C, C.T)


def test_is_minimum_phase_agrees_with_the_roots():
    # The step-down recursion says whether every root lies inside the unit circle: the same
    # answer as the roots themselves, for polynomials built from known roots.
    rng = np.random.default_rng(2)
    for _ in range(50):
        radius = rng.uniform(0.2, 1.2, 4)
        angle = rng.uniform(0.1, 3.0, 4)
        roots = np.concatenate([radius * np.exp(1j * angle), radius * np.exp(-1j * angle)])
        if np.any(np.abs(np.abs(roots) - 1.0) < 1e-3):
            continue
        a = np.real(np.poly(roots))
        assert dsp.is_minimum_phase(a) == bool(np.all(np.abs(roots) < 1.0))
    assert dsp.is_minimum_phase(np.array([1.0]))


def test_levinson_recovers_an_autoregressive_process():
    # An AR(2) process x[n] = 1.6 x[n-1] - 0.8 x[n-2] + w[n] has the autocorrelation of the
    # Yule-Walker equations; the predictor from its first lags is [1, -1.6, 0.8], off only by
    # the -90 dB white-noise correction (well under 1e-6 for this conditioning).
    a1, a2 = 1.6, -0.8
    rho1 = a1 / (1.0 - a2)
    r = [1.0, rho1]
    for _ in range(3):
        r.append(a1 * r[-1] + a2 * r[-2])
    a = dsp.levinson_predictor(dsp.white_noise_corrected(np.array(r)))
    assert a == pytest.approx([1.0, -a1, -a2, 0.0, 0.0], abs=1e-6)


def test_autocorrelation_predictor_sums_blocks_exactly():
    # Over more than one FFT block (65536 samples) the autocorrelation is exact: the same
    # predictor as from the direct lag sums (to rounding).
    rng = np.random.default_rng(3)
    x = np.convolve(rng.normal(size=70000), [1.0, 0.5, 0.25])[:70000]
    p = 6
    full = np.array([x[: x.size - k] @ x[k:] for k in range(p + 1)])
    want = dsp.levinson_predictor(dsp.white_noise_corrected(full))
    assert dsp.autocorrelation_predictor(x, p) == pytest.approx(want, abs=1e-10)


def test_noise_floor_is_the_noise_under_ticks():
    # White noise of RMS 0.01 with loud decaying bursts over a third of the recording: the
    # frames within 3 dB of the quietest are noise alone, and their RMS is the noise's (a
    # 10 ms frame at 48 kHz scatters by sqrt(2 / 480) = 6 % in power: within 5 % over all).
    fs = 48000
    rng = np.random.default_rng(4)
    x = 0.01 * rng.normal(size=fs)
    t = np.arange(fs // 10) / fs
    for start in (0.1, 0.4, 0.7):
        i = int(start * fs)
        x[i : i + t.size] += np.exp(-t / 0.01) * np.sin(2 * np.pi * 900 * t)
    assert dsp.noise_floor(x, fs) == pytest.approx(0.01, rel=0.05)
    quiet = dsp.quiet_frames(
        np.array([1.0, 1.9, 2.1, 0.0, 50.0]), among=np.array([True, True, True, False, True])
    )
    assert list(quiet) == [True, True, False, False, False]
