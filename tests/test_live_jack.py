"""The live engine on a real audio server: JACK's dummy backend, a clocked server without
hardware (`.ci/run` installs jackd2 and libportaudio2)."""

import threading
import time

import numpy as np
import pytest

import synth
from synth.errors import SynthError
from synth.live.jack import JackDummyServer, jackd_available

pytestmark = pytest.mark.skipif(
    not jackd_available(), reason="jackd is not installed (Debian: apt-get install jackd2)"
)

FS = 48000
BLOCK = 256


@pytest.fixture(scope="module")
def jack():
    try:
        import sounddevice  # noqa: F401
    except OSError as exc:
        pytest.skip(f"PortAudio is not installed (Debian: apt-get install libportaudio2): {exc}")
    with JackDummyServer(samplerate=FS, period=BLOCK) as server:
        yield server


@pytest.fixture(scope="module")
def scene():
    return synth.load_preset("default")


def wait_for(condition, timeout):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def client_ports(server):
    return [p for p in server.ports() if not p.startswith("system:")]


def test_hits_from_another_thread_are_all_played_as_process_plays_them(jack, scene):
    # the stream's callback and process() run the same mixing code on the same blocks: the
    # audio tapped from the callback is process() of the same hits at the same start times.
    # A hit handed over after its block was mixed would be played late (and counted): the
    # hand-over allowance (0.1 s, the largest allowed) covers a trigger thread descheduled on a
    # busy test machine
    seconds = 3.0
    engine = synth.Engine(
        samplerate=FS, blocksize=BLOCK, device=jack.device, record_seconds=seconds, handover=0.1
    )
    plates = [(scene.plate, scene.listener), (scene.plate, synth.Accelerometer((0.3, 0.1)))]
    bodies = [engine.add(p, listener=li) for p, li in plates]
    played = []
    rng = np.random.default_rng(12)

    def trigger():
        for _ in range(40):
            time.sleep(rng.uniform(0.0, 0.05))
            i = int(rng.integers(len(bodies)))
            v = float(rng.uniform(0.1, 2.0))
            pos = (float(rng.uniform(0.05, 1.15)), float(rng.uniform(0.05, 0.44)))
            gain = float(rng.uniform(0.2, 1.0))
            onset = bodies[i].hit(scene.ball, v, position=pos, gain=gain)
            played.append((i, v, pos, gain, onset))

    engine.start()
    assert engine.running and client_ports(jack)
    thread = threading.Thread(target=trigger)
    thread.start()
    thread.join()
    assert wait_for(lambda: engine._recorded >= engine.recording.shape[0], seconds + 10)
    stats = engine.stats
    engine.stop()
    assert not engine.running
    assert jack.alive and client_ports(jack) == []  # the server is left as it was
    assert stats.impacts_played == len(played) == 40
    assert stats.impacts_refused == 0 and stats.impacts_late == 0
    # the callback's run time (stats.callback_max) is wall-clock: `synth bench live` reports
    # it; a test on a shared machine can only ask that the stream ran
    assert stats.callbacks > 0
    with pytest.raises(SynthError, match="stopped"):
        bodies[0].hit(scene.ball, 1.0)

    offline = synth.Engine(samplerate=FS, blocksize=BLOCK)
    replay = [offline.add(p, listener=li) for p, li in plates]
    for i, v, pos, gain, onset in played:
        assert onset is not None
        replay[i].hit(scene.ball, v, position=pos, gain=gain, at=onset)
    want = offline.process(engine.recording.shape[0])
    assert np.max(np.abs(want)) > 0.0
    tol = float(np.spacing(np.float32(np.max(np.abs(want))))) * 4
    np.testing.assert_allclose(engine.recording, want, rtol=0, atol=tol)


def test_a_burst_of_hits_is_bounded_per_block_while_the_stream_runs(jack, scene):
    # while the stream runs, at most max_hits_per_block pulses wait for the audio thread
    # (a bound on any block's transform work): a burst of hits faster than the blocks is
    # partly refused and counted; every accepted hit is played
    with synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device) as engine:
        body = engine.add(scene.plate, listener=scene.listener, gain=0.1)
        engine_limit = engine.max_hits_per_block
        time.sleep(0.05)
        accepted = sum(body.hit(scene.ball, 1.0) is not None for _ in range(20 * engine_limit))
        assert wait_for(lambda: engine.stats.impacts_pending == 0, 2.0)
        stats = engine.stats
    assert stats.impacts_refused == 20 * engine_limit - accepted > 0
    assert stats.impacts_played == accepted >= engine_limit


def test_add_while_running_and_stop_fades_out(jack, scene):
    with synth.Engine(
        samplerate=FS, blocksize=BLOCK, device=jack.device, record_seconds=2.0, fade=0.01
    ) as engine:
        time.sleep(0.1)
        body = engine.add(scene.plate, listener=scene.listener)  # picked up at the next block
        onset = body.hit(scene.ball, 2.0)
        assert onset > engine.time - 1e-9
        assert wait_for(lambda: engine.stats.impacts_played == 1, 2.0)
        time.sleep(0.05)  # stop while it rings
    assert not engine.running and client_ports(jack) == []
    out = engine.recording[:, 0]
    end = engine._recorded
    stopped_at = engine.fade_frame
    # the fade: raised cosine over 10 ms from the block after stop(), then exact silence
    fade = int(0.01 * FS)
    assert np.any(out[:stopped_at])
    tail = out[stopped_at + fade : end]
    assert tail.size and not np.any(tail)
    # no click: the last ringing samples are faded, not cut (each step is below the
    # largest step of the free ringing before stop)
    steps = np.abs(np.diff(out[:end]))
    assert np.max(steps[stopped_at:]) <= np.max(steps[:stopped_at])


def test_synth_play_runs_a_preset_through_the_engine(jack, capsys):
    # the command plays the preset's drop on the server and returns once it has rung out
    from synth.cli import main

    assert main(["play", "default", "--device", str(jack.device), "--max-seconds", "10"]) == 0
    out = capsys.readouterr().out
    assert "drop 1:" in out and "impacts played" in out
    assert client_ports(jack) == []
