"""Recordings of bouncing sounds the engine did not make: the Sound Design Toolkit's bouncing
ball (Hunt-Crossley contact on a modal resonator, fixed restitution), with noise at -30 and
-40 dB, in a synthetic room (RT60 0.4 and 0.6 s) and through OGG/Vorbis. The files and their
truth are in tests/data/sdt/, made by tests/data/make_sdt_recordings.py.

What the analysis should do on them: find every tick that clearly stands out (its peak over
the first millisecond at least :data:`STANDS_OUT_DB` over the peak of the :data:`BEFORE`
before it; strikes closer than the analysis' ``min_separation`` to the previous one, the
chatter of a ball coming to rest, are one burst, found as one tick), report no tick that is
not one of SDT's strikes (from the strike, less :data:`EARLY`, to the end of its first contact
plus :data:`LATE`) and give SDT's restitution. What it still gets wrong is listed in
:data:`KNOWN_FALSE` and :data:`KNOWN_MISSED` with the cause found, so that a change shows both
ways; ``python tests/test_recordings_sdt.py`` prints, per recording, the strikes missed, the
ticks that are no strike and the restitutions, from :func:`strike_report`.

The truth is SDT's strikes (the velocity impulses of its ``Bouncing`` control), not every
contact: between strikes SDT's hammer stays on the resonator's ringing surface, in contact for
26 to 68 % of the samples after the first strike (its velocity changes there: the contact
force is not zero), in runs of contact at every sample and of separate one-sample contacts, so
its contact force changes where no strike is, and some strikes begin a contact that lasts
rather than a blow.
"""

from __future__ import annotations

import functools
import inspect
import json
import math
from pathlib import Path

import numpy as np
import pytest

from synth.analysis import analyze, analyze_file
from synth.analysis.report import GROWN_BOUNCE
from synth.store.audio import read_audio

DATA = Path(__file__).parent / "data" / "sdt"
NAMES = sorted(p.stem for p in DATA.glob("*.json"))
STANDS_OUT_DB = 6.0
BEFORE = 0.003
#: A tick may start this much before its strike, s: the onset is the level crossing of the
#: whitened burst, to within a few sample periods (docs/analysis.md, step 4), 0.1 ms at
#: 44.1 kHz ...
EARLY = 0.0001
#: ... and this much after the end of the contact, s: weak ticks (``strength`` of a few dB)
#: start late where what the whitening leaves of the earlier ringing hides the start of their
#: burst (docs/analysis.md, Method), as in tests/test_recordings_scenes.py; the strikes
#: that stand out are over 1 ms apart, so no other strike lies within this.
LATE = 0.00025
#: Strikes closer than this to the previous one are one burst (s): the analysis' default
#: ``min_separation``, below which it does not split ticks.
MIN_SEPARATION = inspect.signature(analyze).parameters["min_separation"].default
#: Restitution from bounce times, relative: SDT's flights shrink by exactly ``e``, and the
#: bounce time ``t_n`` is known to twice the onset tolerance over bounces of 40 ms or more.
RESTITUTION_RTOL = 0.02


#: Ticks reported where SDT has no strike, s (rounded to 0.1 ms), and why.
KNOWN_FALSE = {
    "glass-room": [],
    # a real contact event that no strike in the truth marks: SDT's hammer, in separate
    # one-sample contacts since 0.5251 s (after the strike at 0.5250 s), lands at 0.64864 s
    # in a contact that lasts 192 samples (4.4 ms, force at every sample, as strong as the
    # one-sample contacts' strongest); it does not clearly stand out (the recording's peak over
    # its first millisecond is 2.1 dB under that of the 3 ms before), so it is not asked for,
    # but it is an impact of the hammer on the resonator, not a remainder of one
    "metal-noise30": [0.6486],
    "wood-noise40": [],
    # 0.5215 and 0.5237 s: what the 20 ms whitening predictor leaves of the loudest strike's
    # response 2.2 and 4.4 ms after it (its frames there 3 to 4 dB under the strike's, as in
    # the whitened clean SDT render before the room, noise and encoding); SDT's hammer is not
    # in contact there (its contact ends at the strike), and the recording does not stand
    # out there (-0.5 and -0.3 dB over the 3 ms before). Step 3 takes the two for bounces
    # (2.2 ms each, e = 1.0, flagged) after the strike, the first tick, and the strike's
    # template (step 5) ends at the first of them, so it does not hold them
    "wood-room-ogg": [0.5215, 0.5237],
}
#: Strikes that stand out but are not found, s, and why.
KNOWN_MISSED = {
    "glass-room": [],
    "metal-noise30": [],
    "wood-noise40": [],
    # the loudest strike, 0.5193 s, is the first tick, on time: Vorbis' lowpass leaves the
    # band near the Nyquist frequency empty, and the whitening predictor lifts no band over
    # the noise the recording starts in (docs/analysis.md, step 1), so the step from the
    # silence assumed before the first sample leaves no burst there
    "wood-room-ogg": [],
}


def load(name: str):
    truth = json.loads((DATA / f"{name}.json").read_text())
    x, fs = read_audio(DATA / truth["file"])
    return truth, x if x.ndim == 1 else x.mean(axis=1), fs


def standing_out(x: np.ndarray, fs: float, times) -> np.ndarray:
    """Which ticks at ``times`` (s) clearly stand out of what precedes them."""
    out = []
    for t in times:
        k = int(round(t * fs))
        after = np.abs(x[k : k + int(round(0.001 * fs))]).max()
        before = np.abs(x[max(0, k - int(round(BEFORE * fs))) : k])
        out.append(after >= 10.0 ** (STANDS_OUT_DB / 20.0) * (before.max() if before.size else 0.0))
    return np.array(out, bool)


def burst_starts(strikes: np.ndarray) -> np.ndarray:
    """Which strikes (times in s, ascending) begin a burst: at least :data:`MIN_SEPARATION`
    after the previous strike."""
    return np.diff(strikes, prepend=-np.inf) >= MIN_SEPARATION


@functools.cache
def strike_report(name: str) -> dict:
    """Strikes that stand out but were not found, ticks that are no strike, and the
    unflagged restitutions, against SDT's truth (for ``python tests/test_recordings_sdt.py``)."""
    truth, x, fs = load(name)
    strikes, ends = np.array(truth["ticks"]), np.array(truth["contact_ends"])
    an = analyze_file(DATA / truth["file"])
    got = np.array([t.time for t in an.ticks])
    inside = (got[:, None] >= strikes - EARLY) & (got[:, None] <= ends + LATE)
    return dict(
        false=np.round(got[~inside.any(axis=1)], 4).tolist(),
        missed=np.round(
            strikes[burst_starts(strikes) & standing_out(x, fs, strikes) & ~inside.any(axis=0)], 4
        ).tolist(),
        restitution=[t.restitution for t in an.ticks if t.restitution is not None and not t.flags],
        truth=truth["restitution"],
    )


def test_sdt_data_is_complete():
    # the recordings the module docstring names are all there
    assert len(NAMES) == 4 and all(
        (DATA / json.loads((DATA / f"{n}.json").read_text())["file"]).exists() for n in NAMES
    )


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_sdt_ticks(name):
    # every strike that stands out is found and every tick is a strike, but for the cases
    # listed with their causes
    report = strike_report(name)
    assert (report["false"], report["missed"]) == (KNOWN_FALSE[name], KNOWN_MISSED[name])


@pytest.mark.slow
def test_sdt_restitution_over_missed_bounces_is_flagged():
    # wood-noise40: the ticks found are SDT's first four strikes (the first, 20 dB under the
    # second, and the third, which begins a lasting contact, by step 8) and the strike at
    # 0.990 s, after the 15 strikes of the chatter that do not stand out. The restitutions of
    # the third and fourth ticks are SDT's 0.7 and the mean; the last bounce spans the 15
    # missed strikes and grew (e = 2.33): flagged, said in the warnings and left out of it
    truth, _, _ = load("wood-noise40")
    an = analyze_file(DATA / truth["file"])
    assert [round(t.time, 3) for t in an.ticks] == [0.175, 0.42, 0.591, 0.711, 0.99]
    assert [t.restitution for t in an.ticks[2:4]] == pytest.approx(
        [truth["restitution"]] * 2, rel=RESTITUTION_RTOL
    )
    assert an.mean_restitution == pytest.approx(truth["restitution"], rel=RESTITUTION_RTOL)
    assert [t.index for t in an.ticks if GROWN_BOUNCE in t.flags] == [5]
    assert any("impossible restitution" in w and "tick 5" in w for w in an.warnings)


@pytest.mark.slow
def test_sdt_restitution_over_double_bounces():
    # glass-room: the ticks found are the strikes at 0.732, 1.030 and 1.198 s (every other
    # bounce's strike lies 4.4 and 5.8 dB under the 3 ms before it and is not found), so the
    # bounce times span two of SDT's flights each, which shrink by e at every bounce: their
    # ratio is e^2, within twice the onset tolerance over bounces of 0.17 s and more. Not
    # flagged: a series that misses every other tick is geometric with ratio e^2 in bounce
    # times and energies alike (the third tick's energy 3.9 dB under the second's, e^2 = 0.563
    # allows 5.0 dB), and nothing in the ticks tells it from a ball of restitution e^2
    report = strike_report("glass-room")
    assert report["restitution"] == pytest.approx([report["truth"] ** 2], rel=RESTITUTION_RTOL)


#: A synthetic bouncing series in white noise for step 8 (docs/analysis.md): the wood
#: resonator of wood-noise40 (tests/data/make_sdt_recordings.py: mode frequencies Hz, decay
#: times s, pickup gains), its velocity recorded (each mode's impulse response starts at its
#: peak, ``r^n cos(w n)``), struck at SDT's rate ...
SERIES_MODES = (
    (310.0, 0.06, 1.0),
    (742.0, 0.04, -0.7),
    (1385.0, 0.03, 0.5),
    (2210.0, 0.02, 0.6),
    (3190.0, 0.015, -0.4),
    (4630.0, 0.01, 0.3),
)
SERIES_FS = 44100
#: ... seven strikes from 0.15 s, the first bounce 0.25 s, each flight and impact speed
#: ``e`` times the one before; the first strike 20 dB under what its speed gives (SDT's first
#: strike in wood-noise40 lies 20 dB under its second), the third a contact whose force rises
#: over 1 ms, holds 5 ms and falls over 1 ms (a strike that begins a lasting contact, as
#: SDT's third there); white noise 40 dB under the peak.
SERIES_E = 0.7
WEAK_FIRST_DB = 20.0
RAMP, HOLD = 0.001, 0.005
SERIES_NOISE_DB = -40.0


def modal_series(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The synthetic series: the recording, each strike's time and the end of its force, s."""
    from scipy.signal import lfilter

    fs = SERIES_FS
    force = np.zeros(int(1.2 * fs))
    strikes, ends = [], []
    t, bounce = 0.15, 0.25
    for i in range(7):
        k = int(round(t * fs))
        speed = bounce / 0.25 * (10.0 ** (-WEAK_FIRST_DB / 20.0) if i == 0 else 1.0)
        if i == 2:
            n = int(round(RAMP * fs))
            shape = np.concatenate(
                (np.arange(1, n + 1) / n, np.ones(int(round(HOLD * fs))), np.linspace(1, 0, n))
            )
            force[k : k + shape.size] += 0.1 * speed * shape
            ends.append((k + shape.size) / fs)
        else:
            force[k] += speed
            ends.append(k / fs)
        strikes.append(k / fs)
        t, bounce = t + bounce, bounce * SERIES_E
    x = np.zeros_like(force)
    for f, tau, gain in SERIES_MODES:
        r, w = math.exp(-1.0 / (tau * fs)), 2.0 * math.pi * f / fs
        x += gain * lfilter([1.0, -r * math.cos(w)], [1.0, -2.0 * r * math.cos(w), r * r], force)
    noise = np.random.default_rng(seed).standard_normal(x.size)
    x += noise * np.abs(x).max() * 10.0 ** (SERIES_NOISE_DB / 20.0)
    return x, np.array(strikes), np.array(ends)


@pytest.mark.parametrize("seed", range(3))
def test_weak_first_strike_and_ramped_onset_are_found(seed):
    # both stand out of the recording (6 dB over the 3 ms before). Steps 1-7 miss the weak
    # first strike (its whitened frames 7 to 10 dB over their background's median, at
    # step 3's threshold_db or under: this failed before step 8), which step 8 finds; the
    # ramp is found within its contact. Every strike that stands out is found on time (from
    # the strike, less EARLY, to the end of its force plus LATE) and nothing else: the
    # restitution from the bounce times is the series' e to RESTITUTION_RTOL
    x, strikes, ends = modal_series(seed)
    stands = standing_out(x, SERIES_FS, strikes)
    assert stands[0] and stands[2]
    an = analyze(x, SERIES_FS)
    got = np.array([t.time for t in an.ticks])
    inside = (got[:, None] >= strikes - EARLY) & (got[:, None] <= ends + LATE)
    assert inside.any(axis=1).all(), got[~inside.any(axis=1)]
    assert inside[:, stands].any(axis=0).all(), strikes[stands & ~inside.any(axis=0)]
    assert an.mean_restitution == pytest.approx(SERIES_E, rel=RESTITUTION_RTOL)


if __name__ == "__main__":
    for n in NAMES:
        print(n, strike_report(n))
