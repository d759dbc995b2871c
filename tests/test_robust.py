"""Robustness: bad input, extreme numbers, kills and leftovers (every case here failed,
with a traceback, a partial file or a silent wrong result, before its fix)."""

import errno
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_run import run

import synth
from synth import jitcache
from synth.cli import main
from synth.errors import ParameterError, SynthError
from synth.io.presets import PresetError, apply_overrides, load_preset, scene_from_dict
from synth.physics.bounces import simulate_scene
from synth.physics.contact import ENERGY_IMBALANCE, solve_contact
from synth.sound import modal_bank
from synth.sound.modal_bank import pulse
from synth.sound.render import modal_model, render
from synth.store import audio as audio_io

REPO = Path(__file__).resolve().parent.parent


def leftovers(folder: Path) -> list[str]:
    """Temporary files of the engine left in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# --------------------------------------------------------------------------- heavy ball


def test_long_contact_kernel_matches_the_short_one(monkeypatch):
    # the frame-of-the-current-time kernel computes the same transforms: forced on every
    # impact of the default scene, the modal bank's float64 audio (every mode rendered, no
    # omission) agrees with the short kernel's to 1e-12 of its peak (the same quadrature,
    # libm's exponentials instead of vecmath's polynomials: they differ by rounding, 1e-15
    # of the peak here), and not bit for bit (so the long kernel did run; float32
    # audio would round the difference away). impact_excitation chooses the kernel by
    # pulse.long_contact, which the test makes choose the long one.

    scene = load_preset("default")
    sequence = simulate_scene(scene, max_duration=1.0)
    model = modal_model(scene.plate, scene.listener, samplerate=48000)
    impacts = [imp.result for imp in sequence]
    onsets = np.array([imp.time for imp in sequence])
    excitation = model.excitation(scene.position)

    def bank_audio():
        audio, _ = modal_bank.synthesize(
            impacts, onsets, modal_bank.Bank(model.poles, excitation, model.output, 48000),
            floor=0.0, max_samples=48000,
        )  # fmt: skip
        return audio

    a = bank_audio()
    monkeypatch.setattr(pulse, "long_contact", lambda sigma_max, tau: True)
    b = bank_audio()
    assert a.size == b.size and not np.array_equal(a, b)
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))


def test_bowling_ball_renders():
    # a 7 kg ball of 0.109 m radius dropped 1 m on the default board settles in one
    # impact whose contact (sigma_max tau >> 700 Np) overflowed e^(sigma tau) before
    scene = load_preset(
        "default", ["ball.radius=0.109", "ball.mass=7", "drop.height=1", "contact.model=thesis"]
    )
    r = render(scene, samplerate=16000)
    assert len(r.impacts) == 1 and r.impacts.stop_reason == "settled"
    assert np.all(np.isfinite(r.audio)) and np.max(np.abs(r.audio)) > 0.5


# --------------------------------------------------------------------------- ranges


@pytest.mark.parametrize(
    "override, words",
    [
        ("plate.length=1e308", ["plate.length", "1e+308", "<= 100"]),
        ("plate.thickness=1e308", ["plate.thickness", "[1e-06, 100]"]),
        ("drop.height=1e308", ["drop.height", "<= 1000"]),
        ("drop.height=1e-300", ["drop.height", ">= 1e-06"]),
        ("drop.height=1e6", ["drop.height", "<= 1000"]),
        ("ball.mass=1e308", ["ball.mass", "1000]"]),
        ("ball.radius=1e308", ["ball.radius", "[1e-06, 1]"]),
        ("gravity=1e308", ["gravity", "<= 1000"]),
        ("render.preroll=1e6", ["render.preroll", "[0, 10]"]),
        ("render.fade=1e4", ["render.fade", "[0, 10]"]),
        ("render.max_tail=1e9", ["render.max_tail", "(0, 600]"]),
        ("render.max_duration=1e9", ["render.max_duration", "(0, 600]"]),
        ("render.pulse_points=10000000", ["render.pulse_points", "[5, 4097]"]),
        ("render.peak_db=-10000", ["render.peak_db", "[-120, 0]"]),
        ("render.loudness_lufs=-10000", ["render.loudness_lufs", "-120"]),
    ],
)
def test_extreme_numbers_are_refused_before_work(capsys, tmp_path, override, words):
    out = tmp_path / "x.wav"
    code, _, err = run(capsys, "render", "default", "-o", out, "--set", override)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err, (w, err)
    assert not out.exists() and leftovers(tmp_path) == []


def test_peak_db_on_the_command_line_is_checked(capsys, tmp_path):
    code, _, err = run(capsys, "render", "default", "-o", tmp_path / "x.wav", "--peak-db", "-10000")
    assert code == 2 and "peak_db" in err and "-120" in err


def test_bench_repeat_must_be_positive(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "contact", "--repeat", "-5"])
    assert exc.value.code == 2
    assert "--repeat" in capsys.readouterr().err


def test_write_audio_samplerate_range(tmp_path):
    with pytest.raises(ParameterError, match=r"samplerate=1099511627776 .*\[1, 768000\]"):
        audio_io.write_audio(tmp_path / "x.wav", np.zeros(10), 2**40)
    assert leftovers(tmp_path) == []


# --------------------------------------------------------------------------- silent results


def test_silent_render_is_refused():
    scene = load_preset("default")
    with pytest.raises(ParameterError, match="max_frequency=1.0 .*silent"):
        render(scene, samplerate=48000, max_frequency=1.0)


def test_pcm_file_that_would_hold_only_silence_is_refused(tmp_path):
    # 1e-6 of full scale is below half a 16-bit step (2^-16 = 1.5e-5): every sample would
    # be written as 0; exact silence (all zeros) is written as asked
    x = np.full(100, 1e-6)
    with pytest.raises(ParameterError, match="only silence"):
        audio_io.write_audio(tmp_path / "x.wav", x, 48000, subtype="PCM_16")
    audio_io.write_audio(tmp_path / "y.wav", x, 48000, subtype="PCM_24")
    audio_io.write_audio(tmp_path / "z.wav", np.zeros(100), 48000, subtype="PCM_16")


def test_fade_longer_than_the_audio_is_refused():
    scene = load_preset("default")
    with pytest.raises(ParameterError, match="fade=9.0 s is longer than the audio"):
        render(scene, samplerate=8000, fade=9.0)


def test_first_impact_after_max_duration_is_refused():
    # a 100 m drop first touches sqrt(2 h / g) = 4.5 s after release
    scene = load_preset("default", ["drop.height=100"])
    with pytest.raises(ParameterError, match="drop.height=100.0 .*4.515 s.*max_duration=1"):
        render(scene, samplerate=48000, max_duration=1.0)


def test_sequence_of_another_scene_is_refused_and_a_mismatch_accepted():
    from synth.stimuli.sequences import mismatch_sequence

    scene = load_preset("default")
    other = load_preset("thesis-glass17-mdf12")
    with pytest.raises(ParameterError, match="another ball, plate or contact law"):
        render(scene, sequence=simulate_scene(other), samplerate=8000)
    seq = mismatch_sequence(other, scene)  # the other's timing, this scene's contacts
    r = render(scene, sequence=seq, samplerate=8000)
    assert len(r.impacts) == len(seq)


def test_empty_sequence_is_refused():
    from synth.physics.bounces import BounceSequence

    scene = load_preset("default")
    empty = BounceSequence((), "settled", scene.drop_height, scene.gravity)
    with pytest.raises(ParameterError, match="sequence has no impacts"):
        render(scene, samplerate=48000, sequence=empty)


def test_energy_imbalance_is_not_a_success():
    # an admittance of 1e30 m/(N s) ends the contact within the time axis' resolution:
    # the energy balance is off by 100 %, so the result must not claim success
    r = solve_contact(mass=4e-3, stiffness=1e9, admittance=1e30, speed=1.0)
    assert not r.success and r.status == ENERGY_IMBALANCE
    assert "energy balance" in r.message
    ok = solve_contact(mass=4e-3, stiffness=1e9, admittance=1e-3, speed=1.0)
    assert ok.success and ok.energy_residual < 1e-6


# --------------------------------------------------------------------------- presets, --set


def test_set_takes_one_value():
    with pytest.raises(PresetError, match="no line breaks"):
        apply_overrides({}, ["gravity=9.81\nfoo=1"])
    assert apply_overrides({}, ["gravity=9.81"]) == {"gravity": 9.81}


BASE = {
    "ball": {"material": "steel", "radius": 0.005},
    "plate": {"material": "mdf-18", "thickness": 0.018, "length": 1.0, "width": 0.5},
    "drop": {"height": 0.1},
}


@pytest.mark.parametrize(
    "section, key, words",
    [
        ("ball", "radius", ["ball.radius is missing"]),
        ("ball", "material", ["ball.material"]),
        ("plate", "thickness", ["plate.thickness is missing"]),
        ("plate", "width", ["plate.width is missing"]),
        ("drop", "height", ["drop.height"]),
    ],
)
def test_missing_preset_keys_are_named(section, key, words):
    data = {k: dict(v) for k, v in BASE.items()}
    del data[section][key]
    with pytest.raises(PresetError) as exc:
        scene_from_dict(data)
    for w in words:
        assert w in str(exc.value)


def test_inline_material_with_only_density_names_the_missing_key():
    data = {k: dict(v) for k, v in BASE.items()}
    data["ball"]["material"] = {"density": 7800.0}
    with pytest.raises(PresetError, match="ball.material.young is missing"):
        scene_from_dict(data)


# --------------------------------------------------------------------------- outputs


def test_report_onto_a_directory_fails_before_anything_is_written(capsys, tmp_path):
    out = tmp_path / "x.wav"
    out.write_bytes(b"precious")
    (tmp_path / "dir.json").mkdir()
    code, _, err = run(capsys, "render", "default", "-o", out, "--report", tmp_path / "dir.json")
    assert code == 2 and "report=" in err and "is a directory" in err
    assert out.read_bytes() == b"precious"


def test_bad_plot_path_fails_before_the_audio_is_replaced(capsys, tmp_path):
    out = tmp_path / "x.wav"
    out.write_bytes(b"precious")
    code, _, err = run(
        capsys, "render", "default", "-o", out, "--plot", tmp_path / "missing" / "p.png"
    )
    assert code == 2 and "plot=" in err and "does not exist" in err
    assert out.read_bytes() == b"precious"


def test_unwritable_folder_is_a_clean_error(capsys, tmp_path):
    # /proc refuses new files even to root
    code, _, err = run(
        capsys, "render", "default", "-o", tmp_path / "x.wav", "--report", "/proc/report.json"
    )
    assert code == 2 and "report=" in err and "cannot create a file" in err
    assert leftovers(tmp_path) == [] and not (tmp_path / "x.wav").exists()


def test_all_outputs_or_none(capsys, tmp_path, monkeypatch):
    # the report fails (full disk) after the audio was written: the old audio stays, no
    # temporary is left
    from synth.store import atomic

    out = tmp_path / "x.wav"
    out.write_bytes(b"precious")

    def full_disk(path, obj, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(atomic, "write_json_atomically", full_disk)
    code, _, err = run(
        capsys,
        "render",
        "default",
        "-o",
        out,
        "--report",
        tmp_path / "r.json",
        "--samplerate",
        8000,
    )
    assert code == 1 and "No space left on device" in err and len(err.strip().splitlines()) == 1
    assert out.read_bytes() == b"precious" and leftovers(tmp_path) == []
    assert not (tmp_path / "r.json").exists()


def test_sigterm_during_the_write_unwinds_and_cleans(capsys, tmp_path, monkeypatch):
    import soundfile

    real_write = soundfile.write

    def killed_mid_write(file, data, *a, **kw):
        real_write(file, data[: len(data) // 2], *a, **kw)  # half the file is on disk
        os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(soundfile, "write", killed_mid_write)
    out = tmp_path / "x.wav"
    out.write_bytes(b"precious")
    code, _, err = run(capsys, "render", "default", "-o", out, "--samplerate", 8000)
    assert code == 128 + signal.SIGTERM and "SIGTERM" in err
    assert out.read_bytes() == b"precious" and leftovers(tmp_path) == []


def _killed_in_a_weakref_callback():
    # numba's type cache has such callbacks; Python ignores (and prints) their exceptions
    import weakref

    class Held:
        pass

    def killed(_):
        os.kill(os.getpid(), signal.SIGTERM)
        sum(range(10))  # the handler runs here, in the callback

    held = Held()
    ref = weakref.ref(held, killed)
    del held
    assert ref() is None


def _killed_where_a_library_swallows_everything():
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        sum(range(10))  # the handler runs here
    except BaseException:  # noqa: BLE001, S110 - a library that catches every exception
        pass


@pytest.mark.parametrize(
    "swallowed", [_killed_in_a_weakref_callback, _killed_where_a_library_swallows_everything]
)
def test_a_swallowed_sigterm_still_ends_the_command_and_keeps_the_output(
    capsys, tmp_path, monkeypatch, swallowed
):
    # SIGTERM's handler runs wherever the main thread is; where its exception is swallowed
    # the work goes on, but the command ends as terminated, without a traceback, and neither
    # replaces the existing output nor leaves a partial file
    import soundfile

    real_write = soundfile.write

    def write_after_a_swallowed_sigterm(file, data, *a, **kw):
        swallowed()
        real_write(file, data, *a, **kw)

    monkeypatch.setattr(soundfile, "write", write_after_a_swallowed_sigterm)
    out = tmp_path / "x.wav"
    out.write_bytes(b"precious")
    code, _, err = run(capsys, "render", "default", "-o", out, "--samplerate", 8000)
    assert code == 128 + signal.SIGTERM and "SIGTERM" in err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert out.read_bytes() == b"precious" and leftovers(tmp_path) == []
    monkeypatch.undo()
    code, _, _ = run(capsys, "render", "default", "-o", out, "--samplerate", 8000)
    assert code == 0 and out.read_bytes() != b"precious"  # the next command commits again


def test_stale_temporaries_of_dead_writers_are_removed(tmp_path):
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    stale = tmp_path / f".synth-{dead}-0123456789ab.part.wav"
    live = tmp_path / f".synth-{os.getpid()}-0123456789ab.part.wav"
    foreign = tmp_path / ".x.0123456789ab.part.wav"
    for p in (stale, live, foreign):
        p.write_bytes(b"partial")
    audio_io.write_audio(tmp_path / "x.wav", np.zeros(10), 8000)
    assert not stale.exists() and live.exists() and foreign.exists()


@pytest.mark.parametrize("length", [237, 250, 255])
def test_long_output_names(tmp_path, length):
    name = "a" * (length - 4) + ".wav"
    assert len(name.encode()) == length
    p = audio_io.write_audio(tmp_path / name, np.zeros(10), 8000)
    assert p.exists() and leftovers(tmp_path) == []


# --------------------------------------------------------------------------- messages


def test_reading_a_directory_says_so(tmp_path):
    with pytest.raises(audio_io.AudioFileError, match="is a directory"):
        audio_io.read_audio(tmp_path)


def test_system_error_is_made_specific(tmp_path, monkeypatch):
    import shutil
    from collections import namedtuple

    f = tmp_path / "x.wav"
    f.write_bytes(b"RIFF")
    real_open = open

    def denied(path, *a, **kw):
        if Path(path) == f:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, *a, **kw)

    monkeypatch.setattr("builtins.open", denied)
    assert audio_io._system_reason(f, "System error.", reading=True) == "Permission denied"
    monkeypatch.setattr("builtins.open", real_open)
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9, 100))
    assert "no space left" in audio_io._system_reason(f, "System error.", nbytes=10**6)
    assert audio_io._system_reason(f, "Format not recognised.") == "Format not recognised."


# --------------------------------------------------------------------------- numba cache


def test_jit_cache_falls_back_when_nothing_is_writable(tmp_path):
    # a file named __pycache__ cannot be made a folder (not even by root), and /dev/null
    # as home has no .cache
    src = tmp_path / "src"
    src.mkdir()
    (src / "__pycache__").write_text("")
    env = {"HOME": "/dev/null", "XDG_CACHE_HOME": "/dev/null/cache"}
    notes = []

    class Stream:
        def write(self, text):
            notes.append(text)

    chosen = jitcache.configure(env, [src], Stream())
    assert chosen and env["NUMBA_CACHE_DIR"] == chosen and "numba cache" in "".join(notes)
    # a user's own choice and a working in-tree folder are kept
    assert jitcache.configure({"NUMBA_CACHE_DIR": "/x"}, [src], Stream()) is None
    assert jitcache.configure({"HOME": "/dev/null"}, [tmp_path], Stream()) is None


def test_jit_cache_checks_every_folder_that_holds_a_kernel():
    # numba caches each kernel beside its own source: a subpackage left out of the check
    # would fail to compile on an installed package whose folders are read-only
    root = Path(jitcache.__file__).resolve().parent
    kernels = {p.parent for p in root.rglob("*.py") if "numba.njit" in p.read_text()}
    assert kernels and kernels <= set(jitcache._source_dirs())


@pytest.mark.slow
def test_help_without_a_writable_home(tmp_path):
    # an installed copy (its __pycache__ folders unusable) and a home that cannot be
    # written: `synth --help` works and says where the compiled code went
    import shutil

    pkg = tmp_path / "site"
    shutil.copytree(REPO / "synth", pkg / "synth", ignore=shutil.ignore_patterns("__pycache__"))
    for d in [pkg / "synth", *[p for p in (pkg / "synth").rglob("*") if p.is_dir()]]:
        (d / "__pycache__").write_text("")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(
        HOME="/dev/null",
        XDG_CACHE_HOME="/dev/null/cache",
        PYTHONPATH=str(pkg),
        PYTHONDONTWRITEBYTECODE="1",
    )
    proc = subprocess.run(
        [sys.executable, "-c", "import synth.cli; synth.cli.main(['--help'])"],
        check=False,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "usage: synth" in proc.stdout
    assert "note: no writable numba cache folder" in proc.stderr


def test_synth_errors_are_synth_errors():
    # every refusal above is a SynthError (the CLI's one-line error, exit 2)
    assert issubclass(PresetError, SynthError) and issubclass(audio_io.AudioFileError, SynthError)
    assert synth.ParameterError is ParameterError


@pytest.mark.parametrize("suffix", [None, ".probe"])
def test_an_interrupt_just_after_the_temporary_is_created_leaves_nothing(
    tmp_path, monkeypatch, suffix
):
    # a signal handler's exception can come between two bytecodes: here right after
    # os.open created the temporary, before the code that wrote it could note it
    from synth.store import atomic

    real_open = os.open

    def open_then_interrupt(*args, **kwargs):
        real_open(*args, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "open", open_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        with atomic.temporary_sibling(tmp_path / "x.wav", suffix=suffix):
            pass
    monkeypatch.undo()
    assert leftovers(tmp_path) == []


def _render_command(folder: Path) -> list[str]:
    """`synth render default` writing a WAV and its report into ``folder``."""
    out, report = str(folder / "x.wav"), str(folder / "x.json")
    return [sys.executable, "-m", "synth", "render", "default", "-o", out, "--report", report]


@pytest.fixture(scope="module")
def render_seconds(tmp_path_factory):
    """Wall time (s) of an uninterrupted `synth render default` on this machine (the
    caches warmed by a first run), so that the kills below fall inside it."""
    import time

    folder = tmp_path_factory.mktemp("timed")
    subprocess.run(_render_command(folder), cwd=REPO, check=True, capture_output=True)
    start = time.monotonic()
    subprocess.run(_render_command(folder), cwd=REPO, check=True, capture_output=True)
    return time.monotonic() - start


@pytest.mark.slow
@pytest.mark.parametrize("moment", [0.1, 0.6, 0.9, ".part.probe", ".part.wav", ".part.json"])
def test_sigterm_at_any_moment_leaves_no_partial_file(tmp_path, render_seconds, moment):
    # a real `synth render` killed with SIGTERM at a fraction of its run time (importing,
    # rendering) or as soon as a temporary file of the given suffix appears (checking the
    # output paths, writing the WAV, writing the report): it exits cleanly (143, or 0 if it
    # had finished) and leaves either no output or a complete one, and no temporary
    import time

    import soundfile

    out = tmp_path / "x.wav"
    proc = subprocess.Popen(
        _render_command(tmp_path), stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=REPO
    )
    if isinstance(moment, str):
        while proc.poll() is None and not any(n.endswith(moment) for n in leftovers(tmp_path)):
            time.sleep(1e-4)
    else:
        time.sleep(moment * render_seconds)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    # -SIGTERM: killed before the handler was installed (importing) or after it was
    # removed (the outputs written, the interpreter exiting)
    assert proc.returncode in (0, 128 + signal.SIGTERM, -signal.SIGTERM), err.decode()[-2000:]
    assert b"Traceback" not in err
    assert leftovers(tmp_path) == []
    report = tmp_path / "x.json"
    assert out.exists() == report.exists()  # all outputs or none
    if out.exists():
        assert soundfile.info(str(out)).frames > 0 and json.loads(report.read_text())
