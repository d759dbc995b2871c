"""Robustness, second round: silent wrong results, tracebacks and hangs of issue 28. Every
case here failed before its fix; a hang is run in a subprocess whose timeout is the test's
time limit (the bound is the subprocess timeout, never an assertion on a measured time)."""


import pytest

from synth.cli import main
from synth.errors import ParameterError
from synth.io import cache


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# --------------------------------------------------------------------------- silent wrong


@pytest.mark.parametrize(
    "second", [["--report", "{out}"], ["--plot", "{out}"], ["--report", "./{name}"]]
)
def test_two_outputs_on_one_path_are_refused_before_work(capsys, tmp_path, monkeypatch, second):
    # `-o out.wav --report out.wav` used to exit 0 with the JSON report in out.wav
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out.wav"
    out.write_bytes(b"an earlier render")
    argv = [a.format(out=out, name=out.name) for a in second]
    code, _, err = run(capsys, "render", "default", "-o", out, *argv)
    assert code == 2 and "same file" in err and "output=" in err
    assert out.read_bytes() == b"an earlier render"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.wav"]


@pytest.mark.parametrize("value", ["-1", "lots", "1.5"])
def test_a_bad_cache_bound_is_one_error_for_render_and_cache_info(
    capsys, tmp_path, monkeypatch, value
):
    # render used to switch the disk cache off silently where `synth cache info` refused
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("SYNTH_CACHE_MAX_BYTES", value)
    out = tmp_path / "out.wav"
    code_render, _, err_render = run(capsys, "render", "default", "-o", out)
    code_info, _, err_info = run(capsys, "cache", "info")
    assert code_render == code_info == 2
    assert err_render == err_info and f"SYNTH_CACHE_MAX_BYTES={value!r}" in err_render
    assert not out.exists()
    with pytest.raises(ParameterError, match="SYNTH_CACHE_MAX_BYTES"):
        cache.savez_atomic(tmp_path / "cache" / "x.npz", {})
