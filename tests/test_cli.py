"""Tests of synth.cli: the ``synth`` command line (info, presets, materials, bench parser,
analyze, alter)."""

import json
import math
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from cli_run import run

from synth.cli import build_parser, main
from synth.io.presets import load_preset
from synth.physics.bounces import STOP_REASONS, simulate_scene

REPO = Path(__file__).resolve().parent.parent
DEFAULT = REPO / "synth" / "presets" / "default.toml"
ROW_KEYS = {"n", "time", "speed", "restitution", "contact_time", "peak_force", "inelasticity"}


def data_rows(text):
    """The impact rows of the text table (lines that start with an impact number)."""
    return [line.split() for line in text.splitlines() if re.match(r"^\s*\d+\s+\d", line)]


# --------------------------------------------------------------------------- info


def test_info(capsys):
    # The default preset, the measured model: a 10 mm steel ball at 1.4 m/s (10 cm drop)
    # mid-plate on 18 mm MDF rebounds at the measured e = 0.76 (thesis section 3.2; within
    # 0.02). The table ends with the scheduler's stop reason and counts the rows it printed.
    code, out, err = run(capsys, "info", "default")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == tomllib.loads(DEFAULT.read_text())["description"]
    rows = data_rows(out)
    first = rows[0]
    assert first[0] == "1"
    assert float(first[3]) == pytest.approx(0.76, abs=0.02)
    # Free fall from 0.1 m: t1 = sqrt(2 h / g), v1 = sqrt(2 g h), printed to 5 decimals.
    assert float(first[1]) == pytest.approx(math.sqrt(2 * 0.1 / 9.81), abs=5e-6)
    assert float(first[2]) == pytest.approx(math.sqrt(2 * 9.81 * 0.1), abs=5e-6)
    seq = simulate_scene(load_preset("default"))
    assert seq.stop_reason in STOP_REASONS
    assert lines[-1] == f"{len(rows)} impacts; the sequence ended: {seq.stop_reason}"
    assert len(rows) == len(seq.table())


def test_info_rejects_bad_override(capsys):
    # A negative radius: exit status 2, nothing on stdout, one line on stderr naming the key
    # and the value.
    code, out, err = run(capsys, "info", "default", "--set", "ball.radius=-1")
    assert code == 2
    assert out == ""
    assert len(err.splitlines()) == 1
    assert "ball.radius=-1" in err


def test_info_json(capsys):
    # The JSON output parses; each impact row carries the documented keys; the first impact
    # is free fall from 0.1 m: t1 = sqrt(2 h / g) and v1 = sqrt(2 g h) (closed form, 1e-12 is
    # float rounding); impact times increase and restitution stays in (0, 1] (energy balance).
    code, out, err = run(capsys, "info", "default", "--json")
    assert code == 0 and err == ""
    doc = json.loads(out)
    assert doc["preset"] == "default"
    assert doc["stop_reason"] in STOP_REASONS
    rows = doc["impacts"]
    assert rows and all(ROW_KEYS <= set(r) for r in rows)
    assert [r["n"] for r in rows] == list(range(1, len(rows) + 1))
    assert rows[0]["time"] == pytest.approx(math.sqrt(2 * 0.1 / 9.81), rel=1e-12)
    assert rows[0]["speed"] == pytest.approx(math.sqrt(2 * 9.81 * 0.1), rel=1e-12)
    assert rows[0]["restitution"] == pytest.approx(0.76, abs=0.02)  # measured, section 3.2
    times = [r["time"] for r in rows]
    assert all(b > a for a, b in zip(times, times[1:]))
    assert all(0.0 <= r["restitution"] <= 1.0 for r in rows)
    assert doc["duration"] >= times[-1]


def test_info_json_rejects_unknown_preset(capsys):
    # An unknown preset: status 2, no JSON on stdout, one line naming it and the near name.
    code, out, err = run(capsys, "info", "defualt", "--json")
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1
    assert "'defualt'" in err and "did you mean 'default'" in err


def test_info_override(capsys):
    # --set applies before the simulation: a 5 cm drop first lands at sqrt(2 h / g) (closed
    # form, 1e-12 relative).
    code, out, _ = run(capsys, "info", "default", "--json", "--set", "drop.height=0.05")
    assert code == 0
    assert json.loads(out)["impacts"][0]["time"] == pytest.approx(
        math.sqrt(2 * 0.05 / 9.81), rel=1e-12
    )


@pytest.mark.parametrize(
    "item, part",
    [
        ("ball.radius", "'ball.radius'"),
        ("a.b.c=1", "a.b.c"),
        ("plate.boundary=pinned", "plate.boundary='pinned'"),
    ],
)
def test_info_override_rejects_malformed(capsys, item, part):
    # Malformed or impossible --set items: status 2 and one line on stderr naming the item.
    code, out, err = run(capsys, "info", "default", "--set", item)
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and part in err


def test_info_module_entry_point():
    # `python -m synth info default` runs the same command in a fresh interpreter: status 0,
    # the preset's description first.
    proc = subprocess.run(
        [sys.executable, "-m", "synth", "info", "default"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == tomllib.loads(DEFAULT.read_text())["description"]


def test_info_module_entry_point_rejects_bad_override():
    # The exit status 2 of a bad --set reaches the shell through `python -m synth`.
    proc = subprocess.run(
        [sys.executable, "-m", "synth", "info", "default", "--set", "ball.radius=-1"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert len(proc.stderr.splitlines()) == 1 and "ball.radius=-1" in proc.stderr


# --------------------------------------------------------------------------- presets


def test_presets(capsys):
    # `presets` lists "default" with the description in its file.
    code, out, err = run(capsys, "presets")
    assert code == 0 and err == ""
    desc = tomllib.loads(DEFAULT.read_text())["description"]
    lines = {line.split(maxsplit=1)[0]: line.split(maxsplit=1)[1] for line in out.splitlines()}
    assert lines["default"] == desc


def test_presets_rejects_broken_file(capsys, monkeypatch, tmp_path):
    # A broken file in $SYNTH_PRESETS is listed as unreadable; the command still succeeds.
    (tmp_path / "broken.toml").write_text("description = \n", encoding="utf-8")
    monkeypatch.setenv("SYNTH_PRESETS", str(tmp_path))
    code, out, _ = run(capsys, "presets")
    assert code == 0
    line = next(line for line in out.splitlines() if line.startswith("broken "))
    assert "(unreadable:" in line and str(tmp_path / "broken.toml") in line
    assert any(line.startswith("default ") for line in out.splitlines())


def test_presets_rejects_non_utf8_file(capsys, monkeypatch, tmp_path):
    # A file that is not UTF-8 is a broken preset too: listed as unreadable, status 0.
    (tmp_path / "latin1.toml").write_bytes(b'description = "b\xe9ton"\n')
    monkeypatch.setenv("SYNTH_PRESETS", str(tmp_path))
    code, out, _ = run(capsys, "presets")
    assert code == 0
    line = next(line for line in out.splitlines() if line.startswith("latin1 "))
    assert "(unreadable:" in line


# --------------------------------------------------------------------------- materials


def test_materials(capsys):
    # `materials` lists the thesis' rows with their constants (thesis Table 3.1: steel
    # rho 7800 kg/m^3, E 216 GPa; 18 mm MDF rho 700 kg/m^3, E 5.689 GPa), as printed (4 figures).
    code, out, err = run(capsys, "materials")
    assert code == 0 and err == ""
    rows = {}
    for line in out.splitlines():
        m = re.match(r"^(\S+)\s+rho=\s*(\S+) kg/m\^3\s+E=\s*(\S+) GPa\s+nu=(\S+)", line)
        assert m, line
        rows[m.group(1)] = tuple(float(g) for g in m.group(2, 3, 4))
    assert rows["steel"] == (7800.0, 216.0, 0.3)
    assert rows["mdf-18"] == (700.0, 5.689, 0.4)


def test_materials_rejects_arguments():
    # `materials` takes no argument: argparse exits with status 2.
    with pytest.raises(SystemExit) as info:
        main(["materials", "steel"])
    assert info.value.code == 2


# --------------------------------------------------------------------------- parser


def test_parser_bench_accepts_contact():
    # `synth bench` hands the rest of its command line to the checkout's benchmarks, whose
    # parser reads "contact" and its options (nothing is run here).
    from benchmarks.cli import build_parser as bench_parser

    argv = ["contact", "--repeat", "3", "--tolerances", "1e-3", "1e-6"]
    assert build_parser().parse_args(["bench", *argv]).argv == argv
    args = bench_parser().parse_args(argv)
    assert (args.what, args.repeat, args.tolerances) == ("contact", 3, [1e-3, 1e-6])


def test_bench_outside_a_checkout_says_where_the_benchmarks_are(tmp_path, monkeypatch, capsys):
    # The benchmarks are not installed: outside a source checkout `synth bench` says what
    # they are, where they live and how to run them, in one line, whatever follows it.
    monkeypatch.chdir(tmp_path)
    for argv in (["bench", "contact"], ["bench", "--help"], ["bench"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1, err
        for words in ("benchmarks and validation studies", "source repository", "synth bench NAME"):
            assert words in err, (words, err)
        assert str(tmp_path) in err


def test_bench_finds_the_checkout_from_a_subfolder(tmp_path):
    # The checkout is the nearest folder up with a benchmarks package and a pyproject.toml
    # naming this project; another project's pyproject.toml, or none, is passed over.
    from conftest import REPOSITORY

    from synth.cli.bench import find_checkout

    assert find_checkout(REPOSITORY / "docs") == REPOSITORY
    other = tmp_path / "other"
    (other / "benchmarks").mkdir(parents=True)
    (other / "benchmarks" / "__init__.py").write_text("")
    (other / "pyproject.toml").write_text('[project]\nname = "another-project"\n')
    assert find_checkout(other / "benchmarks") is None
    (other / "pyproject.toml").write_text("not toml [")
    assert find_checkout(other) is None
    (other / "pyproject.toml").write_text('[project]\nname = "impact-synth"\n')
    assert find_checkout(other / "benchmarks") == other.resolve()


@pytest.mark.parametrize(
    "argv",
    [
        ["bench", "plates"],
        ["bench"],
        [],
        ["render-all"],
        ["info"],
        ["bench", "contact", "--repeat", "many"],
    ],
)
def test_parser_rejects_bad_arguments(argv, capsys):
    # Unknown benchmark, missing or unknown subcommand, missing preset, non-integer repeat:
    # argparse exits with status 2 before anything runs.
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert capsys.readouterr().err.strip()


# --------------------------------------------------------------------------- analyze, alter


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """The default preset rendered to a stereo FLAC (the same signal in both channels)
    and the render's impact times, s."""
    import soundfile

    from synth.sound.render import render

    r = render(load_preset("default"), samplerate=44100, max_frequency=12000.0, max_tail=1.0)
    path = tmp_path_factory.mktemp("rec") / "default.flac"
    soundfile.write(path, np.stack([r.audio, r.audio], axis=1), 44100, subtype="PCM_24")
    return path, r.onsets


def test_analyze_command(capsys, rendered, tmp_path):
    # The table, JSON, CSV and plot of one recording: the first five onsets of the render
    # within 0.2 ms (the analysis' requirement; 24-bit FLAC at 44.1 kHz, channel 1).
    path, truth = rendered
    code, out, _ = run(capsys, "analyze", str(path), "--channel", "1")
    assert code == 0
    rows = [line.split() for line in out.splitlines() if re.match(r"^\s*\d+\s+\d", line)]
    assert [float(r[1]) for r in rows[:5]] == pytest.approx(truth[:5], abs=2e-4)
    code, out, _ = run(capsys, "analyze", str(path), "--json")
    data = json.loads(out)
    assert [t["time"] for t in data["ticks"][:5]] == pytest.approx(truth[:5], abs=2e-4)
    assert data["channel"] is None and data["units"]["time"] == "s"
    code, out, _ = run(capsys, "analyze", str(path), "--csv", "--min-separation", "0.002")
    header, *lines = out.splitlines()
    assert header.split(",")[:3] == ["index", "time", "bounce_time"]
    assert float(lines[0].split(",")[1]) == pytest.approx(truth[0], abs=2e-4)
    png = tmp_path / "a.png"
    assert run(capsys, "analyze", str(path), "--plot", str(png))[0] == 0
    assert png.stat().st_size > 10_000


def test_analyze_command_rejects_bad_input(capsys, rendered, tmp_path):
    path, _ = rendered
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"RIFF0000WAVEjunk")
    for argv, words in (
        ([str(bad)], "cannot read"),
        ([str(tmp_path / "none.wav")], "no such file"),
        ([str(path), "--channel", "2"], "channel"),
        ([str(path), "--channel", "left"], "channel"),
        ([str(path), "--min-separation", "-1"], "min_separation"),
    ):
        code, _, err = run(capsys, "analyze", *argv)
        assert code == 2 and words in err, (argv, err)


@pytest.mark.slow
def test_alter_command(capsys, rendered, tmp_path):
    # K = 0.5 halves 1 - e for every bounce: the altered file, analysed, has the new
    # restitution (mean within 1 %) and the same first onset.
    import soundfile

    from synth.analysis import analyze_file

    path, truth = rendered
    out = tmp_path / "half.wav"
    code, text, _ = run(capsys, "alter", str(path), "-o", str(out), "--restitution-scale", "0.5")
    assert code == 0 and str(out) in text
    before = analyze_file(path)
    after = analyze_file(out)
    e0 = np.array([t.restitution for t in before.ticks[2:8]])
    e1 = np.array([t.restitution for t in after.ticks[2:8]])
    assert e1 == pytest.approx(1.0 - 0.5 * (1.0 - e0), rel=0.01)
    assert after.ticks[0].time == pytest.approx(before.ticks[0].time, abs=1e-4)
    assert soundfile.info(out).channels == 2


def test_alter_command_rejects_bad_input(capsys, rendered, tmp_path):
    path, _ = rendered
    for argv, words in (
        (
            [str(path), "-o", str(tmp_path / "x.wav"), "--restitution-scale", "-1"],
            "restitution_scale",
        ),
        (
            [str(path), "-o", str(tmp_path / "x.wav"), "--restitution-scale", "50"],
            "restitution_scale",
        ),
        (
            [str(path), "-o", str(tmp_path / "nodir" / "x.wav"), "--restitution-scale", "0.5"],
            "nodir",
        ),
    ):
        code, _, err = run(capsys, "alter", *argv)
        assert code == 2 and words in err, (argv, err)
        assert not (tmp_path / "x.wav").exists()


# --------------------------------------------------------------------------- render


def test_render_command_options(capsys, tmp_path):
    # Every option reaches the file: rate, subtype, level, overrides, plot and report.
    import soundfile

    out = tmp_path / "x.wav"
    rep = tmp_path / "x.json"
    png = tmp_path / "x.png"
    code, text, err = run(
        capsys,
        "render",
        "default",
        "-o",
        str(out),
        "--samplerate",
        "22050",
        "--subtype",
        "PCM_16",
        "--normalize",
        "peak",
        "--peak-db",
        "-6",
        "--set",
        "drop.height=0.05",
        "--set",
        "render.max_tail=0.5",
        "--floor-db",
        "-60",
        "--max-frequency",
        "5000",
        "--plot",
        str(png),
        "--report",
        str(rep),
    )
    assert code == 0, err
    info = soundfile.info(out)
    assert (info.samplerate, info.subtype, info.channels) == (22050, "PCM_16", 1)
    x, _ = soundfile.read(out)
    assert 20 * math.log10(np.max(np.abs(x))) == pytest.approx(-6.0, abs=0.01)  # 16-bit steps
    data = json.loads(rep.read_text())
    assert data["settings"]["floor_db"] == -60.0 and data["settings"]["max_tail"] == 0.5
    assert data["settings"]["max_frequency"] == 5000.0  # a flag generated from RenderOptions
    assert data["impacts"][0]["speed"] == pytest.approx(math.sqrt(2 * 9.81 * 0.05), rel=1e-12)
    assert png.stat().st_size > 10_000
    assert str(out) in text


def test_render_command_physical_and_none(capsys, tmp_path):
    # physical fits a 24-bit file; none (pascals) needs a float file, and a PCM file that
    # would clip is refused with a one-line message, leaving nothing behind.
    import soundfile

    code, _, err = run(
        capsys, "render", "default", "-o", str(tmp_path / "p.wav"), "--normalize", "physical"
    )
    assert code == 0, err
    x, _ = soundfile.read(tmp_path / "p.wav")
    assert 0.01 < np.max(np.abs(x)) < 1.0
    code, _, err = run(
        capsys,
        "render",
        "default",
        "-o",
        str(tmp_path / "n.wav"),
        "--normalize",
        "none",
        "--subtype",
        "FLOAT",
    )
    assert code == 0, err
    y, _ = soundfile.read(tmp_path / "n.wav")
    assert np.max(np.abs(y)) > 10.0  # pascals: the tick peaks near 100 Pa
    code, _, err = run(
        capsys, "render", "default", "-o", str(tmp_path / "c.wav"), "--normalize", "none"
    )
    assert code == 2 and "clip" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "c.wav").exists()


def test_render_command_loudness(capsys, tmp_path):
    # Integrated loudness (ITU-R BS.1770, pyloudnorm) to the asked target, within 0.1 LU.
    import pyloudnorm
    import soundfile

    out = tmp_path / "l.wav"
    code, _, err = run(
        capsys,
        "render",
        "default",
        "-o",
        str(out),
        "--normalize",
        "loudness",
        "--loudness-lufs",
        "-45",
        "--subtype",
        "FLOAT",
    )
    assert code == 0, err
    x, fs = soundfile.read(out)
    assert pyloudnorm.Meter(fs, block_size=0.4).integrated_loudness(x) == pytest.approx(
        -45.0, abs=0.1
    )


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--samplerate", "1000"], ["samplerate=1000"]),
        (["--set", "render.max_frequency=40000"], ["render.max_frequency=40000", "Nyquist"]),
        (["--set", "ball.radius=-1"], ["ball.radius=-1", "[1e-06, 1]"]),
        (["--peak-db", "3"], ["peak_db=3.0", "in [-120, 0]"]),
        (["--max-impacts", "0"], ["max_impacts=0", "[1, 100000]"]),  # a generated flag
        (["--max-frequency", "30000"], ["max_frequency=30000.0", "Nyquist"]),
    ],
)
def test_render_command_rejects_bad_options(capsys, tmp_path, argv, words):
    out = tmp_path / "bad.wav"
    code, _, err = run(capsys, "render", "default", "-o", str(out), *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1
    for w in words:
        assert w in err, (w, err)
    assert not out.exists()
