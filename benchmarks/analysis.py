"""``synth bench analysis``: the analysis of synthetic bounces the engine did not make (known
ticks, noise), its tick error and restitution error."""

from __future__ import annotations

import math
import time

import numpy as np

#: Modes of the benchmark's synthetic ticks: frequency (Hz), amplitude decay time (s),
#: relative amplitude; each file draws its own frequencies (+-3 %), decay times (+-20 %)
#: and phases.
_BOUNCE_MODES = (
    (620.0, 0.040, 1.0),
    (1370.0, 0.025, 0.8),
    (2450.0, 0.015, 0.7),
    (4100.0, 0.008, 0.5),
    (6900.0, 0.004, 0.4),
)


def synthetic_bounce(
    e: float,
    samplerate: int,
    *,
    t1: float = 0.15,
    n_ticks: int = 20,
    snr_db: float | None = None,
    seed: int = 0,
) -> tuple:
    """A bouncing sound with a known geometric restitution, not made by the engine.

    Bounce times ``T_n = t1 e^(n-1)`` (s); each tick is five damped sinusoids (0.6-7 kHz,
    decay times 4-40 ms) with amplitude proportional to the impact speed ``g T_n / 2``,
    started at its exact (sub-sample) onset. The seed draws the file's modal frequencies
    (+-3 %), decay times (+-20 %) and phases (the same for every tick: one impact point)
    and the noise. White noise at ``snr_db``: the mean power of the bouncing part (from
    the first onset to 50 ms after the last) over the noise power, dB, as in the tests.

    Parameters
    ----------
    e : float in (0, 1)
        Restitution, dimensionless.
    samplerate : int
        Hz.
    t1 : float > 0
        First bounce time, s.
    n_ticks : int >= 3
        Number of ticks.
    snr_db : float or None
        Signal-to-noise ratio, dB; ``None``: no noise.
    seed : int
        Random seed.

    Returns
    -------
    audio : ndarray of float64
    samplerate : int
        Hz.
    onsets : ndarray
        The true onsets, s.
    """
    rng = np.random.default_rng(seed)
    fs = samplerate
    T = t1 * e ** np.arange(n_ticks)
    onsets = 0.05 + np.r_[0.0, np.cumsum(T[:-1])]
    n = int((onsets[-1] + 0.3) * fs)
    x = np.zeros(n)
    base = np.array(_BOUNCE_MODES)
    freqs = base[:, 0] * rng.uniform(0.97, 1.03, base.shape[0])
    decays = base[:, 1] * rng.uniform(0.8, 1.2, base.shape[0])
    amps = base[:, 2]
    phase = rng.uniform(0.0, 2.0 * np.pi, base.shape[0])
    span = int(20 * decays.max() * fs)  # 20 decay times: < -170 dB, no audible cut
    for i, t0 in enumerate(onsets):
        speed = e**i
        k0 = int(np.ceil(t0 * fs))
        tt = np.arange(k0, min(n, k0 + span)) / fs - t0
        tick = np.sum(
            amps[:, None]
            * np.exp(-tt[None, :] / decays[:, None])
            * np.sin(2 * np.pi * freqs[:, None] * tt[None, :] + phase[:, None]),
            axis=0,
        )
        x[k0 : k0 + tt.size] += speed * tick
    if snr_db is not None:
        part = x[int(onsets[0] * fs) : int((onsets[-1] + 0.05) * fs)]
        p = np.mean(part**2)
        x = x + rng.standard_normal(n) * math.sqrt(p / 10 ** (snr_db / 10))
    return x, fs, onsets


def run_analysis(
    snrs=(None, 40.0, 30.0, 20.0, 10.0),
    restitutions=(0.6, 0.8, 0.9),
    seeds=10,
    samplerate: int = 48000,
) -> dict:
    """Accuracy of the recovered restitution (bounces 2-8) and onsets (ticks 1-8) against SNR.

    A true tick counts as found when a detected onset lies within 1 ms of it; the
    restitution and onset errors are over the found ticks only; a restitution the analysis
    flags as spanning a missed bounce (or otherwise impossible, its ``RESTITUTION_FLAGS``:
    withheld, no value) is counted apart, not as an error. A file in which nothing
    is detected (``AnalysisError``) counts all its ticks as missed.
    """
    from synth.analysis import AnalysisError, analyze
    from synth.analysis.report import RESTITUTION_FLAGS

    rows = []
    for snr in snrs:
        errs, onset_errs, found, missed, flagged = [], [], 0, 0, 0
        t0 = time.perf_counter()
        for e in restitutions:
            for seed in range(seeds):
                x, fs, onsets = synthetic_bounce(e, samplerate, snr_db=snr, seed=seed)
                try:
                    a = analyze(x, fs)
                except AnalysisError:  # no tick found at all: all missed
                    missed += 8
                    continue
                got = np.array([t.time for t in a.ticks])
                for i in range(8):
                    j = int(np.argmin(np.abs(got - onsets[i])))
                    if abs(got[j] - onsets[i]) > 1e-3:
                        missed += 1
                        continue
                    found += 1
                    onset_errs.append(got[j] - onsets[i])
                    tick = a.ticks[j]
                    if i < 2:
                        continue
                    if set(tick.flags) & set(RESTITUTION_FLAGS):
                        flagged += 1  # withheld: the analysis says why this is no bounce's
                    elif tick.restitution is not None:
                        errs.append(abs(tick.restitution - e) / e)
        n_files = len(restitutions) * seeds
        rows.append(
            dict(
                snr_db=snr,
                files=n_files,
                ticks_found=found,
                ticks_missed=missed,
                e_flagged=flagged,
                e_error_median=float(np.median(errs)) if errs else float("nan"),
                e_error_p95=float(np.percentile(errs, 95)) if errs else float("nan"),
                e_error_max=float(np.max(errs)) if errs else float("nan"),
                onset_error_rms_ms=float(np.sqrt(np.mean(np.square(onset_errs)))) * 1e3
                if onset_errs
                else float("nan"),
                seconds_per_file=(time.perf_counter() - t0) / n_files,
            )
        )
    return dict(samplerate=samplerate, restitutions=list(restitutions), rows=rows)


def format_analysis(result) -> str:
    """The table of :func:`run_analysis` (Markdown)."""
    lines = [
        f"synthetic bounces: e in {result['restitutions']}, {result['rows'][0]['files']} files "
        f"per SNR, bounces 2-8 (e) and ticks 1-8 (onsets), {result['samplerate']} Hz; SNR: "
        f"power of the bouncing part over the noise's; errors over the ticks found; e flagged: "
        f"restitutions the analysis flags (a bounce missed before them), not counted as errors",
        "| SNR (dB) | ticks found / missed | e flagged | e error, median | e error, 95th "
        "percentile | e error, max | onset error, RMS (ms) | analysis time per file (ms) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        snr = "no noise" if r["snr_db"] is None else f"{r['snr_db']:.0f}"
        lines.append(
            f"| {snr} | {r['ticks_found']} / {r['ticks_missed']} | {r['e_flagged']} | "
            f"{r['e_error_median']:.2e} | "
            f"{r['e_error_p95']:.2e} | {r['e_error_max']:.2e} | {r['onset_error_rms_ms']:.3f} | "
            f"{r['seconds_per_file'] * 1e3:.0f} |"
        )
    return "\n".join(lines)
