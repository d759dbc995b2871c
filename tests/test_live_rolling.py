"""A rolling voice of the live engine (``Body.roll``): live equals the offline rolling, its
stop fade, its checks; through a JACK dummy server, updated every 16 ms."""

import threading
import time

import numpy as np
import pytest

import synth
from synth.errors import ParameterError
from synth.live import native
from synth.live.rolling import HORIZON
from synth.physics import rolling, surface
from synth.physics.scene import Ball
from synth.sound.render import modal_model
from synth.sound.rolling import POINTS_PER_WAVELENGTH, rolling_sound
from synth.store.audio import PHYSICAL_FULL_SCALE

FS = 48000
FRAME = 768  # a game's frame at 62.5 Hz: 16 ms
ORIGIN = np.array([0.2, 0.25])
DIRECTION = np.array([0.8, 0.6])
START = 0.01  # m along the envelope: past its first reach of the ball


@pytest.fixture(scope="module")
def setup():
    plate = synth.Plate("mdf-18", thickness=0.018, length=1.2, width=0.6)
    mic = synth.Microphone((0.6, 0.3, 0.2))
    ball = Ball("steel", 0.01)
    # the caller's roughness (no published value is built in, docs/rolling.md)
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=2e-4, hurst=0.8)
    profile = surface.rough_profile(spec, length=0.3, spacing=5e-6, seed=1)
    return plate, mic, ball, surface.contact_envelope(profile, ball.radius)


def live_rolling(setup, speeds, *, stop_after=None, fade=0.02, tail=0):
    """The engine's output (float64) of a rolling voice whose speed the game sets to
    ``speeds[k]`` at the start of frame ``k`` (its position where the ball is), stopped
    after ``stop_after`` frames; and the voice."""
    plate, mic, ball, envelope = setup
    engine = synth.Engine(samplerate=FS, blocksize=256, max_rolls=1)
    body = engine.add(plate, listener=mic)
    voice = body.roll(ball, ORIGIN + DIRECTION * START, speeds[0] * DIRECTION, envelope=envelope,
                      start=START)  # fmt: skip
    chunks = []
    for k, v in enumerate(speeds):
        if k:
            voice.update(ORIGIN + DIRECTION * voice.path_position, v * DIRECTION)
        if k == stop_after:
            voice.stop(fade=fade)
        chunks.append(engine.process(FRAME)[:, 0])
    if tail:
        chunks.append(engine.process(tail)[:, 0])
    return np.concatenate(chunks).astype(float), voice, engine


def test_a_rolling_voice_is_the_offline_rolling_of_the_same_speeds(setup):
    # the game sets a new speed every 16 ms; offline, roll() of the same speeds per sample
    # and rolling_sound() of its force through the same listener. The contact is the same
    # integration (the offline kernel, the same steps): the ball ends at the same point, bit
    # for bit. The audio differs by the mode shapes' tables only (live: one per update,
    # anchored at the ball; offline: one along the whole path), each interpolated linearly
    # within (k_b step)^2 / 8 of a mode's largest value (docs/rolling.md): the difference
    # is held under that bound relative to the signal's RMS (it is far below it)
    plate, mic, ball, envelope = setup
    speeds = np.random.default_rng(1).uniform(0.1, 0.6, 20)
    live, voice, _ = live_rolling(setup, speeds)
    contact = rolling.roll(
        ball, plate, envelope, speed=np.repeat(speeds, FRAME), samplerate=FS,
        origin=tuple(ORIGIN), direction=tuple(DIRECTION), start=START,
    )  # fmt: skip
    model = modal_model(plate, mic, samplerate=FS)
    offline = rolling_sound(contact, model) / PHYSICAL_FULL_SCALE[model.units]
    assert voice.path_position == contact.final_state.path_position
    assert voice.overruns == 0 and voice.frames == live.size and voice.playing
    bound = (2.0 * np.pi / POINTS_PER_WAVELENGTH) ** 2 / 8.0
    rms = np.sqrt(np.mean(offline**2))
    assert rms > 0.0
    assert np.sqrt(np.mean((live - offline) ** 2)) < bound * rms


def test_stop_fades_the_rolling_out_with_a_raised_cosine_then_ends_it(setup):
    # stopped at the start of frame 6, the voice is the unstopped one times a raised cosine
    # over the fade (no step: no click), then silence; its id is reported ended. float32
    # output: to its rounding
    speeds = np.full(10, 0.3)
    fade = 0.02
    on, _, _ = live_rolling(setup, speeds)
    off, voice, engine = live_rolling(setup, speeds, stop_after=6, fade=fade, tail=256)
    n = int(round(fade * FS))
    at = 6 * FRAME
    window = np.ones(on.size)
    window[at : at + n] = 0.5 * (1.0 + np.cos(np.pi * np.arange(n) / n))
    window[at + n :] = 0.0
    assert np.allclose(off[: on.size], on * window, rtol=0, atol=1e-6 * np.abs(on).max())
    assert np.all(off[at + n :] == 0.0)
    assert not voice.playing and voice.ended_by == "stop"
    assert engine.ended() == [voice.id]


def test_a_full_body_refuses_a_rolling_voice_and_counts_it(setup):
    plate, mic, ball, envelope = setup
    engine = synth.Engine(samplerate=FS, max_rolls=1)
    body = engine.add(plate, listener=mic)
    first = body.roll(ball, (0.5, 0.3), (0.2, 0.0), envelope=envelope, start=START)
    assert first is not None and first.playing
    assert body.roll(ball, (0.5, 0.3), (0.2, 0.0), envelope=envelope, start=START) is None
    assert body.rolls_refused == 1
    first.stop(fade=0.001)
    engine.process(512)
    assert not first.playing
    assert body.roll(ball, (0.5, 0.3), (0.2, 0.0), envelope=envelope, start=START) is not None


def test_the_voice_ends_at_the_end_of_its_surface(setup):
    plate, mic, ball, envelope = setup
    engine = synth.Engine(samplerate=FS, max_rolls=1)
    body = engine.add(plate, listener=mic)
    # 1 m/s from 2 mm before the envelope's end: it reaches it within a few blocks
    voice = body.roll(ball, (0.5, 0.3), (1.0, 0.0), envelope=envelope,
                      start=envelope.length - 0.002)  # fmt: skip
    engine.process(4800)
    assert not voice.playing and voice.ended_by == "surface"
    assert engine.ended() == [voice.id]


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda b, ball, e: b.roll(ball, (0.5, 0.3), (6.0, 0.0), envelope=e),
         r"velocity=\(6\.0, 0\.0\) has speed 6\.0 m/s: it must be at most 5\.0"),
        (lambda b, ball, e: b.roll(ball, (1.5, 0.3), (1.0, 0.0), envelope=e), r"position"),
        (lambda b, ball, e: b.roll(ball, (0.5, 0.3), (1.0,), envelope=e), r"velocity"),
        (lambda b, ball, e: b.roll(ball, (0.5, 0.3), (1.0, 0.0), envelope=e, gain=-1.0),
         r"gain=-1\.0"),
        (lambda b, ball, e: b.roll(ball, (0.5, 0.3), (1.0, 0.0), envelope=e, start=1.0),
         r"start=1\.0"),
        (lambda b, ball, e: b.roll(Ball("steel", 0.005), (0.5, 0.3), (1.0, 0.0), envelope=e),
         r"envelope\.radius=0\.01 must be the ball's radius 0\.005"),
        (lambda b, ball, e: b.roll(ball, (0.5, 0.3), (1.0, 0.0), envelope=e).update(
            (0.5, 0.3), (float("nan"), 0.0)), r"velocity"),
        (lambda b, ball, e: b.roll(ball, (0.5, 0.3), (1.0, 0.0), envelope=e).stop(fade=20.0),
         r"fade=20\.0"),
    ],
)  # fmt: skip
def test_bad_rolling_input_raises_naming_the_field(setup, call, match):
    plate, mic, ball, envelope = setup
    engine = synth.Engine(samplerate=FS, max_rolls=1)
    body = engine.add(plate, listener=mic)
    with pytest.raises(ParameterError, match=match):
        call(body, ball, envelope)


def test_max_rolls_is_checked_and_an_engine_without_slots_refuses_to_roll(setup):
    plate, mic, ball, envelope = setup
    with pytest.raises(ParameterError, match=r"max_rolls=17"):
        synth.Engine(samplerate=FS, max_rolls=17)
    # by default an engine holds no rolling slots, and its callback no rolling code: a
    # roll is refused with the setting to change, not returned as None (a full body's)
    engine = synth.Engine(samplerate=FS)
    assert engine.max_rolls == 0 and engine._native.ctl[native.ROLLER] == 0
    body = engine.add(plate, listener=mic)
    with pytest.raises(ParameterError, match=r"max_rolls=0: .* max_rolls=1"):
        body.roll(ball, (0.5, 0.3), (0.2, 0.0), envelope=envelope, start=START)
    assert body.rolls_refused == 0


def busy_python(stop):
    """A game's own loop: pure Python that never sleeps."""
    x = 0
    while not stop.is_set():
        for i in range(1000):
            x += i * i


@pytest.mark.slow  # a JACK server and 4 s of stream
def test_a_rolling_voice_updated_every_16_ms_plays_through_jack(setup):
    # the game's thread updates the voice every 16 ms for 2 s, then as long again while a
    # pure-Python thread spins: the stream plays it (its recording holds the rolling's
    # sound), with no underflow but those of the server's own late cycles (its timer thread
    # run late by the system flags every client's output whatever its work); the updates
    # reach the audio thread in time (no table overrun: the table reaches 50 ms ahead, a
    # few frames); stop() fades it out and ends it
    from benchmarks.jack import JackDummyServer, jackd_available

    if not jackd_available():
        pytest.skip("jackd is not installed (Debian: apt-get install jackd2)")
    try:
        import sounddevice  # noqa: F401
    except OSError as exc:
        pytest.skip(f"PortAudio is not installed: {exc}")
    plate, mic, ball, _ = setup
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=2e-4, hurst=0.8)
    profile = surface.rough_profile(spec, length=0.5, spacing=5e-6, seed=2)
    envelope = surface.contact_envelope(profile, ball.radius)  # 4 s at about 0.1 m/s
    seconds = 2.0
    with JackDummyServer(samplerate=FS, period=256) as server:
        engine = synth.Engine(samplerate=FS, blocksize=256, device=server.device, max_rolls=1,
                              record_seconds=2 * seconds + 1.0)  # fmt: skip
        body = engine.add(plate, listener=mic)
        with engine:
            late0, before = server.late_cycles(), engine.stats
            voice = body.roll(ball, ORIGIN + DIRECTION * START, 0.1 * DIRECTION,
                              envelope=envelope, start=START)  # fmt: skip
            stop = threading.Event()

            updates = [time.monotonic()]

            def game():
                k = 0
                while not stop.is_set():
                    time.sleep(0.016)
                    k += 1
                    speed = 0.1 + 0.03 * np.sin(k / 10.0)
                    voice.update(ORIGIN + DIRECTION * voice.path_position, speed * DIRECTION)
                    updates.append(time.monotonic())

            loop = threading.Thread(target=game)
            loop.start()
            time.sleep(seconds)
            stop_busy = threading.Event()
            busy = threading.Thread(target=busy_python, args=(stop_busy,))
            busy.start()
            time.sleep(seconds)
            stop_busy.set()
            busy.join()
            stop.set()
            loop.join()
            voice.stop(fade=0.02)
            updates.append(time.monotonic() + 0.02)  # it rolls on over the fade
            deadline = time.monotonic() + 2.0
            while voice.playing and time.monotonic() < deadline:
                time.sleep(0.01)
            after, late = engine.stats, server.late_cycles() - late0
            ended = engine.ended()
        recording = engine.recording
    assert after.callbacks - before.callbacks > 0.9 * 2 * seconds * FS / 256
    assert after.output_underflows - before.output_underflows <= late
    assert not voice.playing and voice.ended_by == "stop" and ended == [voice.id]
    # a table reaches HORIZON s ahead of its update, taken at most two blocks after it: the
    # ball passes its end only when the game's thread (on a loaded machine) updates later
    reach = HORIZON - 2 * 256 / FS
    late = sum(max(0.0, b - a - reach) for a, b in zip(updates, updates[1:]))
    assert voice.overruns <= late * FS
    assert voice.frames > 2 * seconds * FS * 0.9
    assert np.sqrt(np.mean(recording[: int(2 * seconds * FS)].astype(float) ** 2)) > 0.0


def test_the_rolling_example_of_the_docs_runs_as_printed():
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / "docs" / "live.md").read_text()
    code = [part.split("```", 1)[0] for part in text.split("```python")[1:]][1]
    assert "floor.roll(" in code
    namespace = {}
    exec(compile(code, "docs/live.md", "exec"), namespace)
    rolling, engine = namespace["rolling"], namespace["engine"]
    assert np.max(np.abs(namespace["audio"])) > 0.0
    assert rolling.overruns == 0 and rolling.frames == 30 * 768
    engine.process(4800)
    assert not rolling.playing and engine.ended() == [rolling.id]


def test_a_removed_body_fades_its_rolling_voice_out_then_is_freed(setup):
    plate, mic, ball, envelope = setup
    engine = synth.Engine(samplerate=FS, max_rolls=1)
    body = engine.add(plate, listener=mic)
    voice = body.roll(ball, (0.5, 0.3), (0.2, 0.0), envelope=envelope, start=START)
    engine.process(1024)
    body.remove(fade=0.01)
    assert body.awake  # it still fades out
    engine.process(2048)
    assert not voice.playing and voice.ended_by == "stop" and engine.ended() == [voice.id]
    engine.process(256)
    assert body.memory == 0 and engine.bodies == ()
    voice.update((0.5, 0.3), (0.2, 0.0))  # a late update of the game does nothing
