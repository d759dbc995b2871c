"""``synth bench hires``: cold renders of the default preset at high sample rates."""

from __future__ import annotations

import math
import time

from benchmarks.common import child_json, peak_rss_mb

#: Sample rates of the hires benchmark, Hz; the last is also rendered with the previous paths.
HIRES_RATES = (96000, 192000, 384000)


def hires_child(samplerate: int, previous: bool = False) -> dict:
    """A cold render of the default preset at ``samplerate`` Hz in this process: seconds
    of the plate's modes, of the rest of the first render (radiation gains, contact,
    synthesis), of a second render (warm: the rest without the gains), and peak resident
    memory (MB). ``previous``: with the engine's former paths, the rectangle rule for
    every plate (band by band past the Ritz crossover: the only rules of
    :data:`synth.sound.radiation.rules.RULES`) and the Ritz solve on BLAS's threads at every size
    (:data:`synth.physics.modes.ritz.ONE_THREAD_UNKNOWNS` infinite)."""
    from synth.io.presets import load_preset
    from synth.physics import modes as plate_modes
    from synth.physics.modes import ritz
    from synth.sound import radiation
    from synth.sound.radiation import rules
    from synth.sound.render import render

    if previous:
        rules.RULES = (rules.RectangleRule(), rules.BandedRule())
        ritz.ONE_THREAD_UNKNOWNS = math.inf
    scene = load_preset("default")
    t0 = time.perf_counter()
    modes = plate_modes.modes(scene.plate, max_frequency=0.5 * samplerate * (1.0 - 1e-9))
    t1 = time.perf_counter()
    first = render(scene, samplerate=samplerate)
    t2 = time.perf_counter()
    render(scene, samplerate=samplerate)
    t3 = time.perf_counter()
    return {
        "n_modes": len(modes),
        "modes_s": t1 - t0,
        "first_s": t2 - t1,
        "warm_s": t3 - t2,
        "peak_mb": peak_rss_mb(),
        "audio_s": first.duration,
        "gains": radiation.cache_info()["computations"],
    }


def _hires_run(samplerate, previous, timeout):
    import tempfile

    code = (
        "import json, sys; import benchmarks as bench; "
        "print(json.dumps(bench.hires_child(int(sys.argv[1]), sys.argv[2] == '1')))"
    )
    with tempfile.TemporaryDirectory(prefix="synth-hires-") as tmp:
        return child_json(code, [str(samplerate), "1" if previous else "0"], timeout, tmp)


def run_hires(rates=HIRES_RATES, timeout=3600.0) -> dict:
    """Cold renders of the default preset (a new process, an empty SYNTH_CACHE_DIR) at
    each of ``rates`` (Hz), and at the last one again with the previous paths (see
    :func:`hires_child`); ``ratio`` is the previous process's seconds over the present
    one's at that rate."""
    rows = [
        {"samplerate": fs, "paths": "present", **_hires_run(fs, False, timeout)} for fs in rates
    ]
    rows.append(
        {"samplerate": rates[-1], "paths": "previous", **_hires_run(rates[-1], True, timeout)}
    )
    now, before = rows[-2], rows[-1]
    ratio = (
        before["process_s"] / now["process_s"]
        if "error" not in now and "error" not in before
        else None
    )
    return {"rows": rows, "ratio": ratio}


def format_hires(result) -> str:
    """The hires benchmark as a Markdown table."""
    lines = [
        "| fs Hz | paths | modes | modes s | gains + render s | warm render s | process s | "
        "peak MB |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        if "error" in r:
            lines.append(f"| {r['samplerate']} | {r['paths']} | failed: {r['error']} | | | | | |")
            continue
        lines.append(
            f"| {r['samplerate']} | {r['paths']} | {r['n_modes']} | {r['modes_s']:.1f} | "
            f"{r['first_s']:.1f} | {r['warm_s']:.1f} | {r['process_s']:.1f} | "
            f"{r['peak_mb']:.0f} |"
        )
    lines.append("")
    if result["ratio"] is not None:
        lines.append(
            f"Cold render at {result['rows'][-1]['samplerate']} Hz: previous paths / present "
            f"paths = {result['ratio']:.1f}x (process seconds)."
        )
    lines.append(
        "Cold: a new process with an empty SYNTH_CACHE_DIR renders the default preset "
        "(`synth render default --samplerate FS`). 'modes s': the plate's modes; 'gains + "
        "render s': the first render after them (radiation gains, contact, bounces, "
        "synthesis); 'warm render s': a second render (gains from memory); 'process s' "
        "includes the interpreter, imports and numba's cache loading. Previous paths: the "
        "rectangle rule for every plate and the Ritz solve on BLAS's threads at every size."
    )
    return "\n".join(lines)
