"""``synth bench long``: analysis time and memory against the length of a recording and its
number of drops."""

from __future__ import annotations

import time

import numpy as np

from benchmarks.analysis import synthetic_bounce
from benchmarks.common import child_json

#: Lengths of the recordings of the long-recording benchmark, s.
LONG_DURATIONS = (30.0, 120.0, 600.0)
#: One drop every this many seconds in the recordings of repeated drops, s.
LONG_PERIOD = 10.0
#: The target for a 10-minute recording: analysed in under this many seconds, s...
LONG_TARGET_S = 30.0
#: ... and a process' peak resident set under this, MB.
LONG_TARGET_MB = 500.0


def long_recording(path, duration: float, repeated: bool, samplerate: int = 48000) -> int:
    """Write a recording of ``duration`` s (float32 WAV) to ``path``: white noise 80 dB under
    full scale and a synthetic bounce (:func:`synthetic_bounce`, e = 0.8, 20 ticks; a new
    seed per drop) starting at 1 s, and with ``repeated`` again every :data:`LONG_PERIOD` s.
    Written in pieces of a drop's period (the file is never in memory whole). Returns the
    number of true ticks."""
    import soundfile

    fs = samplerate
    rng = np.random.default_rng(0)
    total = int(round(duration * fs))
    period = int(round(LONG_PERIOD * fs))
    ticks = 0
    with soundfile.SoundFile(
        path, "w", samplerate=fs, channels=1, subtype="FLOAT", format="WAV"
    ) as f:
        for k, start in enumerate(range(0, total, period)):
            n = min(period, total - start)
            y = rng.standard_normal(n) * 1e-4
            if k == 0 or repeated:
                x, _, onsets = synthetic_bounce(0.8, fs, seed=k)
                m = min(x.size, n - fs)
                if m > 0:
                    y[fs : fs + m] += 0.5 * x[:m]
                    ticks += int(np.count_nonzero(onsets + 1.0 < n / fs))
            f.write(y.astype(np.float32))
    return ticks


def long_child(path: str) -> dict:
    """Analyse the file ``path`` in this process: wall seconds, CPU seconds (the process'
    threads), ticks and series found. Untraced: tracing allocations (tracemalloc) would slow
    the analysis' Python code by up to half again; memory is the process' peak resident set,
    read by the caller."""
    from synth.analysis import analyze_file

    t0, c0 = time.perf_counter(), time.process_time()
    a = analyze_file(path)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"seconds": seconds, "cpu_s": cpu, "ticks": len(a.ticks), "series": len(a.series)}


def run_long(durations=LONG_DURATIONS, timeout: float = 1800.0) -> list:
    """Each recording of :func:`long_recording` (one drop, and repeated drops) analysed by
    ``analyze_file`` in a new process (after a warm-up on a short file, which loads numba's
    cache): wall and CPU seconds, the process' peak resident MB
    (``ru_maxrss``: the interpreter and libraries too), wall and CPU seconds per minute of
    audio, and ticks found against the truth."""
    import os
    import tempfile

    code = (
        "import json, resource, sys; import benchmarks as bench; "
        "bench.long_child(sys.argv[2]); r = bench.long_child(sys.argv[1]); "
        "r['rss_mb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0; "
        "print(json.dumps(r))"
    )
    rows = []
    with tempfile.TemporaryDirectory(prefix="synth-long-") as tmp:
        warm = os.path.join(tmp, "warm.wav")
        long_recording(warm, 3.0, False)
        for repeated in (False, True):
            for duration in durations:
                path = os.path.join(tmp, "long.wav")
                truth = long_recording(path, duration, repeated)
                row = {"duration": duration, "repeated": repeated, "truth": truth}
                row.update(child_json(code, [path, warm], timeout))
                if "error" not in row:
                    row["per_minute"] = row["seconds"] / (duration / 60.0)
                    row["cpu_per_minute"] = row["cpu_s"] / (duration / 60.0)
                rows.append(row)
    return rows


def format_long(rows) -> str:
    """The long-recording benchmark as a Markdown table, then the 10-minute recordings against
    the target (:data:`LONG_TARGET_S`, :data:`LONG_TARGET_MB`)."""
    lines = [
        "| recording | ticks (truth) | series | analysis s (CPU s) | s per minute of audio "
        "(CPU) | process peak MB |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        what = _long_name(r)
        if "error" in r:
            lines.append(f"| {what} | ({r['truth']}) | failed: {r['error']} | | | |")
            continue
        lines.append(
            f"| {what} | {r['ticks']} ({r['truth']}) | {r['series']} | {r['seconds']:.2f} "
            f"({r['cpu_s']:.2f}) | {r['per_minute']:.2f} ({r['cpu_per_minute']:.2f}) | "
            f"{r['rss_mb']:.0f} |"
        )
    lines.append("")
    lines.append(
        "Synthetic bounces (e = 0.8, 20 ticks each) in white noise 80 dB under full scale, "
        "48 kHz float WAV, each analysed by `analyze_file` in a new process after a warm-up "
        "on a 3 s file. CPU: the process' threads (a multithreaded BLAS's helpers too). "
        "'process peak': the process' largest resident set (ru_maxrss, with the interpreter "
        "and libraries)."
    )
    longest = [r for r in rows if r["duration"] >= 600.0 and "error" not in r]
    if longest:
        lines.append("")
        for r in longest:
            met = r["seconds"] < LONG_TARGET_S and r["rss_mb"] < LONG_TARGET_MB
            lines.append(
                f"- {_long_name(r)}: {r['seconds']:.1f} s ({r['cpu_s']:.1f} s CPU), process "
                f"peak {r['rss_mb']:.0f} MB: target under {LONG_TARGET_S:g} s and "
                f"{LONG_TARGET_MB:g} MB {'met' if met else 'not met'}."
            )
    return "\n".join(lines)


def _long_name(r: dict) -> str:
    """A row's recording: its length and drops."""
    return f"{r['duration']:g} s, " + (
        f"a drop every {LONG_PERIOD:g} s" if r["repeated"] else "one drop"
    )
