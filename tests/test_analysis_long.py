"""Long recordings: analysed block by block (synth/analysis/blocks.py) in bounded memory, every
drop found whole, and absurd options refused before any work (docs/analysis.md, Long
recordings)."""

from __future__ import annotations

import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
import soundfile as sf

from synth import analysis
from synth.analysis import blocks, pipeline
from synth.bench import synthetic_bounce
from synth.errors import ParameterError

FS = 48000


def _drops(
    duration: float, starts, n_ticks: int = 20, seed: int = 0
) -> tuple[np.ndarray, list[np.ndarray]]:
    """``duration`` s of white noise 80 dB under full scale with a synthetic bounce (e = 0.8,
    ``n_ticks`` ticks, not made by the engine) starting at each of ``starts`` (s), and the
    true onsets of each."""
    rng = np.random.default_rng(seed)
    y = rng.standard_normal(int(duration * FS)) * 1e-4
    truth = []
    for k, s0 in enumerate(starts):
        x, _, on = synthetic_bounce(0.8, FS, n_ticks=n_ticks, seed=k)
        a = int(round(s0 * FS))
        m = min(x.size, y.size - a)
        y[a : a + m] += 0.5 * x[:m]
        truth.append(on + a / FS)
    return y, truth


def _close(got: np.ndarray, want: np.ndarray, tol: float) -> bool:
    return got.size == want.size and bool(np.all(np.abs(got - want) <= tol))


@pytest.mark.slow
def test_drops_across_blocks_are_found_whole(monkeypatch):
    """Three drops in 26 s cut in blocks of 10 s: one that starts half a second before the
    first block ends (its series spans two blocks) and one in the overlap of the next. Each
    is found as one series, every onset within a sample period of the truth (the accuracy of
    docs/analysis.md, Accuracy, for a recording held whole)."""
    monkeypatch.setattr(blocks, "BLOCK", 10.0)
    monkeypatch.setattr(blocks, "WHOLE", 10.0)
    starts = (1.0, blocks.BLOCK - 0.5, 2 * blocks.BLOCK - 1.0 - blocks.OVERLAP / 2)
    y, truth = _drops(26.0, starts, n_ticks=10)
    a = analysis.analyze(y, FS)
    assert len(a.series) == 3
    for series, want in zip(a.series, truth):
        got = np.array([t.time for t in series.ticks])
        assert _close(got, want, 1.0 / FS), (got - want) if got.size == want.size else got


def test_one_block_is_the_whole_analysis(monkeypatch):
    """A recording that fits in a block is analysed as one array (the presets' round trip and
    frozen ticks rest on it); the same recording cut in blocks gives the same ticks within
    a sample period."""
    y, (want,) = _drops(8.0, (1.0,))
    whole = np.array([t.time for t in analysis.analyze(y, FS).ticks])
    monkeypatch.setattr(blocks, "BLOCK", 3.0)
    monkeypatch.setattr(blocks, "WHOLE", 3.0)
    monkeypatch.setattr(pipeline, "OVERLAP", 1.0)
    cut = np.array([t.time for t in analysis.analyze(y, FS).ticks])
    assert _close(whole, want, 1.0 / FS) and _close(cut, whole, 1.0 / FS)


def _peak_bytes(path) -> tuple[int, analysis.Analysis]:
    tracemalloc.start()
    try:
        result = analysis.analyze_file(path)
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()


def test_memory_does_not_grow_with_the_file(tmp_path, monkeypatch):
    """A file is read in blocks (here of 10 s), never whole: the peak of the memory allocated
    while a 90 s file with one drop is analysed stays within 10 % of a 30 s file's (a whole
    read of the 90 s file alone, in float64, is 35 MB), and the drop is found in both."""
    monkeypatch.setattr(blocks, "BLOCK", 10.0)
    monkeypatch.setattr(blocks, "WHOLE", 10.0)
    peaks = []
    for duration in (30.0, 90.0):
        y, (want,) = _drops(duration, (duration - 3.0,))
        path = tmp_path / f"drop{duration:g}.wav"
        sf.write(path, y.astype(np.float32), FS, subtype="FLOAT")
        peak, result = _peak_bytes(path)
        got = np.array([t.time for t in result.ticks])
        assert _close(got, want, 1.0 / FS)
        assert result.duration == pytest.approx(duration)
        peaks.append(peak)
    assert peaks[1] <= 1.1 * peaks[0] and peaks[1] < 90.0 * FS * 8, peaks


@pytest.mark.parametrize(
    "option, value, allowed",
    [
        ("window", 1e300, "<= 2"),
        ("hop", 5.0, "<= 0.01"),
        ("background", 1e9, "<= 1"),
        ("threshold_db", 1e4, "<= 300"),
        ("dynamic_range_db", float("inf"), "finite"),
        ("lpc_order", 10**9, "2..4096"),
        ("decay_smoothing", 60.0, "<= 0.1"),
        ("min_separation", 1e3, "<= 1"),
        ("gravity", 1e300, "<= 300"),
    ],
)
def test_absurd_options_are_refused_before_any_work(tmp_path, monkeypatch, option, value, allowed):
    """Each option has a documented range (synth.analysis.settings); a value outside it is a
    ParameterError naming the option, its value and the range, raised before a sample is
    read."""
    path = tmp_path / "x.wav"
    sf.write(path, np.zeros(4800), FS)

    def no_read(*args, **kwargs):
        raise AssertionError("samples read before the options were checked")

    monkeypatch.setattr(pipeline, "read_recording", no_read)
    monkeypatch.setattr(blocks.FileSource, "read", no_read)
    with pytest.raises(ParameterError, match=f"{option}=.*{allowed}"):
        analysis.analyze_file(path, **{option: value})


def test_cli_window_out_of_range(tmp_path):
    """``synth analyze FILE --window 1e300``: one line naming the option and its range,
    exit status 2... or 1 as for every ParameterError of the command line; no traceback."""
    path = tmp_path / "x.wav"
    sf.write(path, np.zeros(4800), FS)
    proc = subprocess.run(
        [sys.executable, "-m", "synth.cli", "analyze", str(path), "--window", "1e300"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode != 0
    assert "window=1e+300 must be > 0 and <= 2" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_long_benchmark_recordings(tmp_path):
    """``synth bench long`` writes its recordings in pieces: the length asked, a drop at 1 s
    and, repeated, one every LONG_PERIOD s (20 ticks each: 3 drops in 25 s); its table has a
    row per recording."""
    from synth import bench

    path = tmp_path / "long.wav"
    assert bench.long_recording(path, 25.0, True) == 60
    assert sf.info(path).frames == 25 * FS
    assert bench.long_recording(path, 25.0, False) == 20
    row = {"duration": 25.0, "repeated": True, "truth": 60, "ticks": 60, "series": 3}
    row.update(
        seconds=3.0, cpu_s=2.5, per_minute=7.2, cpu_per_minute=6.0, traced_mb=50.0, rss_mb=200.0
    )
    ten = dict(row, duration=600.0, seconds=29.0, cpu_s=25.0, rss_mb=510.0)
    table = bench.format_long(
        [row, ten, {"duration": 600.0, "repeated": False, "truth": 20, "error": "x"}]
    )
    assert "| 25 s, a drop every 10 s | 60 (60) | 3 | 3.00 (2.50) | 7.20 (6.00) | 50 | 200 |" in (
        table
    )
    assert "failed: x" in table
    assert "600 s, a drop every 10 s: 29.0 s (25.0 s CPU), process peak 510 MB" in table
    assert "not met" in table
