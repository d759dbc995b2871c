"""``synth bench scale``: cold and warm costs of modes, radiation gains and synthesis for a
ladder of plates and random valid scenes, each in its own process."""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import child_json, peak_rss_mb

SCALE_LADDER = (
    # name, material, thickness m, length m, width m, boundary, samplerate Hz
    ("small stiff glass", "glass", 0.010, 0.15, 0.10, "clamped", 48000),
    ("glass table", "glass", 0.008, 1.0, 0.6, "simply-supported", 48000),
    ("steel sheet", "steel", 0.001, 0.5, 0.4, "free", 22050),
    ("steel sheet", "steel", 0.001, 0.5, 0.4, "free", 48000),
    ("thunder sheet", "steel", 0.001, 1.5, 1.0, "simply-supported", 48000),
    ("2 m thin metal", "steel", 0.0021, 1.86, 1.86, "simply-supported", 44100),
    ("free bar", "steel", 0.0037, 1.84, 0.10, "free", 48000),
    # two named targets are for plates with more modes than these steel ones (34 161 to
    # 22.05 kHz and 4614 to 24 kHz): the same sizes in the table's materials with at
    # least as many modes carry them
    ("1.86 m plate", "abs", 0.0021, 1.86, 1.86, "simply-supported", 44100),
    ("1.84 m bar", "rubber", 0.0037, 1.84, 0.10, "free", 48000),
)
#: The ladder's plates that carry the two named targets, and the fewest modes each must
#: have (the counts the targets were set for).
SCALE_NAMED = {"1.86 m plate": 34161, "1.84 m bar": 4614}


#: Random valid scenes of the scale benchmark (each cold in its own process) and the
#: seed that draws them (:func:`random_scale_specs`).
SCALE_RANDOM = 8
SCALE_SEED = 16
_RANDOM_MATERIALS = ("steel", "aluminium", "glass", "brass", "acrylic", "plywood")
_RANDOM_RATES = (22050, 44100, 48000)
_BOUNDARIES = ("free", "simply-supported", "clamped")


def random_scale_specs(count: int, seed: int = SCALE_SEED) -> list:
    """``count`` random valid plates as a new user would pick them: sides
    0.1-2 m, thickness 1-40 mm (log-uniform), any of six materials and the three
    boundaries, 22.05-48 kHz; specs for :func:`scale_child`."""
    rng = np.random.default_rng(seed)
    specs = []
    for _ in range(count):
        a, b = rng.uniform(0.1, 2.0, 2)
        specs.append(
            {
                "material": _RANDOM_MATERIALS[int(rng.integers(len(_RANDOM_MATERIALS)))],
                "thickness": float(np.exp(rng.uniform(np.log(0.001), np.log(0.04)))),
                "length": float(a),
                "width": float(b),
                "boundary": _BOUNDARIES[int(rng.integers(3))],
                "samplerate": int(_RANDOM_RATES[int(rng.integers(len(_RANDOM_RATES)))]),
            }
        )
    return specs


def scale_scene(material, thickness, length, width, boundary):
    """A 16 mm glass marble dropped 10 cm on a point off the middle (0.4, 0.45 of each
    side), microphone 0.4 m above the middle."""
    from synth.io import presets

    scene, _, _ = presets.load_preset_with_options(
        "glass-marble-on-glass-table",
        [
            f"plate.material='{material}'",
            f"plate.thickness={thickness!r}",
            f"plate.length={length!r}",
            f"plate.width={width!r}",
            f"plate.boundary='{boundary}'",
            f"drop.position=[{0.4 * length!r}, {0.45 * width!r}]",
            f"listener.position=[{0.5 * length!r}, {0.5 * width!r}, 0.4]",
        ],
    )
    return scene


def scale_child(spec: dict) -> dict:
    """One plate of the ladder in this process: seconds and peak resident memory (MB)
    after the modes, the microphone's gains and the whole render (whose modes and
    gains then come from the memory cache: the rest is contact, scheduler and
    synthesis), and the CPU seconds of the three (``work_cpu_s``: every thread of the
    process; on a busy machine the wall time also counts the waits for a core)."""
    from synth.physics import modes as plate_modes
    from synth.sound import render as render_mod
    from synth.sound.radiation import plate_gains

    scene = scale_scene(
        spec["material"], spec["thickness"], spec["length"], spec["width"], spec["boundary"]
    )
    fs = spec["samplerate"]
    out = {}
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    try:
        modes = plate_modes.modes(scene.plate, max_frequency=0.5 * fs * (1.0 - 1e-9))
    except Exception as exc:  # noqa: BLE001 - a refusal is a figure of this benchmark
        return {"error": f"{type(exc).__name__}: {exc}"}
    out["modes_s"] = time.perf_counter() - t0
    out["n_modes"] = len(modes)
    out["modes_mb"] = peak_rss_mb()
    omega = np.asarray(modes.angular_frequencies)
    sigma = np.asarray(modes.decay_rates)
    poles = -sigma + 1j * np.sqrt(np.maximum(omega**2 - sigma**2, 0.0))
    k_max = (
        float(omega.max()) ** 2 * scene.plate.surface_density / scene.plate.flexural_rigidity
    ) ** 0.25
    t0 = time.perf_counter()
    result = plate_gains(
        modes,
        scene.listener.position,
        -np.conj(poles),
        max_wavenumber=k_max,
        reference_distance=render_mod.nearest_distance(scene.plate, scene.listener),
        full_output=True,
    )
    out["gains_s"] = time.perf_counter() - t0
    out["gains_mb"] = peak_rss_mb()
    out["rule"] = result.rule
    t0 = time.perf_counter()
    r = render_mod.render(scene, samplerate=fs)
    out["render_s"] = time.perf_counter() - t0
    out["render_mb"] = peak_rss_mb()
    out["work_cpu_s"] = time.process_time() - cpu0
    out["audio_s"] = r.duration
    return out


def _scale_run(spec, cache_dir, timeout):
    import json

    code = (
        "import json, sys; import benchmarks as bench; "
        "print(json.dumps(bench.scale_child(json.loads(sys.argv[1]))))"
    )
    return child_json(code, [json.dumps(spec)], timeout, cache_dir)


def run_scale(ladder=SCALE_LADDER, timeout=600.0, random=SCALE_RANDOM) -> list:
    """Each plate of ``ladder``, then ``random`` random valid plates
    (:func:`random_scale_specs`), rendered in a new process with an empty cache directory
    (cold), then in another process with that directory (warm: modes and gains from
    disk). Seconds and peak memory of each stage; see :func:`scale_child`."""
    import tempfile

    rows = []
    for name, material, h, a, b, boundary, fs in ladder:
        spec = {
            "material": material,
            "thickness": h,
            "length": a,
            "width": b,
            "boundary": boundary,
            "samplerate": fs,
        }
        with tempfile.TemporaryDirectory(prefix="synth-scale-") as tmp:
            cold = _scale_run(spec, tmp, timeout)
            warm = _scale_run(spec, tmp, timeout) if "error" not in cold else cold
        rows.append({"name": name, **spec, "cold": cold, "warm": warm})
    for i, spec in enumerate(random_scale_specs(random)):
        with tempfile.TemporaryDirectory(prefix="synth-scale-") as tmp:
            cold = _scale_run(spec, tmp, timeout)
            warm = _scale_run(spec, tmp, timeout) if "error" not in cold else cold
        rows.append({"name": f"random {i + 1}", **spec, "cold": cold, "warm": warm})
    return rows


#: Targets of the scale benchmark: the random scenes' median cold work
#: (modes, gains and render in a new process), s; the longest any may take, s (or the
#: audio's own length if longer); peak resident memory, MB; the 1.86 m simply supported
#: plate's cold work, s; the free 1.84 x 0.10 m bar's cold modes to 24 kHz, s.
SCALE_TARGETS = {
    "median_s": 2.0,
    "slowest_s": 15.0,
    "peak_mb": 2048.0,
    "thin_metal_s": 5.0,
    "bar_modes_s": 3.0,
}


def _work_s(run: dict) -> float:
    """Seconds of a run's modes, gains and render (the process without the interpreter,
    imports and numba's cache loading)."""
    return run["modes_s"] + run["gains_s"] + run["render_s"]


def _stage(run: dict, key: str) -> str:
    """``seconds (peak MB)`` of one stage of a run, or a dash."""
    if not run or "error" in run:
        return "-"
    return f"{run[key + '_s']:.3g} ({run[key + '_mb']:.0f})"


def _cold_warm(figure, cold: dict, warm: dict) -> str:
    """``figure(cold) / figure(warm)``, a dash for a missing or failed warm run."""
    ok = bool(warm) and "error" not in warm
    return f"{figure(cold)} / {figure(warm) if ok else '-'}"


def format_scale(rows) -> str:
    """The scale benchmark as a Markdown table (cold / warm) and the targets' verdicts."""
    lines = [
        (
            "| plate | fs Hz | modes | modes s (MB) | gains s (MB), rule | render s (MB) | "
            "work s | process s | audio s | work CPU s |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        plate = (
            f"{row['name']}: {row['material']} {row['length']:.3g} x {row['width']:.3g} x "
            f"{row['thickness'] * 1e3:.3g} mm {row['boundary']}"
        )
        c, w = row["cold"], row["warm"]
        if "error" in c:
            lines.append(
                f"| {plate} | {row['samplerate']} | refused or failed: {c['error']} | | | | | | | |"
            )
            continue
        lines.append(
            f"| {plate} | {row['samplerate']} | {c['n_modes']} | "
            f"{_cold_warm(lambda r: _stage(r, 'modes'), c, w)} | "
            f"{_cold_warm(lambda r: _stage(r, 'gains'), c, w)}, {c['rule']} | "
            f"{_cold_warm(lambda r: _stage(r, 'render'), c, w)} | "
            f"{_cold_warm(lambda r: format(_work_s(r), '.3g'), c, w)} | "
            f"{_cold_warm(lambda r: format(r['process_s'], '.3g'), c, w)} | "
            f"{c['audio_s']:.2f} | {_cpu(c)} |"
        )
    lines += _random_summary(rows)
    lines += _ladder_targets(rows)
    lines.append("")
    lines.append(
        "Cold: a new process with an empty SYNTH_CACHE_DIR; warm: a second process "
        "with the first one's cache. Each stage: seconds and, in brackets, the process' "
        "peak resident memory after it (MB). 'render s' is the whole render after the "
        "modes and gains are in memory (contact, bounces, synthesis); 'work s' the three "
        "stages; 'process s' adds the interpreter, imports and numba's cache loading; "
        "'work CPU s' is the cold work's CPU time, every thread of the process."
    )
    return "\n".join(lines)


def _cpu(run: dict) -> str:
    """A run's CPU seconds of work (see :func:`scale_child`), a dash if not recorded."""
    return format(run["work_cpu_s"], ".3g") if "work_cpu_s" in run else "-"


def _verdict(met: bool) -> str:
    return "met" if met else "NOT met"


def _random_summary(rows) -> list:
    """The random scenes' cold work (median, largest), process time, peak memory, how many
    were refused or took longer than max(15 s, their audio's length), with the targets'
    verdicts (:data:`SCALE_TARGETS`)."""
    runs = [r["cold"] for r in rows if r["name"].startswith("random")]
    if not runs:
        return []
    done = [c for c in runs if "error" not in c]
    t = SCALE_TARGETS
    lines = ["", f"Random valid scenes ({len(runs)}, seed {SCALE_SEED}), cold:"]
    if not done:
        return lines + [f"refused or failed: {len(runs)}."]
    work = np.array([_work_s(c) for c in done])
    proc = np.array([c["process_s"] for c in done])
    mb = np.array([c["render_mb"] for c in done])
    slow = sum(_work_s(c) > max(t["slowest_s"], c["audio_s"]) for c in done)
    failed = len(runs) - len(done)
    lines.append(
        f"work median {np.median(work):.3g} s, max {work.max():.3g} s (process median "
        f"{np.median(proc):.3g} s, max {proc.max():.3g} s), peak memory max {mb.max():.0f} MB; "
        f"slower than max(15 s, audio length): {slow}; refused or failed: {failed}."
    )
    cpu = [c["work_cpu_s"] for c in done if "work_cpu_s" in c]
    if len(cpu) == len(done):
        lines[-1] += f" Work CPU time median {np.median(cpu):.3g} s."
    lines.append(
        f"Targets: median under {t['median_s']:g} s {_verdict(np.median(work) < t['median_s'])}; "
        f"none slower than max({t['slowest_s']:g} s, audio length) "
        f"{_verdict(slow == 0 and failed == 0)}; peak under {t['peak_mb'] / 1024:g} GB "
        f"{_verdict(mb.max() < t['peak_mb'])}."
    )
    return lines


def _ladder_targets(rows) -> list:
    """Verdicts of the ladder's two named targets: the 1.86 m simply supported plate's cold
    work and the free bar's cold modes (:data:`SCALE_TARGETS`), where they ran."""
    t = SCALE_TARGETS
    out = []
    for row in rows:
        c = row["cold"]
        if "error" in c:
            continue
        if row["name"] == "1.86 m plate":
            out.append(
                f"1.86 m simply supported plate ({row['material']}, {c['n_modes']} modes; the "
                f"target is set for {SCALE_NAMED[row['name']]}), cold work {_work_s(c):.3g} s: under "
                f"{t['thin_metal_s']:g} s {_verdict(_work_s(c) < t['thin_metal_s'])}."
            )
        if row["name"] == "1.84 m bar":
            out.append(
                f"Free 1.84 x 0.10 m bar ({row['material']}, {c['n_modes']} modes; the target "
                f"is set for {SCALE_NAMED[row['name']]}) to {row['samplerate'] // 2} Hz, cold modes "
                f"{c['modes_s']:.3g} s: under {t['bar_modes_s']:g} s "
                f"{_verdict(c['modes_s'] < t['bar_modes_s'])}."
            )
    return [""] + out if out else []
