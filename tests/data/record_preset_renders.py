"""Record what every preset renders to (tests/test_frozen_renders.py checks it).

Run from the repository: ``python tests/data/record_preset_renders.py``. Each preset is
rendered from empty caches (a private cache folder, empty memory caches), as the test does.
"""

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

import synth
from synth.sound import modes, radiation


def render_from_empty_caches(name: str):
    with tempfile.TemporaryDirectory(prefix="synth-record-") as tmp:
        os.environ["SYNTH_CACHE_DIR"] = tmp
        modes.clear_memory_cache()
        radiation.clear_memory_cache()
        return synth.render_preset(name)


def main() -> None:
    out = {}
    for name in sorted(synth.io.presets.available()):
        r = render_from_empty_caches(name)
        digest = hashlib.sha256(np.ascontiguousarray(r.audio, dtype="<f4").tobytes()).hexdigest()
        ticks = synth.analyze(r.audio, samplerate=r.samplerate).ticks
        out[name] = dict(
            sha256=digest,
            samples=int(r.audio.size),
            samplerate=r.samplerate,
            ticks=[round(float(t.time), 9) for t in ticks],
        )
        print(name, digest[:16], r.audio.size, len(ticks), flush=True)
    path = Path(__file__).with_name("preset_renders.json")
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
