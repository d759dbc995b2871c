"""Record what every preset renders to (tests/test_frozen_renders.py checks it).

Run from the repository: ``python tests/data/record_preset_renders.py``. Each preset is
rendered and analysed as the test does (tests/conftest.py, ``preset_run_from_empty_caches``).
"""

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

import synth

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import preset_run_from_empty_caches  # noqa: E402  (tests/conftest.py)


def main() -> None:
    out = {}
    for name in sorted(synth.io.presets.available()):
        run = preset_run_from_empty_caches(name)
        r = run.render
        digest = hashlib.sha256(np.ascontiguousarray(r.audio, dtype="<f4").tobytes()).hexdigest()
        ticks = run.analysis.ticks
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
