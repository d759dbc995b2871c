"""Recordings of bouncing sounds the engine did not make: the Sound Design Toolkit's bouncing
ball (Hunt-Crossley contact on a modal resonator, fixed restitution), with noise at -30 and
-40 dB, in a synthetic room (RT60 0.4 and 0.6 s) and through OGG/Vorbis. The files and their
truth are in tests/data/sdt/, made by tests/data/make_sdt_recordings.py.

What the analysis should do on them: find every tick that clearly stands out (its peak over
the first millisecond at least :data:`STANDS_OUT_DB` over the peak of the :data:`BEFORE`
before it; strikes closer than the analysis' ``min_separation`` to the previous one, the
chatter of a ball coming to rest, are one burst, found as one tick), report no tick that is
not one of SDT's strikes (from the strike, less
:data:`EARLY`, to the end of its first contact plus :data:`LATE`) and give SDT's restitution.
It does not yet (issue 15): ``python tests/test_recordings_sdt.py`` prints, per recording,
the strikes missed, the ticks that are no strike and the restitutions, from
:func:`strike_report`.
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np

from synth.analysis import analyze, analyze_file
from synth.io.audio import read_audio

DATA = Path(__file__).parent / "data" / "sdt"
NAMES = sorted(p.stem for p in DATA.glob("*.json"))
STANDS_OUT_DB = 6.0
BEFORE = 0.003
#: A tick may start this much before its strike, s: the onset is the level crossing of the
#: whitened burst, to within a few sample periods (docs/analysis.md, step 4), 0.1 ms at
#: 44.1 kHz ...
EARLY = 0.0001
#: ... and this much after the end of the contact, s.
LATE = 0.0001
#: Strikes closer than this to the previous one are one burst (s): the analysis' default
#: ``min_separation``, below which it does not split ticks.
MIN_SEPARATION = inspect.signature(analyze).parameters["min_separation"].default
#: Restitution from bounce times, relative: SDT's flights shrink by exactly ``e``, and the
#: bounce time ``t_n`` is known to twice the onset tolerance over bounces of 40 ms or more.
RESTITUTION_RTOL = 0.02


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


if __name__ == "__main__":
    for n in NAMES:
        print(n, strike_report(n))
