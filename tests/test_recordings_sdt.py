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
from pathlib import Path

import numpy as np
import pytest

from synth.analysis import analyze, analyze_file
from synth.analysis.report import MISSED_BOUNCE
from synth.analysis.series import RESTITUTION_STEP
from synth.io.audio import read_audio

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
    # both clearly stand out of the recording (peak over the first millisecond 8.3 and 6.8 dB
    # over that of the 3 ms before), and both are missed by the detection's rules:
    # 0.1749 s: SDT's first strike, 20 dB under its second, stands 8.3 dB over the noise's
    # peaks but its whitened frame only 6 dB over the whitened noise (step 3 asks for
    # threshold_db, 10 dB); 0.5911 s: the strike begins a contact that lasts (the force grows
    # over a millisecond), so the whitened signal rises by under 6 dB a frame over three
    # frames and stays there: a step of the excitation, no burst (rise_db, and the running
    # median follows it)
    "wood-noise40": [0.1749, 0.5911],
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
    # wood-noise40: the ticks found are the strikes at 0.420, 0.711 and 0.990 s; the last
    # bounce spans the 15 strikes between them (SDT's flights shrinking by 0.7 down to the
    # chatter of the ball coming to rest) and gives e = 0.96 (SDT's is 0.7). The energy of the
    # third tick is 12 dB under the previous tick's, where e = 0.96 allows 0.4 dB: more than
    # the 6 dB by which any missed bounce lowers it, so it is flagged, said in the warnings,
    # and left out of the mean
    truth, _, _ = load("wood-noise40")
    an = analyze_file(DATA / truth["file"])
    flagged = [t for t in an.ticks if MISSED_BOUNCE in t.flags]
    assert [t.index for t in flagged] == [3]
    assert flagged[0].restitution > truth["restitution"] * (1.0 + RESTITUTION_STEP)
    assert an.mean_restitution is None
    assert any("missed bounce" in w and "tick 3" in w for w in an.warnings)


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


if __name__ == "__main__":
    for n in NAMES:
        print(n, strike_report(n))
