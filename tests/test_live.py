"""The live engine without a device: ``Engine.process`` against ``synth.render`` of the same
impacts, its limits, and its checks of every argument."""

import builtins
import os
import sys
from pathlib import Path

import numpy as np
import pytest

import synth
from synth.errors import ParameterError, SynthError
from synth.live.voice import HIT_RTOL
from synth.physics.bounces import BounceSequence, Impact
from synth.physics.contact import solve_impact

FS = 48000
PRE = 0.005  # s: the first tick's start, in the render (preroll) and live (at)
EXACT_DB = -200.0  # an omission floor far below float32 resolution


@pytest.fixture(scope="module")
def scene():
    # the thesis' model (the impedance plate, as a live body's hits): hits and renders compared
    return synth.load_preset("default", ["contact.model=thesis"])


@pytest.fixture(scope="module")
def accel_scene():
    s = synth.load_preset("default", ["contact.model=thesis"])
    return synth.Scene(
        s.ball,
        s.plate,
        drop_height=s.drop_height,
        position=(0.4, 0.2),
        listener=synth.Accelerometer((0.9, 0.3)),
        contact=s.contact,
    )


def float32_ulp_of_peak(x):
    """Half an ulp of float32 at the signal's peak: the rounding of its last conversion."""
    return float(np.spacing(np.float32(np.max(np.abs(x)))))


def rendered(scene, sequence=None, **kw):
    """The scene's render in the engine's level (normalize="physical"), exact tails."""
    return synth.render(
        scene,
        samplerate=FS,
        normalize="physical",
        floor_db=kw.pop("floor_db", EXACT_DB),
        fade=0.0,
        preroll=PRE,
        sequence=sequence,
        **kw,
    )


def hits_sequence(scene, times, speeds):
    """A BounceSequence of single hits at ``times`` (s) with ``speeds`` (m/s), solved as
    Body.hit solves them."""
    impacts = tuple(
        Impact(
            i + 1,
            t,
            v,
            solve_impact(scene.ball, scene.plate, v, position=scene.position, rtol=HIT_RTOL),
            0.5,
        )
        for i, (t, v) in enumerate(zip(times, speeds))
    )
    return BounceSequence(impacts, "max-impacts", 1.0, 9.81)


@pytest.mark.slow
def test_a_drop_played_live_is_the_render(scene):
    # both are the exact modal sum (the floor far below float32's resolution); the live
    # bank advances its state from block boundaries instead of tiles, which changes only
    # float64 rounding: the float32 outputs agree to the last conversion's rounding
    r = rendered(scene)
    engine = synth.Engine(samplerate=FS, blocksize=256, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    onsets = body.drop(
        scene.ball, scene.drop_height, position=scene.position, at=PRE, contact=scene.contact
    ).onsets
    assert len(onsets) == r.settings["n_impacts"]
    live = engine.process(r.audio.size)[:, 0]
    assert engine.stats.impacts_played == len(onsets)
    np.testing.assert_allclose(live, r.audio, rtol=0, atol=float32_ulp_of_peak(r.audio))


def test_hits_in_the_middle_of_blocks_are_the_render(scene):
    # onsets at arbitrary sub-sample times, several in one block and overlapping tails:
    # the same exact sum as the offline bank's
    times = np.array([0.0, 0.00123457, 0.0029, 0.0311, 0.03113, 0.1207])
    speeds = [1.5, 0.3, 0.8, 1.2, 0.05, 0.6]
    r = rendered(scene, hits_sequence(scene, times, speeds))
    engine = synth.Engine(samplerate=FS, blocksize=128, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    for t, v in zip(times, speeds):
        assert (
            body.hit(
                scene.ball, v, position=scene.position, at=PRE + t, contact=scene.contact
            ).onset
            == PRE + t
        )
    live = engine.process(r.audio.size)[:, 0]
    np.testing.assert_allclose(live, r.audio, rtol=0, atol=float32_ulp_of_peak(r.audio))


def test_hits_of_a_hollow_ball_are_the_render(scene):
    # a table tennis ball's shell law: the live slot takes its pulse from the shell
    # kernel's dense output, as the offline bank does
    ball = synth.HollowBall("abs", 0.02, thickness=5.2e-4)
    hollow = synth.Scene(
        ball, scene.plate, drop_height=0.3, position=scene.position, listener=scene.listener
    )
    times, speeds = np.array([0.0, 0.0107, 0.05]), [2.4, 0.7, 1.1]
    r = rendered(hollow, hits_sequence(hollow, times, speeds))
    engine = synth.Engine(samplerate=FS, blocksize=256, floor_db=EXACT_DB)
    body = engine.add(hollow.plate, listener=hollow.listener)
    for t, v in zip(times, speeds):
        body.hit(ball, v, position=hollow.position, at=PRE + t)
    live = engine.process(r.audio.size)[:, 0]
    assert engine.stats.impacts_played == len(times)
    np.testing.assert_allclose(live, r.audio, rtol=0, atol=float32_ulp_of_peak(r.audio))


def test_a_drop_with_another_contact_law_and_gravity_is_the_render(scene):
    # the drop takes a scene's contact model and gravity: Hunt-Crossley damping on the Moon
    moon = synth.Scene(
        scene.ball,
        scene.plate,
        drop_height=0.05,
        position=(0.3, 0.2),
        gravity=1.62,
        contact=synth.Contact("hunt-crossley", dissipation=0.2),
    )
    r = rendered(moon)
    engine = synth.Engine(samplerate=FS, floor_db=EXACT_DB)
    body = engine.add(moon.plate, listener=moon.listener)
    onsets = body.drop(
        moon.ball,
        moon.drop_height,
        position=moon.position,
        at=PRE,
        contact=moon.contact,
        gravity=moon.gravity,
    ).onsets
    assert len(onsets) == r.settings["n_impacts"]
    live = engine.process(r.audio.size)[:, 0]
    np.testing.assert_allclose(live, r.audio, rtol=0, atol=float32_ulp_of_peak(r.audio))


def test_several_bodies_add_up(scene, accel_scene):
    # each body is its own modal bank; the output is their sum (a microphone over one
    # plate and an accelerometer on another), each in its physical calibration
    a = rendered(scene)
    b = rendered(accel_scene)
    n = max(a.audio.size, b.audio.size)
    want = np.zeros(n)
    want[: a.audio.size] += a.audio
    want[: b.audio.size] += b.audio
    engine = synth.Engine(samplerate=FS, floor_db=EXACT_DB)
    for s in (scene, accel_scene):
        engine.add(s.plate, listener=s.listener).drop(
            s.ball, s.drop_height, position=s.position, at=PRE, contact=s.contact
        )
    live = engine.process(n)[:, 0]
    tol = float32_ulp_of_peak(a.audio) + float32_ulp_of_peak(b.audio) + float32_ulp_of_peak(want)
    np.testing.assert_allclose(live, want, rtol=0, atol=tol)


def test_default_floor_keeps_within_its_budget(scene):
    # the render and the engine each leave out at most floor * reference at any sample
    # (modal_bank's budget; the reference is the loudest impact's, the first of a drop)
    r = synth.render(scene, samplerate=FS, normalize="physical", fade=0.0, preroll=PRE)
    engine = synth.Engine(samplerate=FS)
    engine.add(scene.plate, listener=scene.listener).drop(
        scene.ball, scene.drop_height, position=scene.position, at=PRE, contact=scene.contact
    )
    live = engine.process(r.audio.size)[:, 0]
    budget = 10 ** (-80 / 20) * r.settings["reference_amplitude"] * r.gain
    assert np.max(np.abs(live - r.audio)) <= 2 * budget + float32_ulp_of_peak(r.audio)


def test_fewer_pulse_points_stay_below_the_floor(scene):
    # a coarser pulse grid makes hit() cheaper; its transform error is of order h^3.5 (see
    # modal_bank): 23 points instead of 65 multiply it by about (65/23)^3.5 = 38, from below
    # 2e-6 of the impulse to below 1e-4, which keeps the ticks within -60 dB of the loudest
    # (measured: -76 dB on the default scene)
    times, speeds = np.array([0.0, 0.05]), [1.5, 0.7]
    r = rendered(scene, hits_sequence(scene, times, speeds))
    engine = synth.Engine(samplerate=FS, floor_db=EXACT_DB, pulse_points=5)
    body = engine.add(scene.plate, listener=scene.listener)
    for t, v in zip(times, speeds):
        body.hit(scene.ball, v, position=scene.position, at=PRE + t, contact=scene.contact)
    live = engine.process(r.audio.size)[:, 0]
    assert 0 < np.max(np.abs(live - r.audio)) < 1e-3 * r.settings["reference_amplitude"] * r.gain


def test_a_quiet_body_sleeps_and_silence_is_exact(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    assert not body.awake
    assert not np.any(engine.process(1024))
    body.hit(scene.ball, 1.0)
    assert body.awake and body.pending == 1
    engine.process(FS * 4)  # the default plate's tail falls below -80 dB in ~1 s
    assert not body.awake
    assert not np.any(engine.process(512))


def test_stop_all_silences_a_body(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    body.hit(scene.ball, 1.0)
    assert np.any(engine.process(2048))
    body.hit(scene.ball, 1.0)
    body.stop_all()
    assert body.pending == 0 and not body.awake
    assert not np.any(engine.process(2048))


def test_a_full_ring_refuses_and_counts(scene):
    engine = synth.Engine(samplerate=FS, max_pending=2)
    body = engine.add(scene.plate, listener=scene.listener)
    assert body.hit(scene.ball, 1.0) is not None
    assert body.hit(scene.ball, 1.0) is not None
    assert body.hit(scene.ball, 1.0) is None
    assert engine.stats.impacts_refused == 1 and engine.stats.impacts_pending == 2
    engine.process(1024)
    assert engine.stats.impacts_played == 2
    assert body.hit(scene.ball, 1.0) is not None  # room again once played


def silence(ring):
    """stop_all (kernel.silence) at once of a body of 3 modes and one voice slot whose
    pending ring is ``ring``; returns the engine's event ring."""
    from synth.live import native
    from synth.live import state as st

    state = st.EngineState(st.EngineOptions(samplerate=FS, max_bodies=1, callback="python"))
    c = synth.sound.modal_bank.bank_coefficients(
        np.array([-1.0 + 100.0j] * 3), np.ones(3), np.ones(3), float(FS)
    )
    index = state.add_body(c, np.ones(3), ring, st.BodySettings())
    native.silence_body(state.ctl, state.records[index][0])
    return state.events


def test_a_slot_being_filled_is_neither_played_nor_dropped():
    # a producer owns a reserved slot until it publishes it: the audio thread skips it
    # and stop_all (which drops READY slots) leaves it alone, so no other producer can
    # take it while it is written
    from synth.live.kernel import FREE
    from synth.live.voice import WRITING, PendingRing

    ring = PendingRing(2, 3, 4, 5, 2)
    i = ring.reserve()
    assert ring.state[i] == WRITING and ring.pending() == 0
    silence(ring)
    assert ring.state[i] == WRITING
    j = ring.reserve()
    assert j != i and ring.reserve() == -1 and ring.refused == 1
    ring.publish(i, 10, 5, 2, 1.0)
    ring.release(j)
    assert ring.pending() == 1 and np.count_nonzero(ring.state == FREE) == 1


def test_waiting_pulses_are_bounded_and_silence_frees_the_bound():
    # the audio thread transforms the pulses handed over since its last block: at most
    # max_new wait at a time (a bound on any block's work); a transform or stop_all's
    # dropping of a pulse frees its place. Without a deadline (bounded=False) the ring
    # alone bounds them.
    from synth.live.voice import PendingRing

    ring = PendingRing(8, 3, 4, 7, 3)
    slots = [ring.reserve(pulse=True) for _ in range(4)]
    assert slots[3] == -1 and ring.refused == 1
    for i in slots[:3]:
        ring.publish(i, 10, 5, 2, points=5)
    assert ring.pending() == 3
    silence(ring)
    assert ring.pending() == 0 and ring.transformed[0] == 3
    assert all(ring.reserve(pulse=True) >= 0 for _ in range(3))
    assert ring.reserve(pulse=True) == -1
    assert ring.reserve(pulse=True, bounded=False) >= 0


def test_hits_without_a_stream_are_bounded_by_the_ring_alone(scene):
    engine = synth.Engine(samplerate=FS, max_pending=8, max_hits_per_block=3)
    body = engine.add(scene.plate, listener=scene.listener)
    assert [body.hit(scene.ball, 1.0) is not None for _ in range(9)] == [True] * 8 + [False]
    engine.process(FS // 10)
    assert engine.stats.impacts_played == 8 and engine.stats.impacts_refused == 1
    with pytest.raises(ParameterError, match="max_hits_per_block"):
        synth.Engine(samplerate=FS, max_pending=8, max_hits_per_block=9)


def test_contacts_too_long_for_a_slot_are_transformed_on_the_calling_thread(scene, monkeypatch):
    # a contact whose pulse grid exceeds a slot's (a soft ball) takes the drop's path, the
    # transform on the calling thread: the same transform, so the result is the render
    from synth.live import body as live_body

    monkeypatch.setattr(live_body, "MAX_SLOT_GRID", 5)  # every contact is too long
    monkeypatch.setattr(live_body, "SLOT_CONTACT", 1e-6)
    times = np.array([0.0, 0.0029, 0.0311])
    speeds = [1.5, 0.8, 0.6]
    r = rendered(scene, hits_sequence(scene, times, speeds))
    engine = synth.Engine(samplerate=FS, blocksize=128, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    for t, v in zip(times, speeds):
        body.hit(scene.ball, v, position=scene.position, at=PRE + t, contact=scene.contact)
    assert body._ring.pulses == 0 and body.pending == 3
    live = engine.process(r.audio.size)[:, 0]
    np.testing.assert_allclose(live, r.audio, rtol=0, atol=float32_ulp_of_peak(r.audio))


def test_prepared_points_play_as_unprepared_ones(scene):
    # prepare() only computes ahead what a hit at a new point computes itself
    a = synth.Engine(samplerate=FS)
    b = synth.Engine(samplerate=FS)
    body_a = a.add(scene.plate, listener=scene.listener)
    body_b = b.add(scene.plate, listener=scene.listener)
    body_b.prepare((0.3, 0.2), (0.7, 0.4))
    for body in (body_a, body_b):
        body.hit(scene.ball, 1.2, position=(0.3, 0.2), at=0.001)
        body.hit(scene.ball, 0.8, position=(0.7, 0.4), at=0.004)
    np.testing.assert_array_equal(a.process(4096), b.process(4096))
    with pytest.raises(ParameterError, match="position"):
        body_b.prepare((5.0, 0.2))


def test_a_refused_hit_takes_no_slot(scene):
    engine = synth.Engine(samplerate=FS, max_pending=1)
    body = engine.add(scene.plate, listener=scene.listener)
    with pytest.raises(ParameterError, match="speed"):
        body.hit(scene.ball, -1.0)
    assert body.hit(scene.ball, 1.0) is not None  # the only slot is still free


def test_default_start_is_one_block_ahead(scene):
    # without a stream the clock is the next frame to mix; a hit starts one block later
    engine = synth.Engine(samplerate=FS, blocksize=256)
    body = engine.add(scene.plate)
    engine.process(1000)
    assert body.hit(scene.ball, 1.0).onset == (1000 + 256) / FS
    assert engine.time == 1000 / FS


def test_channels_carry_the_mono_mix(scene):
    engine = synth.Engine(samplerate=FS, channels=2)
    engine.add(scene.plate).hit(scene.ball, 1.0, at=0.0)
    out = engine.process(4096)
    assert out.shape == (4096, 2) and out.dtype == np.float32
    assert np.any(out) and np.array_equal(out[:, 0], out[:, 1])


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(samplerate=1000), "samplerate"),
        (dict(samplerate=48000.0), "samplerate"),
        (dict(blocksize=0), "blocksize"),
        (dict(blocksize=True), "blocksize"),
        (dict(device=1.5), "device"),
        (dict(latency="fast"), "latency"),
        (dict(latency=-1.0), "latency"),
        (dict(channels=0), "channels"),
        (dict(floor_db=0.0), "floor_db"),
        (dict(max_pending=0), "max_pending"),
        (dict(fade=0.0), "fade"),
        (dict(handover=-1.0), "handover"),
        (dict(record_seconds=-1.0), "record_seconds"),
        (dict(pulse_points=4), "pulse_points"),
        (dict(max_frequency=0.0), "max_frequency"),
        (dict(max_frequency=30000.0), "max_frequency"),
        (dict(max_voices=0), "max_voices"),
        (dict(max_voices=257), "max_voices"),
        (dict(max_total_voices=65537), "max_total_voices"),
        (dict(on_device_lost="print"), "on_device_lost"),
    ],
)
def test_engine_rejects_bad_arguments(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        synth.Engine(**{"samplerate": FS, **kwargs})


def test_add_hit_drop_reject_bad_arguments(scene):
    engine = synth.Engine(samplerate=FS)
    with pytest.raises(ParameterError, match="plate"):
        engine.add("plate")
    with pytest.raises(ParameterError, match="listener"):
        engine.add(scene.plate, listener=(0.1, 0.1, 0.2))
    with pytest.raises(ParameterError, match="listener.position"):
        engine.add(scene.plate, listener=synth.Accelerometer((5.0, 0.1)))
    with pytest.raises(ParameterError, match="gain"):
        engine.add(scene.plate, gain=0.0)
    body = engine.add(scene.plate)
    ball = scene.ball
    for call, name in [
        (lambda: body.hit("ball", 1.0), "ball"),
        (lambda: body.hit(synth.Ball("steel", radius=0.3), 1.0), "ball.radius"),
        (lambda: body.hit(ball, 0.0), "speed"),
        (lambda: body.hit(ball, float("nan")), "speed"),
        (lambda: body.hit(ball, 1.0, position=(9.0, 0.1)), "position"),
        (lambda: body.hit(ball, 1.0, position="middle"), "position"),
        (lambda: body.hit(ball, 1.0, gain=-1.0), "gain"),
        (lambda: body.hit(ball, 1.0, at=-1.0), "at"),
        (lambda: body.hit(ball, 1.0, at=float("inf")), "at"),
        (lambda: body.drop(None, 0.1), "ball"),
        (lambda: body.drop(ball, -0.1), "height"),
        (lambda: body.drop(ball, 0.1, position=(0.1, 7.0)), "position"),
        (lambda: body.drop(ball, 0.1, gain=float("nan")), "gain"),
        (lambda: body.drop(ball, 0.1, at="soon"), "at"),
        (lambda: body.drop(ball, 0.1, contact="hertz"), "contact"),
        (lambda: body.hit(ball, 1.0, gravity=0.0), "gravity"),
        (lambda: engine.process(-1), "frames"),
    ]:
        with pytest.raises(ParameterError, match=name):
            call()
    engine.process(4800)
    with pytest.raises(ParameterError, match="at"):
        body.hit(ball, 1.0, at=0.05)  # before the next frame to mix (0.1 s)
    assert engine.stats.impacts_pending == 0


def test_a_body_beyond_the_mode_budget_is_refused_before_any_work(empty_caches, monkeypatch):
    # Engine.add holds a plate to the render's mode budget (synth.cost.check_body) before its
    # modes are solved: the 18 mm board of 1.2 x 0.6 m has about 500 modes below 24 kHz, over
    # a budget of 100, and nothing reaches the plate-mode cache.
    monkeypatch.setenv("SYNTH_MAX_MODES", "100")
    engine = synth.Engine(samplerate=48000)
    plate = synth.Plate("mdf-18", thickness=0.018, length=1.2, width=0.6)
    with pytest.raises(synth.ParameterError, match="SYNTH_MAX_MODES"):
        engine.add(plate)
    cache = Path(os.environ["SYNTH_CACHE_DIR"])
    assert not cache.exists() or not any(p.is_file() for p in cache.rglob("*"))


@pytest.mark.parametrize(
    "variable, value, says",
    [
        # the board's microphone sums, by the summed polar rule: their first rule and check
        # rule about 6e8 rectangle-term equivalents at 24 kHz (synth info --cost)
        ("SYNTH_MAX_RADIATION_WORK", "100000000", "Rayleigh sums need .*accelerometer"),
        # its cold Ritz solve: about 1e10 floating-point operations
        ("SYNTH_MAX_SOLVER_FLOPS", "1000000000", "cold solve of the plate's modes"),
        # its solver's matrices and the radiation chunks: about 150 MiB
        ("SYNTH_MAX_MEMORY_BYTES", "10000000", "body's largest arrays .*max_voices"),
    ],
)
def test_a_body_beyond_the_render_budget_is_refused_before_any_work(
    empty_caches, monkeypatch, variable, value, says
):
    # Engine.add holds a body to the budget of a render (synth.cost.check_body: modes, mode
    # solver, radiation work, memory) before any mode is solved: the free 18 mm board of
    # 1.2 x 0.6 m heard by a microphone at 48 kHz is refused under each lowered budget, the
    # message naming what is too big, the variable and what to change; nothing reaches the
    # disk cache (no mode solved, no gain computed).
    monkeypatch.setenv(variable, value)
    engine = synth.Engine(samplerate=48000)
    plate = synth.Plate("mdf-18", thickness=0.018, length=1.2, width=0.6)
    with pytest.raises(synth.ParameterError, match=f"refused before any work: .*{says}") as info:
        engine.add(plate)
    assert variable in str(info.value)
    cache = Path(os.environ["SYNTH_CACHE_DIR"])
    assert not cache.exists() or not any(p.is_file() for p in cache.rglob("*"))
    assert engine.bodies == ()


def test_a_moved_listener_beyond_the_budget_is_refused_and_the_body_keeps_its_own(
    empty_caches, monkeypatch
):
    # Body.move checks the new listener's cost as Engine.add does, before its gains are
    # computed: a small simply supported plate (closed-form modes) heard by a microphone
    # moves within the budget, and under a radiation budget below its sums' first two rules
    # a move is refused and the body keeps its listener; so is a new body of two ears.
    engine = synth.Engine(samplerate=16000)
    plate = synth.Plate("mdf-18", thickness=0.018, length=0.3, width=0.2,
                        boundary="simply-supported")  # fmt: skip
    first = synth.Microphone((0.15, 0.1, 0.2))
    body = engine.add(plate, listener=first)
    body.move(synth.Microphone((0.1, 0.1, 0.3)))
    monkeypatch.setenv("SYNTH_MAX_RADIATION_WORK", "1")
    with pytest.raises(synth.ParameterError, match="SYNTH_MAX_RADIATION_WORK"):
        body.move(synth.Microphone((0.2, 0.1, 0.2)))
    assert body.listener == synth.Microphone((0.1, 0.1, 0.3))
    # and a body heard by two ears is refused alike before any of them is prepared
    stereo = synth.Engine(samplerate=16000, channels=2)
    with pytest.raises(synth.ParameterError, match="SYNTH_MAX_RADIATION_WORK"):
        stereo.add(plate, listener=synth.live.ears((0.15, 0.1, 0.2)))
    assert stereo.bodies == ()


def test_start_without_portaudio_says_what_to_install(monkeypatch, scene):
    # sounddevice raises OSError at import when the PortAudio library is missing
    real_import = builtins.__import__

    def no_portaudio(name, *args, **kwargs):
        if name == "sounddevice":
            raise OSError("PortAudio library not found")
        return real_import(name, *args, **kwargs)

    monkeypatch.delitem(sys.modules, "sounddevice", raising=False)
    monkeypatch.setattr(builtins, "__import__", no_portaudio)
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate)
    with pytest.raises(SynthError, match="libportaudio2"):
        engine.start()
    assert not engine.running
    body.hit(scene.ball, 1.0, at=0.0)  # process() works all the same
    assert np.any(engine.process(2048))


def test_start_without_the_device_says_so():
    pytest.importorskip("sounddevice", exc_type=OSError)
    engine = synth.Engine(samplerate=FS, device=9999)
    with pytest.raises(SynthError, match="no audio output device 9999"):
        engine.start()
    assert not engine.running


def test_synth_play_without_the_device_is_a_one_line_error(capsys):
    pytest.importorskip("sounddevice", exc_type=OSError)
    from synth.cli import main

    assert main(["play", "default", "--device", "9999"]) == 2
    assert "no audio output device 9999" in capsys.readouterr().err


@pytest.mark.parametrize(
    "script, argv", [("ui_button.py", []), ("game_loop.py", ["--seconds", "2"])]
)
def test_examples_run_offline(script, argv, tmp_path, monkeypatch, capsys):
    # the examples' offline modes run the same engine on its own clock and write a file
    import runpy
    from pathlib import Path

    out = tmp_path / "out.wav"
    path = Path(__file__).parent.parent / "examples" / script
    monkeypatch.setattr(sys, "argv", [str(path), *argv, "--offline", str(out)])
    runpy.run_path(str(path), run_name="__main__")
    audio, fs = synth.read_audio(out)
    assert fs == FS and np.any(audio)


def test_bench_live_figures_format():
    # the benchmark's pieces run and print their targets (figures themselves are not
    # asserted: wall-clock times depend on the machine)
    from benchmarks import live as bench

    result = dict(
        callback=bench.callback_cost(bodies=(1, 2), seconds=0.1),
        move=bench.move_cost(bodies=1, seconds=0.1, every=2),
        transform=bench.transform_cost(repeat=2),
        hit_us=bench.hit_cost(repeat=5),
        add_s=dict(cold=1.0, warm_disk=0.01, warm_memory=0.001),
        jack=None,
    )
    assert [r["bodies"] for r in result["callback"]] == [1, 2]
    assert all(r["played"] >= 1 for r in result["callback"])
    text = bench.format_live(result)
    assert "1 body:" in text and "hit() on the calling thread" in text and "not measured" in text
    assert "the audio thread's share of a hit" in text and "the listener moving" in text
    assert result["move"]["moves"] >= 1
    assert result["transform"]["hits_per_block"] == synth.Engine(samplerate=FS).max_hits_per_block
    # the JACK figures: the time to the output is labelled as derived from the onset that
    # hit() sets (block + latency + hand-over), the time to the callback as measured
    phase = dict(callbacks=10, underflows=0, played=5, late=0, refused=0, stolen=0)
    result["jack"] = dict(
        realtime_server=False, block_s=256 / FS, latency_s=0.01, nominal_latency_s=0.005,
        handover_s=0.002, hit_to_callback_ms=dict(median=5.0, max=7.0), hit_to_output_ms=17.3,
        seconds=1.0, rate=200.0, bodies=16, alone=phase, busy=phase, threads8=phase,
        callback_mean=0.1, callback_max=0.5, callback_gap_max=1.0, peak=0.1, output_peak=0.1,
        clipped=0,
    )  # fmt: skip
    text = bench.format_live(result)
    assert "first sample at the output: 17.30 ms, derived, not measured" in text
    assert "hit() to the end of the callback holding the tick's first sample: median" in text


def test_a_scene_added_sounds_as_it_renders(scene):
    # a Scene's default listener is above its impact point; engine.add(scene) hears the
    # scene's plate through the scene's own listener, so a drop off the centre is the render
    # (the measured model on the impedance plate, the one a live body solves)
    off_centre = synth.Scene(
        scene.ball,
        scene.plate,
        drop_height=0.05,
        position=(0.3, 0.15),
        contact=synth.Contact(plate="impedance"),
    )
    r = rendered(off_centre)
    engine = synth.Engine(samplerate=FS, blocksize=256, floor_db=EXACT_DB)
    body = engine.add(off_centre)
    assert body.listener == off_centre.listener
    body.drop(
        off_centre.ball,
        off_centre.drop_height,
        position=off_centre.position,
        at=PRE,
        contact=off_centre.contact,
    )
    live = engine.process(r.audio.size)[:, 0]
    np.testing.assert_allclose(live, r.audio, rtol=0, atol=float32_ulp_of_peak(r.audio))


def test_body_gain_set_after_add_is_ramped_over_one_block(scene):
    # the body's gain multiplies its mix; a change ramps linearly over the next block
    # (from the old gain to the new one at its last sample), then holds
    n = 256
    a = synth.Engine(samplerate=FS, blocksize=n)
    b = synth.Engine(samplerate=FS, blocksize=n)
    bodies = [e.add(scene.plate, listener=scene.listener) for e in (a, b)]
    for body in bodies:
        body.hit(scene.ball, 1.0, at=0.0)
    ref = a.process(8 * n)[:, 0].astype(float)
    first = b.process(2 * n)[:, 0].astype(float)
    bodies[1].gain = 0.25
    assert bodies[1].gain == 0.25
    rest = b.process(6 * n)[:, 0].astype(float)
    np.testing.assert_array_equal(first, ref[: 2 * n])
    ramp = 1.0 + (0.25 - 1.0) * np.arange(1, n + 1) / n
    tol = 2 * float32_ulp_of_peak(ref)
    np.testing.assert_allclose(rest[:n], ref[2 * n : 3 * n] * ramp, rtol=0, atol=tol)
    np.testing.assert_allclose(rest[n:], ref[3 * n :] * 0.25, rtol=0, atol=tol)
    with pytest.raises(ParameterError, match="gain"):
        bodies[1].gain = 0.0


def test_a_drop_that_does_not_fit_is_refused_whole_and_counted(scene):
    probe = synth.Engine(samplerate=FS)
    n = len(probe.add(scene.plate).drop(scene.ball, scene.drop_height).onsets)
    assert n > 2
    engine = synth.Engine(samplerate=FS, max_pending=n + n // 2)
    body = engine.add(scene.plate)
    assert len(body.drop(scene.ball, scene.drop_height).onsets) == n
    assert body.drop(scene.ball, scene.drop_height) is None  # only n // 2 slots free
    stats = engine.stats
    assert stats.impacts_pending == n
    assert stats.impacts_refused == n and stats.drops_refused == 1
    small = synth.Engine(samplerate=FS, max_pending=n - 1)
    with pytest.raises(ParameterError, match="max_pending"):
        small.add(scene.plate).drop(scene.ball, scene.drop_height)


def test_absurd_inputs_are_parameter_errors_naming_the_bound(scene):
    # each of these once overflowed, exhausted memory, held a slot for ever or played
    # samples of 6e7: now a ParameterError names the field, its value and the range
    for kwargs, name in [
        (dict(record_seconds=1e308), "record_seconds"),
        (dict(record_seconds=1e6), "record_seconds"),
        (dict(master_gain_db=1e308), "master_gain_db"),
        (dict(callback="C"), "callback"),
    ]:
        with pytest.raises(ParameterError, match=rf"{name}=.* must"):
            synth.Engine(samplerate=FS, **kwargs)
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate)
    ball = scene.ball
    for call, name in [
        (lambda: engine.process(2**40), "frames"),
        (lambda: body.hit(ball, 1.0, at=1e308), "at"),
        (lambda: body.hit(ball, 1.0, at=1e9), "at"),
        (lambda: body.hit(ball, 1e5), "speed"),
        (lambda: body.hit(ball, 1.0, gain=1e308), "gain"),
        (lambda: body.hit(ball, 1.0, gain=1e9), "gain"),
        (lambda: body.drop(ball, 1e-300), "height"),
        (lambda: body.drop(ball, 1e308), "height"),
    ]:
        with pytest.raises(ParameterError, match=rf"{name}=.* must"):
            call()
    assert engine.stats.impacts_pending == 0


def test_the_master_bus_never_sends_full_scale(scene):
    # a hit far louder than full scale: the soft clipper keeps every sample below 0 dBFS
    # (identity up to -1 dBFS), the meter reports the bus' true peak and the clipped count
    engine = synth.Engine(samplerate=FS, master_gain_db=40.0)
    engine.add(scene.plate, gain=1e4).hit(scene.ball, 2.0, at=0.0)
    out = engine.process(FS // 10)
    stats = engine.stats
    assert stats.peak > 1.0 and stats.clipped > 0
    assert np.max(np.abs(out)) < 1.0
    assert stats.output_peak == float(np.max(np.abs(out)))
    quiet = synth.Engine(samplerate=FS, clip=False)
    quiet.add(scene.plate, gain=1e4).hit(scene.ball, 2.0, at=0.0)
    assert np.max(np.abs(quiet.process(FS // 10))) > 1.0  # as asked: nothing done


def limited_engine(scene, gain, **kw):
    """A stereo engine (the ears of the docs' example) with one hit at 10 ms on the
    scene's plate at body ``gain``; the keywords go to Engine."""
    engine = synth.Engine(samplerate=FS, channels=2, clip=False, **kw)
    body = engine.add(scene.plate, listener=synth.live.ears((0.6, -0.4, 0.5), (0.0, 1.0)))
    body.gain = gain
    body.hit(scene.ball, 2.0, at=0.01)
    return engine


def unit_peak(scene):
    """The bus' sample peak of :func:`limited_engine` at body gain 1, no limiter."""
    return float(np.max(np.abs(limited_engine(scene, 1.0).process(FS // 10))))


@pytest.mark.parametrize("ceiling_db", [0.0, -3.0])
def test_the_limiter_keeps_a_burst_of_plus_12_dbfs_at_its_ceiling(scene, ceiling_db):
    # a hit whose bus peaks at +12 dBFS: with the limiter, no sample and no 4x-oversampled
    # inter-sample point above the ceiling reaches the device (the float32 samples sent);
    # its gain reduction covers the burst's true peak over the ceiling, and it is counted
    from synth.live.limiter import true_peak

    gain = 10.0 ** (12.0 / 20.0) / unit_peak(scene)
    loud = limited_engine(scene, gain).process(FS // 10)
    assert 10.0 ** (11.99 / 20.0) <= np.max(np.abs(loud)) <= 10.0 ** (12.01 / 20.0)
    engine = limited_engine(scene, gain, limiter=True, ceiling_db=ceiling_db)
    out = engine.process(FS // 10)
    ceiling = 10.0 ** (ceiling_db / 20.0)
    assert out.dtype == np.float32
    assert np.max(np.abs(out)) <= ceiling
    assert true_peak(out) <= ceiling
    stats = engine.stats
    assert stats.peak == pytest.approx(float(np.max(np.abs(loud))), rel=1e-6)
    needed = 20.0 * np.log10(true_peak(loud) / ceiling)
    assert stats.limiter_max_reduction_db >= needed - 1e-6
    assert stats.limiter_active > 0 and stats.clipped == 0
    # the limiter is not a clipper: the loudest part keeps its shape, within 1 dB of the
    # ceiling (the gain follows the envelope, it does not flatten the waveform)
    assert np.max(np.abs(out)) >= ceiling * 10.0 ** (-1.0 / 20.0)


def test_a_bus_below_the_ceiling_passes_the_limiter_bit_identical(scene):
    # 6 dB below the ceiling (true peak): the limiter only delays the bus by its look-ahead
    from synth.live.limiter import true_peak

    gain = 0.5 / unit_peak(scene)
    plain = limited_engine(scene, gain).process(FS // 10)
    assert true_peak(plain) < 1.0
    engine = limited_engine(scene, gain, limiter=True, ceiling_db=0.0)
    out = engine.process(FS // 10)
    from synth.live.limiter import LOOKAHEAD

    delay = int(round(LOOKAHEAD * FS))
    assert np.array_equal(out[delay:], plain[:-delay]) and not out[:delay].any()
    assert engine.stats.limiter_active == 0 and engine.stats.limiter_max_reduction_db == 0.0


def test_the_limiter_s_settings_are_checked(scene):
    for kw, name in [
        (dict(limiter=1), "limiter"),
        (dict(limiter=True, ceiling_db=0.5), "ceiling_db"),
        (dict(limiter=True, ceiling_db=-21.0), "ceiling_db"),
        (dict(limiter=True, lookahead=0.0), "lookahead"),
        (dict(limiter=True, lookahead=256 / FS + 1e-3), "lookahead"),  # beyond one block
        (dict(limiter=True, lookahead=8 / FS), "lookahead"),  # shorter than its reach
    ]:
        with pytest.raises(ParameterError, match=rf"{name}=.* must"):
            synth.Engine(samplerate=FS, blocksize=256, **kw)
    # the default look-ahead is at most one block; without the limiter it is not asked for
    assert synth.Engine(samplerate=FS, blocksize=16, limiter=True)._native.limiter.delay == 16
    assert synth.Engine(samplerate=FS, blocksize=16)._native.limiter is None


def test_a_host_mixes_into_its_own_buffers(scene):
    # mix_into fills a host's buffer of any size with the same mixing as process(); with
    # the exact modal sum (no omission, whose checks fall on the pieces' boundaries) the
    # pieces change only float64 rounding of the modes' advance
    times = [0.0011, 0.0173, 0.0402]
    engines = [synth.Engine(samplerate=FS, blocksize=256, floor_db=EXACT_DB) for _ in range(2)]
    for e in engines:
        body = e.add(scene.plate, listener=scene.listener)
        for i, t in enumerate(times):
            body.hit(scene.ball, 0.5 + i, at=t)
    want = engines[0].process(FS // 10)
    host = engines[1]
    buffer = np.empty((100, 1), dtype=np.float32)
    got = np.concatenate([host.mix_into(buffer).copy() for _ in range(FS // 1000)])
    np.testing.assert_allclose(got, want, rtol=0, atol=2 * float32_ulp_of_peak(want))
    assert host.render_block(7).shape == (7, 1)
    assert host.stats.impacts_played == len(times)
    for bad in (
        np.empty((10, 2), np.float32),
        np.empty((10, 1)),
        np.empty((10, 2), np.float32)[:, :1],
    ):
        with pytest.raises(ParameterError, match="out="):
            host.mix_into(bad)


def test_a_body_reports_its_memory(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    ring = body._ring
    # at least the pending ring's amplitudes and pulse samples, which dominate
    assert body.memory >= ring.amplitudes.nbytes + ring.samples.nbytes + ring.coefficients.nbytes


def test_stereo_bodies_are_heard_at_each_ear(scene):
    # a body added with one listener per channel: each channel is exactly the mono engine
    # of that ear's listener (its own Rayleigh gains); a mono body in the same engine is on
    # both channels
    left, right = synth.live.ears((0.6, 0.1, 0.4), facing=(0.0, 1.0))
    assert left.position[0] < right.position[0]  # facing +y, the left ear is towards -x
    assert np.isclose(right.position[0] - left.position[0], 0.18)
    stereo = synth.Engine(samplerate=FS, channels=2)
    body = stereo.add(scene.plate, listener=(left, right))
    mono_body = stereo.add(scene.plate, listener=scene.listener, gain=0.5)
    assert body.hit(scene.ball, 1.0, position=(0.2, 0.3), at=0.001).onset == 0.001
    mono_body.hit(scene.ball, 0.7, at=0.05)
    body.drop(scene.ball, 0.02, position=(0.9, 0.2), at=0.02)
    out = stereo.process(FS // 5)
    for c, ear in enumerate((left, right)):
        mono = synth.Engine(samplerate=FS)
        b = mono.add(scene.plate, listener=ear)
        b.hit(scene.ball, 1.0, position=(0.2, 0.3), at=0.001)
        b.drop(scene.ball, 0.02, position=(0.9, 0.2), at=0.02)
        m = mono.add(scene.plate, listener=scene.listener, gain=0.5)
        m.hit(scene.ball, 0.7, at=0.05)
        want = mono.process(FS // 5)[:, 0]
        np.testing.assert_allclose(out[:, c], want, rtol=0, atol=float32_ulp_of_peak(want))
    assert not np.allclose(out[:, 0], out[:, 1])
    assert stereo.stats.impacts_played == mono.stats.impacts_played
    with pytest.raises(ParameterError, match="listener"):
        synth.Engine(samplerate=FS).add(scene.plate, listener=(left, right))
    with pytest.raises(ParameterError, match="facing"):
        synth.live.ears((0.6, 0.1, 0.4), facing=(0.0, 0.0))


def test_a_heavy_ball_on_a_light_panel_is_refused_alike_by_hit_and_drop():
    # a 0.88 kg ball on a 26 g panel touches it for longer than a live body's slots take:
    # hit() refused it while drop() cut nothing and played it; both now refuse it, naming
    # the contact time and the way out (render offline)
    ball = synth.Ball("steel", radius=0.03)
    panel = synth.Plate("mdf-18", thickness=0.002, length=0.15, width=0.12)
    assert 0.85 < ball.mass < 0.9 and 0.02 < panel.mass < 0.03
    body = synth.Engine(samplerate=FS).add(panel)
    for call in (lambda: body.hit(ball, 1.0), lambda: body.drop(ball, 0.05)):
        with pytest.raises(ParameterError, match="contact lasts .* synth.render"):
            call()
    assert body.pending == 0


def test_hits_at_one_point_closer_than_min_interval_are_refused_and_counted(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate)
    body.min_interval = 0.05
    p, q = (0.3, 0.2), (0.3004, 0.2)  # the same point to 1 mm
    assert body.hit(scene.ball, 1.0, position=p, at=0.10).onset == 0.10
    assert body.hit(scene.ball, 1.0, position=q, at=0.12) is None  # 20 ms later: refused
    assert body.hit(scene.ball, 1.0, position=(0.5, 0.2), at=0.12).onset == 0.12  # elsewhere
    assert body.hit(scene.ball, 1.0, position=p, at=0.16).onset == 0.16  # 60 ms later
    stats = engine.stats
    assert stats.impacts_too_close == 1 and stats.impacts_pending == 3
    with pytest.raises(ParameterError, match="min_interval"):
        body.min_interval = 2.0


def alone(scene, hits, frames, **kw):
    """What each of ``hits`` ((speed, at) pairs) plays on its own engine: float64 (frames,)."""
    out = []
    for v, at in hits:
        e = synth.Engine(samplerate=FS, floor_db=EXACT_DB, **kw)
        e.add(scene.plate, listener=scene.listener).hit(scene.ball, v, at=at)
        out.append(e.process(frames)[:, 0].astype(float))
    return out


def raised_cosine(frames, start, length):
    """1 before ``start``, a raised cosine to 0 over ``length`` samples, 0 after."""
    p = np.arange(frames) - start
    w = 0.5 * (1.0 + np.cos(np.pi * np.clip(p, 0, length) / length))
    return np.where(p <= 0, 1.0, np.where(p >= length, 0.0, w))


def test_a_hit_is_a_voice_that_ends_and_is_reported_once(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    a = body.hit(scene.ball, 1.0, at=0.001)
    b = body.hit(scene.ball, 0.5, at=0.002)
    assert isinstance(a, synth.Voice) and a.onset == 0.001 and a.onsets == (0.001,)
    assert a.id != b.id and a.playing and b.playing and a.gain == 1.0
    assert engine.ended() == []
    engine.process(FS // 10)
    assert a.playing and engine.stats.voices_playing == 2
    engine.process(FS * 4)  # the default plate's tail falls below -80 dB in ~1 s
    assert not a.playing and not b.playing and not body.awake
    assert sorted(engine.ended()) == [a.id, b.id]
    assert engine.ended() == []  # each reported once
    stats = engine.stats
    assert stats.voices_playing == 0 and stats.voices_stolen == 0 and stats.events_lost == 0


def test_a_voice_ends_when_its_level_falls_below_the_floor_relative_to_its_peak(scene):
    # each voice's modes stop at the floor relative to its own peak: a quiet hit rings as
    # long beside a loud one (44 dB louder: Hertz force ~ v^1.2) as alone, to the block,
    # where a floor relative to the body's loudest impact would cut it short
    def blocks_until_quiet_ends(with_loud):
        e = synth.Engine(samplerate=FS, blocksize=256)
        body = e.add(scene.plate, listener=scene.listener)
        if with_loud:
            body.hit(scene.ball, 2.0, at=0.0)
        quiet = body.hit(scene.ball, 0.02, at=0.01)
        blocks = 0
        while quiet.playing:
            e.process(256)
            blocks += 1
        return blocks

    alone_, beside = blocks_until_quiet_ends(False), blocks_until_quiet_ends(True)
    assert alone_ == beside and alone_ > FS // 256 // 4  # rings for more than 0.25 s


def test_a_refused_hit_returns_none_and_posts_no_event(scene):
    engine = synth.Engine(samplerate=FS, max_pending=1)
    body = engine.add(scene.plate, listener=scene.listener)
    assert body.hit(scene.ball, 1.0) is not None
    assert body.hit(scene.ball, 1.0) is None
    engine.process(FS * 4)
    assert len(engine.ended()) == 1 and engine.stats.impacts_refused == 1


def test_a_voice_gain_is_ramped_over_one_block_and_leaves_the_others(scene):
    n = 256
    hits = [(1.0, 0.0), (0.6, 0.001)]
    ref_a, ref_b = alone(scene, hits, 8 * n, blocksize=n)
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    a, b = (body.hit(scene.ball, v, at=at) for v, at in hits)
    first = engine.process(2 * n)[:, 0]
    a.gain = 0.25
    assert a.gain == 0.25 and b.gain == 1.0
    rest = engine.process(6 * n)[:, 0]
    w = np.ones(8 * n)
    w[2 * n : 3 * n] = 1.0 + (0.25 - 1.0) * np.arange(1, n + 1) / n
    w[3 * n :] = 0.25
    want = ref_a * w + ref_b
    tol = 4 * float32_ulp_of_peak(want)
    np.testing.assert_allclose(np.concatenate([first, rest]), want, rtol=0, atol=tol)
    for bad in (-0.1, 1e9, float("nan")):
        with pytest.raises(ParameterError, match="gain"):
            a.gain = bad


def test_stop_fades_a_voice_out_and_ends_it(scene):
    # stop(fade) from the next block: a raised cosine over the fade, then silence; the
    # other voice plays on; the stopped voice is reported ended
    n, fade = 256, 0.004
    hits = [(1.0, 0.0), (0.6, 0.001)]
    ref_a, ref_b = alone(scene, hits, 12 * n, blocksize=n)
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    a, b = (body.hit(scene.ball, v, at=at) for v, at in hits)
    first = engine.process(3 * n)[:, 0]
    a.stop(fade=fade)
    rest = engine.process(9 * n)[:, 0]
    want = ref_a * raised_cosine(12 * n, 3 * n, round(fade * FS)) + ref_b
    tol = 4 * float32_ulp_of_peak(want)
    np.testing.assert_allclose(np.concatenate([first, rest]), want, rtol=0, atol=tol)
    assert not a.playing and b.playing and engine.ended() == [a.id]
    a.stop()  # an ended voice: nothing to do
    a.gain = 0.5
    for bad in (0.0, 20.0):
        with pytest.raises(ParameterError, match="fade"):
            b.stop(fade=bad)


def test_a_voice_stopped_before_it_starts_plays_nothing(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    voice = body.hit(scene.ball, 1.0, at=0.05)
    voice.stop()
    assert not np.any(engine.process(FS // 5))
    stats = engine.stats
    assert stats.impacts_played == 0 and stats.impacts_dropped == 1
    assert engine.ended() == [voice.id] and not voice.playing


def test_a_drop_is_one_voice_and_stop_drops_its_later_bounces(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    voice = body.drop(scene.ball, scene.drop_height, at=0.0)
    n = len(voice.onsets)
    assert n > 10 and voice.onset == voice.onsets[0] == 0.0
    assert voice.onsets[5] - voice.onsets[4] > 0.01
    cut = int((voice.onsets[4] + 0.001) * FS)  # after the fifth tick's contact
    engine.process(cut)
    voice.stop(fade=0.002)
    engine.process(FS * 2)
    stats = engine.stats
    assert 5 <= stats.impacts_played < n
    assert stats.impacts_played + stats.impacts_dropped == n
    assert engine.ended() == [voice.id]


def injection_sample(scene, speed, at):
    """The sample at which a hit at ``speed`` (m/s) at ``at`` (s) on the plate's centre joins
    the modes, the first after its contact (synth.live's pulse layout): a hit's default
    contact is the measured surface on the impedance plate."""
    ct = solve_impact(
        scene.ball, scene.plate, speed, position=scene.plate.centre, rtol=HIT_RTOL, surface="auto"
    )
    return int(np.ceil((at + ct.separation_time) * FS - 1e-9))


def test_a_new_voice_steals_the_oldest_with_a_fade(scene):
    # two voice slots, three hits: the third steals the first (the oldest, though the
    # second is quieter), which fades out over STEAL_FADE from the third's injection
    # sample (the first sample after its contact), the others untouched
    from synth.live.voice import STEAL_FADE

    n = 256
    hits = [(1.5, 0.001), (0.1, 0.004), (1.0, 0.0123)]
    refs = alone(scene, hits, 16 * n, blocksize=n)
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB, max_voices=2)
    body = engine.add(scene.plate, listener=scene.listener)
    voices = [body.hit(scene.ball, v, at=at) for v, at in hits]
    live = engine.process(16 * n)[:, 0]
    inject = injection_sample(scene, *hits[2])
    want = refs[0] * raised_cosine(16 * n, inject, round(STEAL_FADE * FS)) + refs[1] + refs[2]
    tol = 4 * float32_ulp_of_peak(want)
    np.testing.assert_allclose(live, want, rtol=0, atol=tol)
    assert engine.stats.voices_stolen == 1 and engine.ended() == [voices[0].id]
    assert not voices[0].playing and voices[1].playing and voices[2].playing


def test_a_stereo_body_reports_a_voice_once_both_ears_ended(scene):
    engine = synth.Engine(samplerate=FS, channels=2)
    body = engine.add(scene.plate, listener=synth.live.ears((0.3, 0.2, 0.3)))
    voice = body.hit(scene.ball, 1.0, position=(0.9, 0.3), at=0.0)
    seen = []
    for _ in range(200):
        engine.process(FS // 20)
        seen += engine.ended()
        if not voice.playing:
            break
    seen += engine.ended()
    assert seen == [voice.id]


def test_voice_ended_events_beyond_the_ring_are_counted_lost(scene, monkeypatch):
    from synth.live import engine as live_engine

    monkeypatch.setattr(live_engine, "EVENT_CAPACITY", 2)
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    voices = [body.hit(scene.ball, 1.0, at=0.001 * k) for k in range(3)]
    for v in voices:
        v.stop(fade=0.001)
    engine.process(FS // 10)
    assert engine.stats.events_lost == 1
    assert engine.ended() == [voices[0].id, voices[1].id]
    voices = [body.hit(scene.ball, 1.0, at=engine.time + 0.001) for _ in range(2)]
    for v in voices:
        v.stop(fade=0.001)
    engine.process(FS // 10)
    assert engine.ended() == [v.id for v in voices]  # room again once read


def pause_gain(levels):
    """The master bus' pause gain at pause levels in [0, 1] (a raised cosine)."""
    return 0.5 * (1.0 - np.cos(np.pi * np.asarray(levels)))


def test_pause_fades_out_holds_the_clock_and_every_voice_then_resumes(scene):
    # pause: the bus fades out over `fade` from the next block (its level falls by
    # 1/fade_frames a sample, heard through a raised cosine); at the end of the block where
    # it reaches 0 the clock and every voice hold and the output is silence; resume fades
    # back in and the voices go on from where they were held. A hit made while paused
    # starts on the held clock.
    n, L = 256, round(0.01 * FS)
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    first = body.hit(scene.ball, 1.0, at=0.0)
    a = engine.process(4 * n)[:, 0]
    engine.pause()
    assert engine.paused
    b = engine.process(4 * n)[:, 0]
    held = -(-(4 * n + L) // n) * n  # the end of the block where the fade ends
    assert engine.time == held / FS
    second = body.hit(scene.ball, 0.5)
    assert second.onset == (held + n) / FS and first.playing and second.playing
    assert not np.any(engine.process(3 * n)) and engine.time == held / FS
    engine.resume()
    assert not engine.paused
    d = engine.process(10 * n)[:, 0]
    ref1, ref2 = alone(scene, [(1.0, 0.0), (0.5, second.onset)], held + 10 * n, blocksize=n)
    down = pause_gain(np.clip(1.0 - np.arange(1, held - 4 * n + 1) / L, 0.0, 1.0))
    up = pause_gain(np.clip(np.arange(1, 10 * n + 1) / L, 0.0, 1.0))
    want = np.concatenate([ref1[: 4 * n], ref1[4 * n : held] * down, (ref1 + ref2)[held:] * up])
    got = np.concatenate([a, b[: held - 4 * n], d])
    assert not np.any(b[held - 4 * n :])
    np.testing.assert_allclose(got, want, rtol=0, atol=4 * float32_ulp_of_peak(want))


def test_stop_all_ends_every_voice(scene):
    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate, listener=scene.listener)
    ringing = body.hit(scene.ball, 1.0, at=0.0)
    engine.process(1024)
    pending = body.hit(scene.ball, 1.0)
    body.stop_all()
    assert not ringing.playing and not pending.playing
    assert sorted(engine.ended()) == [ringing.id, pending.id]
    assert engine.stats.impacts_dropped == 1


def test_voices_made_stopped_and_ended_across_threads_are_each_reported_once(scene):
    # four threads hit (and stop or re-gain some of their voices) while this thread mixes,
    # as the audio thread would: every voice made is reported ended exactly once, every
    # impact handed over is played or dropped, and no voice record is left taken
    import threading
    import time

    from synth.live import kernel

    engine = synth.Engine(samplerate=FS, blocksize=128, max_voices=3, max_pending=16)
    body = engine.add(scene.plate, listener=scene.listener)
    made, lock = [], threading.Lock()

    def game(seed):
        rng = np.random.default_rng(seed)
        for _ in range(40):
            v = body.hit(scene.ball, float(rng.uniform(0.2, 2.0)))
            if v is None:
                continue
            with lock:
                made.append(v)
            if rng.random() < 0.3:
                v.stop(fade=0.002)
            elif rng.random() < 0.3:
                v.gain = float(rng.uniform(0.0, 2.0))
            now = engine.time
            while engine.time == now:  # the next hit after a block was mixed
                time.sleep(0.0002)

    threads = [threading.Thread(target=game, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    ended = []
    while any(t.is_alive() for t in threads):
        engine.process(128)
        ended += engine.ended()
    for t in threads:
        t.join()
    while any(v.playing for v in made):
        engine.process(FS // 10)
    ended += engine.ended()
    assert len(made) > 100  # of 160: a few refused by a full ring
    assert sorted(ended) == sorted(v.id for v in made)
    stats = engine.stats
    assert stats.impacts_played + stats.impacts_dropped == len(made)
    assert stats.impacts_pending == 0 and stats.voices_playing == 0
    assert stats.voices_stolen > 0  # three slots: stealing ran among the rest
    assert not np.any(body._ring.voices[:, kernel.V_STATE] != kernel.V_FREE)


def test_a_body_may_ring_fewer_voices_than_the_engine(scene):
    engine = synth.Engine(samplerate=FS)
    one = engine.add(scene.plate, listener=scene.listener, max_voices=1)
    many = engine.add(scene.plate, listener=scene.listener)
    assert one.max_voices == 1 and many.max_voices == engine.max_voices == 8
    assert one.memory < many.memory
    first = one.hit(scene.ball, 1.0, at=0.001)
    second = one.hit(scene.ball, 1.0, at=0.01)
    engine.process(FS // 10)
    assert engine.stats.voices_stolen == 1 and engine.ended() == [first.id] and second.playing
    with pytest.raises(ParameterError, match="max_voices"):
        engine.add(scene.plate, max_voices=0)


def test_a_full_body_steals_the_lowest_priority_before_the_oldest(scene):
    # two slots: the oldest has priority 1, the second 0; the third (priority 0) steals
    # the second (the lowest priority), which fades out over STEAL_FADE from the third's
    # injection sample; the oldest rings on untouched
    from synth.live.voice import STEAL_FADE

    n = 256
    hits = [(1.5, 0.001), (0.5, 0.004), (1.0, 0.0123)]
    refs = alone(scene, hits, 16 * n, blocksize=n)
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB, max_voices=2)
    body = engine.add(scene.plate, listener=scene.listener)
    voices = [body.hit(scene.ball, v, at=at, priority=p) for (v, at), p in zip(hits, (1, 0, 0))]
    assert [v.priority for v in voices] == [1, 0, 0]
    live = engine.process(16 * n)[:, 0]
    inject = injection_sample(scene, *hits[2])
    want = refs[0] + refs[1] * raised_cosine(16 * n, inject, round(STEAL_FADE * FS)) + refs[2]
    np.testing.assert_allclose(live, want, rtol=0, atol=4 * float32_ulp_of_peak(want))
    assert engine.stats.voices_stolen == 1 and engine.ended() == [voices[1].id]
    assert voices[0].playing and voices[2].playing


def test_a_voice_below_every_ringing_priority_is_refused_whole_and_counted(scene):
    # one slot rung by a priority-5 hit: a priority-0 hit and a priority-0 drop find it
    # taken and are refused when they come to join: nothing of them plays (the output is
    # the first hit's alone, exactly), every bounce is counted dropped, each voice ends
    n = 256
    ref = alone(scene, [(1.0, 0.001)], 32 * n, blocksize=n, max_voices=1)[0]
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB, max_voices=1)
    body = engine.add(scene.plate, listener=scene.listener)
    keep = body.hit(scene.ball, 1.0, at=0.001, priority=5)
    low = body.hit(scene.ball, 2.0, at=0.01, priority=0)
    drop = body.drop(scene.ball, 0.05, at=0.02, priority=0)
    live = engine.process(32 * n)[:, 0]
    np.testing.assert_array_equal(live, ref.astype(np.float32))
    stats = engine.stats
    assert stats.voices_refused == 2 and stats.voices_stolen == 0
    assert stats.impacts_dropped == 1 + len(drop.onsets) and stats.impacts_played == 1
    assert keep.playing and not low.playing and not drop.playing
    assert sorted(engine.ended()) == sorted([low.id, drop.id])
    with pytest.raises(ParameterError, match="priority"):
        body.hit(scene.ball, 1.0, priority=256)
    with pytest.raises(ParameterError, match="priority"):
        body.drop(scene.ball, 0.05, priority=-1)


def test_the_engine_wide_cap_steals_across_bodies_or_refuses_by_priority(scene):
    engine = synth.Engine(samplerate=FS, max_total_voices=2)
    one = engine.add(scene.plate, listener=scene.listener)
    two = engine.add(scene.plate, listener=scene.listener)
    a = one.hit(scene.ball, 1.0, at=0.001)
    b = two.hit(scene.ball, 1.0, at=0.002)
    c = one.hit(scene.ball, 1.0, at=0.003)  # beyond the cap: steals a, the oldest
    engine.process(FS // 10)
    assert engine.ended() == [a.id] and b.playing and c.playing
    assert engine.stats.voices_stolen == 1 and engine.stats.voices_playing == 2
    d = two.hit(scene.ball, 1.0, at=engine.time + 0.001, priority=3)  # steals b
    e = one.hit(scene.ball, 1.0, at=engine.time + 0.002, priority=3)  # steals c
    assert two.hit(scene.ball, 1.0, priority=2) is None  # every voice ranks higher
    assert two.drop(scene.ball, 0.05, priority=0) is None
    engine.process(FS // 10)
    assert sorted(engine.ended()) == sorted([b.id, c.id]) and d.playing and e.playing
    stats = engine.stats
    assert stats.voices_stolen == 3 and stats.voices_refused == 2
    assert sum(v is None or v.playing for v in engine._voice_limit._live.values()) == 2
    engine.process(4 * FS)  # both ring out: room again
    assert one.hit(scene.ball, 1.0) is not None
    with pytest.raises(ParameterError, match="max_total_voices"):
        synth.Engine(samplerate=FS, max_total_voices=0)


def test_a_removed_body_rings_out_then_frees_its_memory_and_its_room(scene):
    import gc
    import weakref

    n = 256
    engine = synth.Engine(samplerate=FS, blocksize=n, max_bodies=2)
    keep = engine.add(scene.plate, listener=scene.listener)
    gone = engine.add(scene.plate, listener=scene.listener)
    alone_ = synth.Engine(samplerate=FS, blocksize=n)
    alone_.add(scene.plate, listener=scene.listener).hit(scene.ball, 1.0, at=0.001)
    ref = alone_.process(4 * FS)
    voice = gone.hit(scene.ball, 1.0, at=0.001)
    engine.process(n)
    memory = weakref.ref(gone._ring.amplitudes)  # the body's largest array
    gone.remove()  # rings out: the same samples as never removed
    assert gone.removed and gone.memory > 0
    with pytest.raises(SynthError, match="removed"):
        gone.hit(scene.ball, 1.0)
    live = engine.process(4 * FS - n)
    np.testing.assert_array_equal(live, ref[n:])
    assert not voice.playing and engine.ended() == [voice.id]
    engine.process(n)  # a block mixed without it: let go of
    gc.collect()
    assert memory() is None and gone.memory == 0 and engine.bodies == (keep,)
    assert engine.stats.impacts_played == 1  # what it played stays counted
    third = engine.add(scene.plate, listener=scene.listener)  # its room is free again
    third.hit(scene.ball, 1.0, at=engine.time + 0.001)
    again = engine.process(FS // 10)
    np.testing.assert_allclose(again, ref[: FS // 10], rtol=0, atol=4 * float32_ulp_of_peak(ref))
    voice.stop()  # a handle on a freed body does nothing
    voice.gain = 0.5


def test_a_removed_body_fades_out_when_asked(scene):
    n = 256
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB)
    body = engine.add(scene.plate, listener=scene.listener)
    voice = body.hit(scene.ball, 1.0, at=0.001)
    ref = alone(scene, [(1.0, 0.001)], 8 * n, blocksize=n)[0]
    engine.process(4 * n)
    body.remove(fade=0.002)
    live = engine.process(4 * n)[:, 0]
    fade = round(0.002 * FS)
    want = ref[4 * n :] * raised_cosine(4 * n, 0, fade)
    np.testing.assert_allclose(live, want, rtol=0, atol=4 * float32_ulp_of_peak(ref))
    assert not voice.playing and not np.any(live[fade:])
    engine.process(n)
    assert body.memory == 0 and engine.bodies == ()
    with pytest.raises(ParameterError, match="fade"):
        engine.add(scene.plate, listener=scene.listener).remove(fade=0.0)


def test_the_master_gain_set_at_run_time_is_ramped_over_one_block(scene):
    # -6 dB asked between two blocks: the next block ramps the bus' gain linearly from 1
    # to 10^(-6/20) (the last sample at the target), the blocks after stay there
    n = 256
    ref = alone(scene, [(1.0, 0.001)], 8 * n, blocksize=n)[0]
    engine = synth.Engine(samplerate=FS, blocksize=n, floor_db=EXACT_DB)
    engine.add(scene.plate, listener=scene.listener).hit(scene.ball, 1.0, at=0.001)
    head = engine.process(4 * n)[:, 0]
    engine.master_gain_db = -6.0
    assert engine.master_gain_db == pytest.approx(-6.0, abs=1e-12)
    tail = engine.process(4 * n)[:, 0]
    g1 = 10.0 ** (-6.0 / 20.0)
    ramp = np.concatenate([1.0 + (g1 - 1.0) * np.arange(1, n + 1) / n, np.full(3 * n, g1)])
    tol = 4 * float32_ulp_of_peak(ref)
    np.testing.assert_allclose(head, ref[: 4 * n], rtol=0, atol=tol)
    np.testing.assert_allclose(tail, ref[4 * n :] * ramp, rtol=0, atol=tol)


def test_a_removed_stereo_body_frees_both_ears_and_a_new_one_takes_their_room(scene):
    engine = synth.Engine(samplerate=FS, channels=2, max_bodies=2)
    head = synth.live.ears((0.3, 0.2, 0.3))
    body = engine.add(scene.plate, listener=head)
    voice = body.hit(scene.ball, 1.0, position=(0.9, 0.3), at=0.0)
    with pytest.raises(ParameterError, match="max_bodies"):
        engine.add(scene.plate, listener=head)  # one entry per ear: full
    engine.process(256)  # it rings
    body.remove(fade=0.001)
    engine.process(FS // 10)
    assert body.memory == 0 and engine.bodies == () and not voice.playing
    assert engine.ended() == [voice.id] and engine.stats.impacts_played == 1
    again = engine.add(scene.plate, listener=head)
    assert again.hit(scene.ball, 1.0, at=engine.time) is not None
    assert np.any(engine.process(FS // 10))


@pytest.mark.parametrize("cycles", [0.02, 0.1, 0.2, 0.25, 0.3, 0.35])
def test_the_true_peak_estimate_reads_a_sine_s_peak_between_its_samples(cycles):
    # a unit sine at ``cycles`` per sample, every phase (faded in and out, so that its ends
    # add no overshoot): 4x oversampling misses the crest by at most an eighth of a sample,
    # so it reads at least cos(2 pi cycles / 8) of it (closed form); its 12-tap interpolator
    # adds at most 0.2 % of passband ripple up to 0.35 of the sample rate
    from synth.live.limiter import true_peak

    n = np.arange(4800)
    ramp = np.sin(0.5 * np.pi * np.arange(1000) / 1000) ** 2
    fade = np.concatenate([ramp, np.ones(n.size - 2000), ramp[::-1]])
    for phase in np.linspace(0.0, np.pi, 17):
        x = np.sin(2 * np.pi * cycles * n + phase) * fade
        assert np.cos(2 * np.pi * cycles / 8) - 1e-9 <= true_peak(x) <= 1.002


def heard_by(scene, listener, floor_db, move_to=None, at_block=0, blocks=60):
    """A stereo engine's output of one hit at 1 ms on the scene's plate heard through
    ``listener`` (two ears), moved to ``move_to`` before block ``at_block`` (process() in
    blocks of the engine's 256 frames)."""
    engine = synth.Engine(samplerate=FS, channels=2, floor_db=floor_db)
    body = engine.add(scene.plate, listener=listener)
    body.hit(scene.ball, 1.0, position=(0.2, 0.3), at=0.001)
    out = []
    for b in range(blocks):
        if move_to is not None and b == at_block:
            body.move(move_to)
        out.append(engine.process(256))
    return np.concatenate(out), body


def test_a_listener_moved_mid_ring_ramps_every_mode_to_its_new_gain(scene):
    # the voices ring the plate's modal state and each ear applies its listener's gains:
    # moved at a block boundary mid-ring, the block before is the old listener's render,
    # the block after the new one's (every mode at its new gain, to float32 rounding: the
    # sum is linear in the gains), and the block between ramps each mode's gain linearly
    # (so the output is old + u (new - old), u = 1/n .. 1: no step beyond the ramp's)
    old = synth.live.ears((0.6, -0.4, 0.5), (0.0, 1.0))
    new = synth.live.ears((0.3, 0.5, 0.3), (1.0, 0.0))
    k, n = 20, 256
    moved, body = heard_by(scene, old, EXACT_DB, move_to=new, at_block=k)
    before, _ = heard_by(scene, old, EXACT_DB)
    after, _ = heard_by(scene, new, EXACT_DB)
    tol = 2 * float32_ulp_of_peak(np.concatenate([before, after]))
    np.testing.assert_allclose(moved[: k * n], before[: k * n], rtol=0, atol=tol)
    np.testing.assert_allclose(moved[(k + 1) * n :], after[(k + 1) * n :], rtol=0, atol=tol)
    u = (np.arange(1, n + 1) / n)[:, None]
    ramp = before[k * n : (k + 1) * n] + u * (after - before)[k * n : (k + 1) * n]
    np.testing.assert_allclose(moved[k * n : (k + 1) * n], ramp, rtol=0, atol=2 * tol)
    assert np.max(np.abs(after - before)[(k + 1) * n :]) > 100 * tol  # the move is heard
    assert body.listener == new
    with pytest.raises(ParameterError, match="listener"):
        body.move(synth.Microphone((0.3, 0.5, 0.3)))  # one listener for two ears


def test_modes_the_old_listener_left_out_ring_for_the_new_one(scene):
    # above the plate's centre the antisymmetric modes are not heard: at the default floor
    # they stop at once (their heard level is nil) and park their plate state; moved to an
    # ear off the centre, they ring again at their new gain. After the ramp, the output is
    # the new listener's exact render (no omission) within the omission budget (each
    # mode's share of the floor times the voice's peak as first heard, summed: floor x
    # peak) and float32 rounding; rescaling heard states mode by mode would have lost them
    cx, cy = scene.plate.centre
    centre = (synth.Microphone((cx, cy, 0.3)), synth.Microphone((cx, cy, 0.3)))
    new = synth.live.ears((0.25, 0.2, 0.3), (1.0, 0.0))
    k, n, floor_db = 10, 256, -80.0
    moved, body = heard_by(scene, centre, floor_db, move_to=new, at_block=k)
    exact, _ = heard_by(scene, new, EXACT_DB)
    first, _ = heard_by(scene, centre, floor_db, blocks=k)
    level = float(np.max(body._ears[0]._arrays["level"]))  # the voice's heard peak
    budget = 10.0 ** (floor_db / 20.0) * level  # level: output units (full scale 1)
    tol = budget + 2 * float32_ulp_of_peak(exact)
    assert np.max(np.abs(moved - exact)[(k + 1) * n :]) <= tol
    # the modes left out above the centre are what the new listener hears most of
    assert np.max(np.abs(exact[(k + 1) * n :])) > 10 * tol
    assert np.max(np.abs(first)) < np.max(np.abs(exact[: k * n]))


def mono_of(scene, hits, frames, **kw):
    """The mono engine's output of ``hits`` ((speed, at) pairs) on the scene's plate heard by
    its listener: float64 (frames,), the signal a pan places."""
    e = synth.Engine(samplerate=FS, floor_db=EXACT_DB, **kw)
    body = e.add(scene.plate, listener=scene.listener)
    for v, at in hits:
        body.hit(scene.ball, v, at=at)
    return e.process(frames)[:, 0].astype(float)


def panned(scene, hits, frames, pan, changes=(), **kw):
    """A stereo engine's output of ``hits`` on a body added at ``pan``, its pan set to each
    of ``changes`` ((block, pan) pairs) before that block of 256 frames: float64
    (frames, 2)."""
    e = synth.Engine(samplerate=FS, channels=2, floor_db=EXACT_DB, **kw)
    body = e.add(scene.plate, listener=scene.listener, pan=pan)
    for v, at in hits:
        body.hit(scene.ball, v, at=at)
    changes, out = dict(changes), []
    for b in range(frames // 256):
        if b in changes:
            body.pan = changes[b]
            assert body.pan == changes[b]
        out.append(e.process(256))
    return np.concatenate(out).astype(float), body


def law(pan):
    """The constant-power pan law, (left, right) = (cos, sin) of (pan + 1) pi / 4."""
    theta = (pan + 1.0) * np.pi / 4.0
    return np.cos(theta), np.sin(theta)


def test_a_panned_body_follows_the_constant_power_law(scene):
    # each channel is the mono body's signal times the law's gain: hard left is the mono
    # signal on the left and exact silence on the right (and the mirror); the centre is
    # the same on both channels, 1/sqrt(2) of the mono signal (-3.01 dB each); at every
    # pan left^2 + right^2 = mono^2 (constant power), to float32 rounding
    hits, frames = [(1.0, 0.001), (0.5, 0.02)], 8192
    mono = mono_of(scene, hits, frames)
    tol = 2 * float32_ulp_of_peak(mono)
    left, _ = panned(scene, hits, frames, -1.0)
    np.testing.assert_array_equal(left[:, 0], mono)
    assert np.max(np.abs(mono)) > 0 and not np.any(left[:, 1])
    right, _ = panned(scene, hits, frames, 1.0)
    np.testing.assert_array_equal(right[:, 1], mono)
    assert not np.any(right[:, 0])
    centre, body = panned(scene, hits, frames, 0.0)
    assert body.pan == 0.0
    np.testing.assert_array_equal(centre[:, 0], centre[:, 1])
    np.testing.assert_allclose(centre[:, 0], mono * np.sqrt(0.5), rtol=0, atol=tol)
    level_db = 20 * np.log10(np.sqrt(np.mean(centre[:, 0] ** 2) / np.mean(mono**2)))
    assert level_db == pytest.approx(-3.0103, abs=1e-3)
    for pan in (-0.7, 0.3):
        out, _ = panned(scene, hits, frames, pan)
        gl, gr = law(pan)
        np.testing.assert_allclose(out[:, 0], gl * mono, rtol=0, atol=tol)
        np.testing.assert_allclose(out[:, 1], gr * mono, rtol=0, atol=tol)
        np.testing.assert_allclose(
            out[:, 0] ** 2 + out[:, 1] ** 2, mono**2, rtol=0, atol=2 * tol * np.max(np.abs(mono))
        )
    # unpanned (the default): the mono signal at its full level on both channels
    unpanned, body = panned(scene, hits, frames, None)
    assert body.pan is None
    np.testing.assert_array_equal(unpanned[:, 0], mono)
    np.testing.assert_array_equal(unpanned[:, 1], mono)


def test_a_pan_set_while_a_body_rings_is_ramped_over_one_block(scene):
    # added hard left; pan=0.5 asked before block 4, then None (unpanned) before block 8:
    # each channel's gain goes linearly over the next block from its old value to its new
    # one at the block's last sample (as body.gain does), then holds: the output is the
    # mono signal times that piecewise-linear gain, so no step is larger than the ramp's
    n, frames = 256, 16 * 256
    hits = [(1.0, 0.001)]
    mono = mono_of(scene, hits, frames)
    out, body = panned(scene, hits, frames, -1.0, changes=[(4, 0.5), (8, None)])
    u = np.arange(1, n + 1) / n
    gl, gr = law(0.5)
    for c, (g_left, g_mid) in enumerate([(1.0, gl), (0.0, gr)]):
        gain = np.concatenate([
            np.full(4 * n, g_left),
            g_left + (g_mid - g_left) * u,
            np.full(3 * n, g_mid),
            g_mid + (1.0 - g_mid) * u,  # unpanned again: the full mono level
            np.full(frames - 9 * n, 1.0),
        ])  # fmt: skip
        tol = 2 * float32_ulp_of_peak(mono)
        np.testing.assert_allclose(out[:, c], gain * mono, rtol=0, atol=tol)
    assert not np.any(out[: 4 * n, 1]) and np.max(np.abs(out[4 * n :, 1])) > 0
    assert body.pan is None


def test_pan_is_refused_where_it_means_nothing(scene):
    # a pan places a mono body between two channels: out of [-1, 1], in an engine of one
    # channel or of four, or on a body heard through its own ears, it is a ParameterError
    # naming pan and what is allowed
    stereo = synth.Engine(samplerate=FS, channels=2)
    body = stereo.add(scene.plate, listener=scene.listener)
    for bad in (1.5, -1.01, float("nan"), "left", True):
        with pytest.raises(ParameterError, match=r"pan="):
            body.pan = bad
    assert body.pan is None
    with pytest.raises(ParameterError, match=r"pan=1.5 must be in \[-1, 1\]"):
        stereo.add(scene.plate, listener=scene.listener, pan=1.5)
    head = synth.live.ears((0.6, 0.1, 0.4), facing=(0.0, 1.0))
    with pytest.raises(ParameterError, match="pan=0.0: this body is heard through 2 listeners"):
        stereo.add(scene.plate, listener=head, pan=0.0)
    two_ears = stereo.add(scene.plate, listener=head)
    with pytest.raises(ParameterError, match="listeners"):
        two_ears.pan = 0.0
    assert two_ears.pan is None
    for channels in (1, 4):
        engine = synth.Engine(samplerate=FS, channels=channels)
        with pytest.raises(ParameterError, match=f"pan=0.0: .*channels={channels}"):
            engine.add(scene.plate, listener=scene.listener, pan=0.0)
        mono = engine.add(scene.plate, listener=scene.listener)
        with pytest.raises(ParameterError, match=f"channels={channels}"):
            mono.pan = -0.5
        mono.pan = None  # unpanned, as it is


def test_four_channels_are_each_heard_through_their_own_listener(scene):
    # an engine of 4 channels, a body added with 4 listeners: each channel is exactly the
    # mono engine of that channel's listener (its own Rayleigh gains); a body of one
    # listener plays on every channel
    listeners = synth.live.ears((0.6, 0.1, 0.4), facing=(0.0, 1.0)) + synth.live.ears(
        (0.3, 0.2, 0.3)
    )
    engine = synth.Engine(samplerate=FS, channels=4)
    body = engine.add(scene.plate, listener=listeners)
    body.hit(scene.ball, 1.0, position=(0.2, 0.3), at=0.001)
    engine.add(scene.plate, listener=scene.listener, gain=0.5).hit(scene.ball, 0.7, at=0.05)
    out = engine.process(FS // 10)
    assert out.shape == (FS // 10, 4)
    for c, listener in enumerate(listeners):
        mono = synth.Engine(samplerate=FS)
        mono.add(scene.plate, listener=listener).hit(scene.ball, 1.0, position=(0.2, 0.3), at=0.001)
        mono.add(scene.plate, listener=scene.listener, gain=0.5).hit(scene.ball, 0.7, at=0.05)
        want = mono.process(FS // 10)[:, 0]
        np.testing.assert_allclose(out[:, c], want, rtol=0, atol=float32_ulp_of_peak(want))
    peaks = np.max(np.abs(out[: int(0.05 * FS)]), axis=0)  # before the mono body's hit
    assert np.all(peaks > 0) and np.unique(peaks).size == 4  # four distinct listeners
    assert engine.stats.impacts_played == 2


@pytest.mark.slow
def test_a_listener_moved_above_its_plate_hears_as_a_body_added_there(scene):
    # engine.move_listener at every ear count: mono (a Microphone), stereo (ears) and four
    # ears (moved all by one displacement, their centroid to the new position: the refusal
    # of more than two ears is gone). After the block that ramps, each engine's output is
    # that of an engine whose body was added with the new listeners (their gains from the
    # plate's fixed radiation grids, within 2e-6 of the exact rule's, far below float32's
    # rounding of the output: 2 ulps of its peak, as for any two live renders)
    head, moved_to = (0.7, 0.1, 0.45), (0.35, 0.3, 0.25)
    quad = tuple(synth.Microphone((0.7 + dx, 0.1 + dy, 0.45)) for dx, dy in
                 ((0.1, 0.0), (0.0, 0.1), (-0.1, 0.0), (0.0, -0.1)))  # fmt: skip
    shifted = tuple(
        synth.Microphone(tuple(p + m - h for p, m, h in zip(q.position, moved_to, head)))
        for q in quad
    )
    cases = (
        (1, synth.Microphone(head), synth.Microphone(moved_to)),
        (2, synth.live.ears(head), synth.live.ears(moved_to)),
        (4, quad, shifted),
    )
    k, n = 8, 256
    for channels, first, then in cases:
        outs = []
        for listener, move in ((first, True), (then, False)):
            engine = synth.Engine(samplerate=FS, channels=channels, floor_db=EXACT_DB)
            body = engine.add(scene.plate, listener=listener)
            body.hit(scene.ball, 1.0, position=(0.2, 0.3), at=0.001)
            blocks = []
            for b in range(3 * k):
                if move and b == k:
                    engine.move_listener(moved_to)
                    moved_body = body
                blocks.append(engine.process(n))
            outs.append(np.concatenate(blocks))
        moved, fresh = outs
        tol = 2 * float32_ulp_of_peak(fresh)
        np.testing.assert_allclose(moved[(k + 1) * n :], fresh[(k + 1) * n :], rtol=0, atol=tol)
        assert np.max(np.abs(moved - fresh)[: k * n]) > 100 * tol  # the move is heard
        if channels == 4:
            for got, want in zip(moved_body.listener, shifted):
                np.testing.assert_allclose(got.position, want.position, rtol=0, atol=1e-15)
        assert moved_body._engine.listener_grid_memory > 0  # the plate's grids, kept


def test_a_listener_moved_close_to_its_plate_takes_the_exact_rule(scene):
    # below the fixed grids' height (their panels no longer resolve 1/R) a move takes the
    # gains of modal_model itself, bit for bit; above it, from the grids the engine keeps
    # once a plate's listener moved, one for all the bodies of that plate
    from synth.sound.radiation.fixed import NEAR_FIELD_HEIGHT
    from synth.sound.render import modal_model

    engine = synth.Engine(samplerate=FS)
    body = engine.add(scene.plate)
    other = engine.add(scene.plate)
    low = synth.Microphone((0.5, 0.2, 0.5 * NEAR_FIELD_HEIGHT))
    body.move(low)
    exact = modal_model(scene.plate, low, samplerate=FS)
    np.testing.assert_array_equal(body._model.output, exact.output)
    assert engine.listener_grid_memory == 0  # no grid built for it
    body.move(synth.Microphone((0.5, 0.2, NEAR_FIELD_HEIGHT)))
    other.move(synth.Microphone((0.5, 0.2, 2 * NEAR_FIELD_HEIGHT)))
    assert len(engine._grids) == 1 and body._grid is other._grid
    assert engine.listener_grid_memory == body._grid.nbytes > 0


@pytest.mark.skipif(not hasattr(__import__("resource"), "RUSAGE_THREAD"), reason="Linux only")
def test_a_first_hit_on_a_new_body_touches_no_new_page(scene):
    # the audio thread must not take page faults: every array it works on is written once
    # when the body is added (a fresh allocation's pages are mapped at their first write),
    # so the block that takes a body's first hit (its pulse transformed, a voice slot's
    # modal state and its parked state written, the body's mix) faults no page in. Counted
    # by the kernel for the calling thread: its minor faults over that block alone
    import resource

    from synth.live import native

    engine = synth.Engine(samplerate=FS)
    out = np.zeros((engine.blocksize, 1), dtype=np.float32)
    native.mix_engine(engine._native.ctl, out)  # the engine's own first block
    bodies = [engine.add(scene.plate, listener=scene.listener) for _ in range(4)]
    for body in bodies:
        body.hit(scene.ball, 1.0, at=engine.time)
    before = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
    native.mix_engine(engine._native.ctl, out)
    faults = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - before
    assert engine.stats.impacts_played == len(bodies)
    assert faults == 0


class _BackToBack:
    """The native callback mixing blocks of ``frames`` into an engine's state back to back on
    another thread (ctypes releases the GIL), as a stream's would: :meth:`after_next` waits
    until a block started after the call has been mixed."""

    def __init__(self, engine, frames: int):
        import threading

        from synth.live import native

        self.blocks, self._stop = 0, threading.Event()
        out = np.empty((frames, engine.channels), dtype=np.float32)

        def mix():
            while not self._stop.is_set():
                native.mix_engine(engine._native.ctl, out)
                self.blocks += 1

        self._thread = threading.Thread(target=mix)

    def __enter__(self):
        self._thread.start()
        self._wait_for(1)
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def _wait_for(self, blocks: int) -> None:
        import time

        while self.blocks < blocks:
            time.sleep(0.0002)

    def after_next(self) -> None:
        self._wait_for(self.blocks + 2)  # the block under way, then one started after


def test_a_stop_fade_asked_while_the_callback_mixes_starts_with_a_later_block():
    # the controlling thread asks for the stop fade while the callback mixes long blocks back
    # to back: each time, a block started after the ask has started the fade. The callback
    # alone writes the fade's position; one written from outside while a block ran was
    # overwritten by the block's own at its end, and stop() waited on a fade that never
    # began (a lost write: almost every time here)
    from synth.live import state as st
    from synth.live.engine import ask_fade

    engine = synth.Engine(samplerate=FS, blocksize=256)
    ctl = engine._native.ctl
    for trial in range(20):
        ctl[st.FADE_AT], ctl[st.FADE_ASKED] = -1, 0
        with _BackToBack(engine, FS) as callback:
            ask_fade(ctl)
            callback.after_next()
        assert ctl[st.FADE_AT] >= 0, trial


def test_a_meter_reset_while_the_callback_mixes_takes_effect():
    # reset_meter()'s ask while the callback mixes long silent blocks back to back: a block
    # started after it has restarted the bus' peaks and the limiter's least gain (a reset
    # written from outside while a block ran was overwritten by the block's figures, kept at
    # the old peak)
    from synth.live import limiter
    from synth.live import state as st
    from synth.live.engine import ask_meter_reset

    engine = synth.Engine(samplerate=FS, blocksize=256, limiter=True)
    times, floats = engine._native.times, engine._native.limiter.floats
    for trial in range(20):
        times[[st.PEAK, st.OUT_PEAK]], floats[limiter.F_MIN_GAIN] = 0.5, 0.5  # an old loud part
        with _BackToBack(engine, FS) as callback:
            ask_meter_reset(engine._native.ctl)
            callback.after_next()
        assert times[st.PEAK] == 0.0 and times[st.OUT_PEAK] == 0.0, trial
        assert floats[limiter.F_MIN_GAIN] == 1.0, trial
    engine.process(256)  # the engine's own use of its state is as before
    times[st.PEAK] = 0.5
    engine.reset_meter()  # without a stream: at once
    assert engine.stats.peak == 0.0
