"""Tests of the hires benchmark (synth bench hires) on a cheap case: the child's figures
and the table."""

from __future__ import annotations

import pytest

import benchmarks as bench


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.slow
def test_hires_child_times_each_stage():
    # the default preset at 8 kHz in this process: modes, first and warm render timed
    out = bench.hires_child(8000)
    assert out["n_modes"] > 0 and out["audio_s"] > 0
    assert out["modes_s"] >= 0 and out["first_s"] > 0 and out["warm_s"] > 0
    assert out["peak_mb"] > 0 and out["gains"] >= 1


def test_format_hires_shows_rows_errors_and_ratio():
    row = dict(n_modes=10, modes_s=1.0, first_s=2.0, warm_s=0.1, process_s=4.0, peak_mb=100.0)
    result = {
        "rows": [
            {"samplerate": 384000, "paths": "present", **row},
            {"samplerate": 384000, "paths": "previous", "error": "over 10 s"},
        ],
        "ratio": None,
    }
    text = bench.format_hires(result)
    assert "| 384000 | present | 10 | 1.0 | 2.0 | 0.1 | 4.0 | 100 |" in text
    assert "failed: over 10 s" in text and "previous paths / present" not in text
    result["rows"][1] = {"samplerate": 384000, "paths": "previous", **row, "process_s": 20.0}
    result["ratio"] = 5.0
    assert "previous paths / present paths = 5.0x" in bench.format_hires(result)
