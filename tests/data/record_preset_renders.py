"""Record what every preset renders to (tests/test_frozen_renders.py checks it).

Run from the repository: ``python tests/data/record_preset_renders.py [NAME ...]``. Each preset
(or only the presets named, the other entries kept as recorded) is rendered and analysed as the
test does (tests/conftest.py, ``preset_run_from_empty_caches``). Record only the presets whose
sound was changed on purpose.
"""

import json
import sys
from pathlib import Path

from synth.io.presets import available as available_presets

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import preset_run_from_empty_caches  # noqa: E402  (tests/conftest.py)
from golden import (  # noqa: E402  (tests/golden.py)
    MAX_RELATIVE_ERROR,
    ROUNDING_PERTURBATION,
    rounding_horizon,
    sketch,
)


def main(names: list[str]) -> None:
    path = Path(__file__).with_name("preset_renders.json")
    available = sorted(available_presets())
    unknown = sorted(set(names) - set(available))
    if unknown:
        raise SystemExit(
            f"no such preset: {', '.join(unknown)} (available: {', '.join(available)})"
        )
    out = json.loads(path.read_text()) if names else {}
    for name in names or available:
        run = preset_run_from_empty_caches(name)
        r = run.render
        ticks = run.analysis.ticks
        out[name] = dict(
            sketch=[float(x) for x in sketch(r.audio)],
            samples=int(r.audio.size),
            samplerate=r.samplerate,
            ticks=[round(float(t.time), 9) for t in ticks],
        )
        height = run.scene.drop_height * (1.0 + ROUNDING_PERTURBATION)
        moved = preset_run_from_empty_caches(name, (f"drop.height={height!r}",)).render.audio
        horizon = rounding_horizon(r.audio, moved, MAX_RELATIVE_ERROR)
        if horizon is not None:
            out[name].update(
                horizon=horizon, horizon_sketch=[float(x) for x in sketch(r.audio[:horizon])]
            )
        print(name, r.audio.size, len(ticks), flush=True)
    out = {name: out[name] for name in sorted(out)}
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
