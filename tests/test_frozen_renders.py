"""Every preset renders to the very samples recorded in tests/data/preset_renders.json, and the
analysis finds the same ticks in it.

Each preset is rendered with its own [render] options but without normalisation (its physical
units: the physics and the synthesis, not a final scaling that tests/test_audio_io.py checks);
a refactoring must not change a single sample (SHA-256 of the float32 audio, little-endian) nor
a tick time (to 1 ns, the precision recorded). A change that is meant to alter the sound records
new values with ``python tests/data/record_preset_renders.py`` and says why in its commit.

Each render starts from empty caches (a private cache folder, empty memory caches), so that it
solves the plate's modes itself: the cache serves only a solution of the very band asked for
and the solver runs on one BLAS thread, so a warm cache gives the same samples. The render and its
analysis are the session's shared run of the preset (tests/conftest.py), which the round trip
reads too.
"""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

import synth

RECORDED = json.loads((Path(__file__).parent / "data" / "preset_renders.json").read_text())


def audio_sha256(audio: np.ndarray) -> str:
    """SHA-256 of the audio as little-endian float32."""
    return hashlib.sha256(np.ascontiguousarray(audio, dtype="<f4").tobytes()).hexdigest()


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(RECORDED))
def test_preset_renders_the_recorded_samples(name, preset_run):
    want = RECORDED[name]
    run = preset_run(name)
    r = run.render
    assert r.samplerate == want["samplerate"]
    assert r.audio.size == want["samples"]
    assert audio_sha256(r.audio) == want["sha256"]
    ticks = run.analysis.ticks
    np.testing.assert_allclose([t.time for t in ticks], want["ticks"], rtol=0, atol=1e-9)


def test_every_preset_is_recorded():
    assert sorted(RECORDED) == sorted(synth.io.presets.available())
