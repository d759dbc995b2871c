"""Random valid scenes render without refusal: simply supported plates of any size
(0.1-2 m a side, 1-40 mm thick) at 22.05-96 kHz, the microphone's gains by the polar
rule where the rectangle rule would be slow (synth.sound.radiation.plate_gains)."""

from __future__ import annotations

import numpy as np
import pytest

from synth.io import presets
from synth.physics import modes as P
from synth.sound import radiation as R
from synth.sound.render import render

MATERIALS = ("steel", "aluminium", "glass", "brass", "acrylic", "plywood")
RATES = (22050, 44100, 48000, 96000)


#: every test gets empty memory caches and its own disk cache directory
pytestmark = pytest.mark.usefixtures("empty_caches")


def _random_scene(rng):
    a, b = rng.uniform(0.1, 2.0, 2)
    thickness = float(np.exp(rng.uniform(np.log(0.001), np.log(0.04))))
    material = MATERIALS[rng.integers(len(MATERIALS))]
    fs = int(RATES[rng.integers(len(RATES))])
    drop = rng.uniform(0.1, 0.9, 2) * (a, b)
    mic = (*(rng.uniform(-0.2, 1.2, 2) * (a, b)), float(rng.uniform(0.05, 1.0)))
    scene, _, _ = presets.load_preset_with_options(
        "glass-marble-on-glass-table",
        [
            f"plate.material='{material}'",
            f"plate.thickness={thickness!r}",
            f"plate.length={float(a)!r}",
            f"plate.width={float(b)!r}",
            "plate.boundary='simply-supported'",
            f"drop.position=[{float(drop[0])!r}, {float(drop[1])!r}]",
            f"listener.position=[{float(mic[0])!r}, {float(mic[1])!r}, {mic[2]!r}]",
        ],
    )
    return scene, fs


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 5, 16])
def test_random_simply_supported_scene_renders(seed):
    """Every mode below Nyquist is kept and the audio is finite and not silent (the
    ringing is cut at 0.5 s after 1 s of bounces to bound the test's time)."""
    scene, fs = _random_scene(np.random.default_rng(seed))
    out = render(scene, samplerate=fs, max_duration=1.0, max_tail=0.5)
    assert out.settings["n_modes"] > 0
    assert np.all(np.isfinite(out.audio)) and np.max(np.abs(out.audio)) > 0.0


@pytest.mark.slow
@pytest.mark.parametrize("index", [2, 3])
def test_random_big_free_and_clamped_scenes_render(index):
    """Random valid plates of the scale benchmark (benchmarks.random_scale_specs) whose
    Ritz problem is past the crossover (a clamped 1.62 x 0.45 m and a free 1.92 x 1.97 m
    plate) render with no refusal: Ritz low band plus dynamic edge effect modes; the
    audio is finite and not silent (no timing asserted). Heard by an accelerometer: a
    microphone's gains are timed by the scale benchmark."""
    from dataclasses import replace

    import benchmarks as bench
    from synth.physics.scene import Accelerometer

    spec = bench.random_scale_specs(index + 1)[index]
    assert spec["boundary"] in ("free", "clamped")
    scene = bench.scale_scene(
        spec["material"], spec["thickness"], spec["length"], spec["width"], spec["boundary"]
    )
    scene = replace(scene, listener=Accelerometer((0.3 * spec["length"], 0.4 * spec["width"])))
    m = P.modes(scene.plate, max_frequency=0.5 * spec["samplerate"] * (1.0 - 1e-9))
    assert m.tolerance == P.EDGE_EFFECT_TOLERANCE
    out = render(scene, samplerate=spec["samplerate"], max_duration=1.0, max_tail=0.5)
    assert out.settings["n_modes"] == len(m)
    assert np.all(np.isfinite(out.audio)) and np.max(np.abs(out.audio)) > 0.0


@pytest.mark.slow
def test_random_big_clamped_scene_heard_by_a_microphone():
    """The benchmark's random clamped 1.62 x 0.45 m acrylic plate at 22.05 kHz (past the
    crossover: Ritz low band, edge effect modes and their Rayleigh-Ritz pairs, whose shapes
    are sums of two products) heard by its microphone: the radiation gains converge to
    their tolerance for every mode, none exceeds its in-phase bound (|H_k| <= S_k, the
    whole plate radiating in phase), and the audio is finite and not silent."""
    import benchmarks as bench
    from synth.sound.render import nearest_distance

    spec = bench.random_scale_specs(3)[2]
    assert spec["boundary"] == "clamped"
    scene = bench.scale_scene(
        spec["material"], spec["thickness"], spec["length"], spec["width"], spec["boundary"]
    )
    fs = spec["samplerate"]
    m = P.modes(scene.plate, max_frequency=0.5 * fs * (1.0 - 1e-9))
    assert m.tolerance == P.EDGE_EFFECT_TOLERANCE and m._solution.edge.n_paired > 0
    omega = np.asarray(m.angular_frequencies)
    sigma = np.asarray(m.decay_rates)
    mirror = sigma + 1j * np.sqrt(omega**2 - sigma**2)
    k_max = (omega[-1] ** 2 * scene.plate.surface_density / scene.plate.flexural_rigidity) ** 0.25
    res = R.plate_gains(
        m,
        scene.listener.position,
        mirror,
        max_wavenumber=k_max,
        reference_distance=nearest_distance(scene.plate, scene.listener),
        full_output=True,
    )
    assert res.success
    assert np.all(np.abs(res.gains) <= res.coherent * (1.0 + 1e-6))
    out = render(scene, samplerate=fs, max_duration=1.0, max_tail=0.5)
    assert out.settings["n_modes"] == len(m)
    assert np.all(np.isfinite(out.audio)) and np.max(np.abs(out.audio)) > 0.0


def test_random_scale_specs_are_valid_and_reproducible():
    """The benchmark's random scenes: the stated ranges (sides 0.1-2 m, 1-40 mm,
    22.05-48 kHz), every boundary among the benchmark's eight, the same for a seed."""
    import benchmarks as bench

    specs = bench.random_scale_specs(bench.SCALE_RANDOM)
    assert specs == bench.random_scale_specs(bench.SCALE_RANDOM)
    assert {s["boundary"] for s in specs} == {"free", "simply-supported", "clamped"}
    for s in specs:
        assert 0.1 <= s["length"] <= 2.0 and 0.1 <= s["width"] <= 2.0
        assert 0.001 <= s["thickness"] <= 0.04
        assert 22050 <= s["samplerate"] <= 48000


def test_scale_table_summarises_random_scenes():
    """The random scenes' lines: median and largest cold work (modes, gains, render) and
    process time, peak memory, how many exceeded max(15 s, audio length) and how many were
    refused, and the targets' verdicts; the ladder's named targets."""
    import benchmarks as bench

    run = {
        "n_modes": 10,
        "modes_s": 0.1,
        "modes_mb": 200.0,
        "gains_s": 0.1,
        "gains_mb": 250.0,
        "rule": "rectangle",
        "render_s": 0.1,
        "render_mb": 300.0,
        "audio_s": 2.0,
    }
    rows = [
        {
            "name": f"random {i}",
            **spec,
            "cold": {**run, "render_s": t, "process_s": t + 2.0},
            "warm": {**run, "process_s": 1.5},
        }
        for i, (spec, t) in enumerate(zip(bench.random_scale_specs(3), (1.0, 2.0, 20.0)))
    ]
    rows.append({"name": "random 4", **rows[0], "cold": {"error": "refused"}, "warm": {}})
    bar = {"material": "steel", "thickness": 0.0037, "length": 1.84, "width": 0.1}
    rows.append(
        {
            "name": "1.84 m bar",
            **bar,
            "boundary": "free",
            "samplerate": 48000,
            "cold": {**run, "modes_s": 4.0, "process_s": 6.0},
            "warm": {},
        }
    )
    text = bench.format_scale(rows)
    assert "work median 2.2 s, max 20.2 s (process median 4 s, max 22 s)" in text
    assert "peak memory max 300 MB" in text
    assert "slower than max(15 s, audio length): 1; refused or failed: 1." in text
    assert "median under 2 s NOT met" in text and "peak under 2 GB met" in text
    assert "cold modes 4 s: under 3 s NOT met" in text
    assert "| 0.1 (200) / 0.1 (200) |" in text  # modes: cold / warm seconds (MB)
    assert "| 4 (200) / - |" in text  # no warm run of the bar
