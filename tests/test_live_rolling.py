"""A rolling voice of the live engine (``Body.roll``): live equals the offline rolling, its
stop fade, its checks; through a JACK dummy server, updated every 16 ms."""

import threading
import time

import numpy as np
import pytest
from conftest import python_blocks

import synth
from synth.errors import ParameterError
from synth.live import rolling_block as rb
from synth.live import state as st
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


#: The tables' interpolation bound, relative to a mode's largest value: ``(k_b step)^2 / 8``
#: at POINTS_PER_WAVELENGTH rows per bending wavelength (docs/rolling.md).
TABLE_BOUND = (2.0 * np.pi / POINTS_PER_WAVELENGTH) ** 2 / 8.0


def live_rolling(setup, speeds, *, stop_after=None, fade=0.02, tail=0, listener=None,
                 channels=1, move=None):  # fmt: skip
    """The engine's output (float64, (frames, channels)) of a rolling voice whose speed the
    game sets to ``speeds[k]`` at the start of frame ``k`` (its position where the ball is),
    stopped after ``stop_after`` frames, heard by ``listener`` (default the setup's
    microphone), moved to ``move = (frame, listener)``; the voice and the engine."""
    plate, mic, ball, envelope = setup
    engine = synth.Engine(samplerate=FS, blocksize=256, channels=channels, max_rolls=1)
    body = engine.add(plate, listener=mic if listener is None else listener)
    voice = body.roll(ball, ORIGIN + DIRECTION * START, speeds[0] * DIRECTION, envelope=envelope,
                      start=START)  # fmt: skip
    chunks = []
    for k, v in enumerate(speeds):
        if k:
            voice.update(ORIGIN + DIRECTION * voice.path_position, v * DIRECTION)
        if k == stop_after:
            voice.stop(fade=fade)
        if move is not None and k == move[0]:
            body.move(move[1])
        chunks.append(engine.process(FRAME))
    if tail:
        chunks.append(engine.process(tail))
    out = np.concatenate(chunks).astype(float)
    return (out[:, 0] if channels == 1 else out), voice, engine


def offline_rolling(setup, speeds, listener):
    """The offline rolling of ``speeds`` (one per frame) heard by ``listener`` (its
    :func:`rolling_sound` at the live engine's full scale), and the contact. Each speed is
    the one the voice takes from the velocity ``speed * DIRECTION``, its length (within a
    rounding of the speed: the contact's flights follow it to the bit)."""
    plate, _, ball, envelope = setup
    heard = np.hypot(*np.multiply.outer(DIRECTION, speeds))
    contact = rolling.roll(
        ball, plate, envelope, speed=np.repeat(heard, FRAME), samplerate=FS,
        origin=tuple(ORIGIN), direction=tuple(DIRECTION), start=START,
    )  # fmt: skip
    model = listener if hasattr(listener, "poles") else modal_model(plate, listener, samplerate=FS)
    return rolling_sound(contact, model) / PHYSICAL_FULL_SCALE[model.units], contact


def within_table_bound(live, offline):
    """The live signal differs from the offline one by less than the tables' interpolation
    bound relative to the offline signal's RMS."""
    rms = np.sqrt(np.mean(offline**2))
    return rms > 0.0 and np.sqrt(np.mean((live - offline) ** 2)) < TABLE_BOUND * rms


SPEEDS = np.random.default_rng(1).uniform(0.1, 0.6, 20)


def test_a_rolling_voice_is_the_offline_rolling_of_the_same_speeds(setup):
    # the game sets a new speed every 16 ms; offline, roll() of the same speeds per sample
    # and rolling_sound() of its force through the same listener. The contact is the same
    # integration (the offline kernel, the same steps): the ball ends at the same point, bit
    # for bit. The audio differs by the mode shapes' tables only (live: one per update,
    # anchored at the ball; offline: one along the whole path), each interpolated linearly
    # within (k_b step)^2 / 8 of a mode's largest value (docs/rolling.md): the difference
    # is held under that bound relative to the signal's RMS (it is far below it)
    live, voice, _ = live_rolling(setup, SPEEDS)
    offline, contact = offline_rolling(setup, SPEEDS, setup[1])
    assert voice.path_position == contact.final_state.path_position
    assert voice.overruns == 0 and voice.frames == live.size and voice.playing
    assert within_table_bound(live, offline)


def test_a_rolling_voice_through_two_ears_is_each_ears_offline_rolling(setup):
    # a body heard through two ears rolls the voice at each: each channel is the offline
    # rolling heard by that ear's microphone, within the tables' bound (as above). Its
    # contact is integrated once a block, in the first ear's slot: the second ear's slot
    # takes no step and its frames are the voice's (each block rolled once, not per ear)
    ears = synth.live.ears((0.6, 0.3, 0.3))
    live, voice, _ = live_rolling(setup, SPEEDS[:8], listener=ears, channels=2)
    for channel, ear in enumerate(ears):
        offline, contact = offline_rolling(setup, SPEEDS[:8], ear)
        assert within_table_bound(live[:, channel], offline)
    assert voice.path_position == contact.final_state.path_position
    assert not np.allclose(live[:, 0], live[:, 1])  # the ears hear it differently
    first, second = (ear._rolls["roll_ints"][0] for ear in voice.body._ears)
    assert first[rb.I_STEPS] == voice.steps > 0 and second[rb.I_STEPS] == 0
    assert voice.frames == live.shape[0] and second[rb.I_FRAMES] == 0


def test_an_accelerometer_hears_the_rolling_with_its_direct_term(setup):
    # the plate's acceleration at the sensor, its direct term included (the force at the
    # contact point seen by the sensor's own mode shapes), as the offline render's
    # Accelerometer: within the tables' bound (as above)
    sensor = synth.Accelerometer((0.9, 0.4))
    live, voice, _ = live_rolling(setup, SPEEDS[:8], listener=sensor)
    offline, _ = offline_rolling(setup, SPEEDS[:8], sensor)
    assert voice.overruns == 0
    assert within_table_bound(live, offline)


def test_a_listener_moved_while_the_ball_rolls_reaches_the_rolling_voice(setup):
    # the listener moves before frame 4: from the next block (256 frames) the voice is heard
    # by the new one, ramped linearly over that block from the old one's (as the impact
    # voices' gains, heard.py), the modes being the plate's. Offline: the rolling heard by
    # each listener's gains the body holds, crossed over that block; within the tables'
    # bound (as above)
    plate = setup[0]
    before, after = synth.Microphone((0.6, 0.3, 0.2)), synth.Microphone((0.2, 0.5, 0.05))
    engine = synth.Engine(samplerate=FS)
    body = engine.add(plate, listener=before)
    old = body._model
    body.move(after)
    new = body._model  # the gains the engine computes for the moved listener
    live, _, _ = live_rolling(setup, SPEEDS[:8], listener=before, move=(4, after))
    heard_before, _ = offline_rolling(setup, SPEEDS[:8], old)
    heard_after, _ = offline_rolling(setup, SPEEDS[:8], new)
    ramp = np.zeros(live.size)
    at = 4 * FRAME
    ramp[at : at + 256] = np.arange(1, 257) / 256.0
    ramp[at + 256 :] = 1.0
    offline = (1.0 - ramp) * heard_before + ramp * heard_after
    assert within_table_bound(live, offline)
    assert not within_table_bound(live, heard_before)  # the move is heard


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
    assert engine.max_rolls == 0 and engine._native.ctl[st.ROLLER] == 0
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


def _update_like_a_game(voice, seconds: float) -> list[float]:
    """A game's thread updates ``voice`` every 16 ms for ``seconds`` s, then as long again
    while a pure-Python thread spins; returns the monotonic times (s) of the updates, from
    the start on."""
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
    return updates


@pytest.mark.slow  # a JACK server and 4 s of stream
@pytest.mark.xdist_group("jack")  # with tests/test_live_jack.py: one JACK server at a time
def test_a_rolling_voice_updated_every_16_ms_plays_through_jack(setup):
    # the game's thread updates the voice every 16 ms for 2 s, then as long again while a
    # pure-Python thread spins: the stream plays it, every block of its life (the
    # recording, the callback's output, holds its sound in each block from its first to
    # its end, and nothing after), within the callback's deadline (see below); the updates
    # reach the audio thread in time (no table overrun: the table reaches 50 ms ahead, a
    # few frames); stop() fades it out and ends it. PortAudio's underflows are not
    # asserted: on a loaded machine the system runs the client's thread late (flagged an
    # underflow) whether or not the server's own cycle was late, whatever the callback's
    # work; what the callback's work decides is its own run time (its stats)
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
            before = engine.stats
            voice = body.roll(ball, ORIGIN + DIRECTION * START, 0.1 * DIRECTION,
                              envelope=envelope, start=START)  # fmt: skip
            updates = _update_like_a_game(voice, seconds)
            voice.stop(fade=0.02)
            updates.append(time.monotonic() + 0.02)  # it rolls on over the fade
            deadline = time.monotonic() + 2.0
            while voice.playing and time.monotonic() < deadline:
                time.sleep(0.01)
            after = engine.stats
            ended = engine.ended()
        recording = engine.recording
    assert after.callbacks - before.callbacks > 0.9 * 2 * seconds * FS / 256
    # the deadline: the callback's mean run time (its own clock, from its entry to its
    # return, over every block) under one block, or the stream could not keep up with it
    assert after.callback_mean < 1.0
    assert not voice.playing and voice.ended_by == "stop" and ended == [voice.id]
    # a table reaches HORIZON s ahead of its update, taken at most two blocks after it: the
    # ball passes its end only when the game's thread (on a loaded machine) updates later
    reach = HORIZON - 2 * 256 / FS
    late = sum(max(0.0, b - a - reach) for a, b in zip(updates, updates[1:]))
    assert voice.overruns <= late * FS
    assert voice.frames > 2 * seconds * FS * 0.9
    # its sound in every block the voice rolled (none skipped; the fade's raised cosine is
    # above 0 to its last frame but one), silence after: the recording's blocks are the
    # callback's, 256 frames, the voice's first block the first that sounds
    sound = recording[:, 0].astype(float)
    first = int(np.flatnonzero(sound)[0])
    assert first % 256 == 0 and first + voice.frames <= sound.size
    blocks = sound[first : first + voice.frames].reshape(-1, 256)
    assert np.all(np.max(np.abs(blocks), axis=1) > 0.0)
    assert np.all(sound[first + voice.frames :] == 0.0)


def test_the_rolling_example_of_the_docs_runs_as_printed():
    code = python_blocks("docs/live.md")[1]
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
