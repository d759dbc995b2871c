"""The live engine on a real audio server: JACK's dummy backend, a clocked server without
hardware (`.ci/run` installs jackd2 and libportaudio2)."""

import ctypes
import os
import re
import signal
import threading
import time
from dataclasses import dataclass

import numpy as np
import pytest
from conftest import REPOSITORY, python_blocks

import synth
from benchmarks.jack import JackDummyServer, jackd_available
from synth.live import state as st

pytestmark = [
    pytest.mark.skipif(
        not jackd_available(), reason="jackd is not installed (Debian: apt-get install jackd2)"
    ),
    # one JACK server at a time: the tests of every file that starts one run on one worker
    pytest.mark.xdist_group("jack"),
]

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
            voice = bodies[i].hit(scene.ball, v, position=pos, gain=gain)
            played.append((i, v, pos, gain, voice.onset if voice is not None else None))

    engine.start()
    assert engine.running and client_ports(jack)
    thread = threading.Thread(target=trigger)
    thread.start()
    thread.join()
    assert wait_for(lambda: engine.recorded >= engine.recording.shape[0], seconds + 10)
    stats = engine.stats
    engine.stop()
    assert not engine.running
    assert jack.alive and client_ports(jack) == []  # the server is left as it was
    assert stats.impacts_played == len(played) == 40
    assert stats.impacts_refused == 0 and stats.impacts_late == 0
    # the callback's run time (stats.callback_max) is wall-clock: `synth bench live` reports
    # it; a test on a shared machine can only ask that the stream ran
    assert stats.callbacks > 0

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


def test_a_burst_on_many_bodies_is_bounded_per_callback_and_every_hit_played(jack, scene):
    # max_hits_per_block pulses on each of M bodies wait while the engine is paused (its
    # clock held, no block transforms anything); all start at the held clock's next frame.
    # On resume no callback transforms more than max_hits_per_block pulses over all bodies
    # (M times as many, M * 110 us each on the default plate, would take several blocks):
    # the first callback takes the bound, each later one the bound again; every hit is
    # played, and those transformed after their start are counted late (played at the
    # start of the block that takes them), so late = M * bound - bound exactly
    bodies_n = 8
    with synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device, fade=0.002) as engine:
        bound = engine.max_hits_per_block
        bodies = [
            engine.add(scene.plate, listener=scene.listener, gain=0.01) for _ in range(bodies_n)
        ]
        for body in bodies:
            body.prepare(scene.position)
        engine.pause()
        assert wait_for(lambda: float(engine._native.times[st.PAUSE_LEVEL]) == 0.0, 2.0)
        time.sleep(0.05)  # a callback that began before the fade ended has returned
        at = engine.time
        for body in bodies:
            for _ in range(bound):
                assert body.hit(scene.ball, 1.0, position=scene.position, at=at) is not None
        assert engine.stats.impacts_played == 0
        engine.resume()
        assert wait_for(lambda: engine.stats.impacts_pending == 0, 5.0)
        stats = engine.stats
    assert stats.transforms_max == bound
    assert stats.impacts_played == bodies_n * bound
    assert stats.impacts_refused == stats.impacts_dropped == 0
    assert stats.impacts_late == bodies_n * bound - bound
    assert stats.transforms_deferred >= bodies_n * bound - bound


def test_a_stalled_server_is_counted_as_its_own_late_cycle(jack, scene):
    # the server's process stopped for 50 ms (about 9 blocks: a machine that does not run
    # it, as a virtual machine's host may not): its own cycle ends late, which it prints,
    # and the engine's callback is flagged with an output underflow although its work
    # took a fraction of a block. `synth bench live` reports both per phase
    with synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device) as engine:
        engine.add(scene.plate, listener=scene.listener, gain=0.05).hit(scene.ball, 1.0)
        time.sleep(0.2)
        late, underflows = jack.late_cycles(), engine.stats.output_underflows
        os.kill(jack.pid, signal.SIGSTOP)
        try:
            time.sleep(0.05)
        finally:
            os.kill(jack.pid, signal.SIGCONT)
        assert wait_for(lambda: jack.late_cycles() > late, 2.0)
        assert wait_for(lambda: engine.stats.output_underflows > underflows, 2.0)
        assert engine.running and not engine.stats.device_lost
    assert "jackd" in jack.log() or "jackdmp" in jack.log()


def test_add_while_running_and_stop_fades_out(jack, scene):
    with synth.Engine(
        samplerate=FS, blocksize=BLOCK, device=jack.device, record_seconds=2.0, fade=0.01
    ) as engine:
        time.sleep(0.1)
        body = engine.add(scene.plate, listener=scene.listener)  # picked up at the next block
        # (the clock read before the call: after it, a thread descheduled on a busy machine
        # may read a clock that has passed the onset)
        before = engine.time
        onset = body.hit(scene.ball, 2.0).onset
        assert onset > before
        assert wait_for(lambda: engine.stats.impacts_played == 1, 2.0)
        time.sleep(0.05)  # stop while it rings
    assert not engine.running and client_ports(jack) == []
    out = engine.recording[:, 0]
    end = engine.recorded
    stopped_at = fade_frame(engine)
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


def busy_python(stop):
    """A game's own loop: pure Python that never sleeps."""
    x = 0
    while not stop.is_set():
        for i in range(1000):
            x += i * i


def run_threads(targets, seconds):
    stop = threading.Event()
    threads = [threading.Thread(target=t, args=(stop,)) for t in targets]
    for t in threads:
        t.start()
    time.sleep(seconds)
    stop.set()
    for t in threads:
        t.join()


def hold_the_gil(seconds):
    """Sleep in C while holding Python's GIL: ctypes' PyDLL calls keep the GIL, so no other
    Python thread runs (and no callback that needs the GIL could) for ``seconds`` s."""
    ctypes.PyDLL(None).usleep(int(seconds * 1e6))


def test_the_audio_runs_while_another_thread_holds_the_gil(jack, scene):
    # the callback is compiled code that PortAudio calls without Python's GIL (its machine
    # code calls no Python API: tests/cold_children.py). While a thread holds the GIL for
    # 3 s (sleeping, so the CPU stays free and only the GIL is asked about) a callback that
    # needed it would stall for the whole hold: almost no block called back, one gap as
    # long as the hold (the Python fallback's, in the timing test below). The stream keeps
    # its clock instead: at least 90 % of the blocks are called back, no gap and no
    # callback lasts a tenth of the hold, and fewer than a tenth of the blocks are flagged
    # (PortAudio's output_underflow). The flags a loaded machine raises with no hold at all
    # (the server's own late cycles, a client thread woken late: up to a few in a hundred
    # blocks on a busy 2-core virtual machine) are measured by `synth bench live`
    engine = synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device)
    engine.add(scene.plate, listener=scene.listener, gain=0.05)
    seconds = 3.0
    with engine:
        time.sleep(0.2)
        before = engine.stats
        hold_the_gil(seconds)
        after = engine.stats
    blocks = seconds * FS / BLOCK
    assert after.callbacks - before.callbacks > 0.9 * blocks  # the clock ran throughout
    assert after.callback_gap_max < 0.1 * blocks  # in blocks: no stall
    assert after.callback_max < 0.1 * blocks  # in blocks: no callback waited
    assert after.output_underflows - before.output_underflows < 0.1 * blocks


def test_busy_python_threads_leave_the_stream_running_and_hits_played(jack, scene):
    # a pure-Python busy loop, then 8 threads calling hit() in loops: the stream keeps
    # running and plays the hits (4 pulses a block on each of 2 bodies bound the audio
    # thread's work). Whether a machine's spare CPU keeps every block in time under this
    # load (a non-realtime audio thread competes with the busy ones) is measured, not
    # asserted: `synth bench live` prints the underflows of both loads
    engine = synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device, max_hits_per_block=4)
    bodies = [engine.add(scene.plate, listener=scene.listener, gain=0.05) for _ in range(2)]
    rng = np.random.default_rng(3)
    speeds = rng.uniform(0.3, 2.0, 64)

    def hitter(k):
        def hit(stop):
            i = 0
            while not stop.is_set():
                bodies[(k + i) % len(bodies)].hit(scene.ball, float(speeds[i % 64]))
                i += 1

        return hit

    with engine:
        time.sleep(0.2)
        before = engine.stats
        run_threads([busy_python], 3.0)
        busy = engine.stats
        run_threads([hitter(k) for k in range(8)], 3.0)
        assert wait_for(lambda: engine.stats.impacts_pending == 0, 2.0)
        after = engine.stats
    blocks = 3.0 * FS / BLOCK
    assert busy.callbacks - before.callbacks > blocks / 2  # the stream ran throughout
    assert after.callbacks - busy.callbacks > blocks / 2
    assert after.impacts_played - busy.impacts_played > 100
    assert after.failed is None


def test_a_stopped_engine_starts_again_and_plays(jack, scene):
    engine = synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device)
    body = engine.add(scene.plate, listener=scene.listener, gain=0.1)
    for round_ in (1, 2):
        with engine:
            assert body.hit(scene.ball, 1.0) is not None
            assert wait_for(lambda: engine.stats.impacts_played == round_, 5.0)
        assert client_ports(jack) == []
    assert engine.stats.impacts_refused == 0


GC_SCRIPT = """
import gc, sys, time
import synth
scene = synth.load_preset("default")
engine = synth.Engine(samplerate=48000, blocksize=256, device=int(sys.argv[1]))
engine.add(scene.plate, listener=scene.listener).hit(scene.ball, 1.0)
engine.start()
time.sleep(0.3)
del engine
gc.collect()
time.sleep(0.5)
print("collected")
"""


@pytest.mark.slow  # a new process imports the package and loads the engine's kernels
def test_collecting_a_running_engine_closes_its_stream(jack):
    # the engine, its stream and a Python callback formed a cycle that nothing closed:
    # collecting it aborted Python on the audio thread. Now a finaliser closes the stream
    import os
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", GC_SCRIPT, str(jack.device)],
        capture_output=True,
        text=True,
        timeout=300,
        env=os.environ.copy(),
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert "collected" in out.stdout
    assert client_ports(jack) == []


DEATH_SCRIPT = """
import os, sys, threading, time
sys.path.append(sys.argv[1])  # the repository's benchmarks, after the installed synth
import synth
from synth.errors import SynthError
from benchmarks.jack import JackDummyServer
scene = synth.load_preset("default")
server = JackDummyServer(samplerate=48000, period=256).start()
lost = []
event = threading.Event()
engine = synth.Engine(samplerate=48000, blocksize=256, device=server.device,
                      on_device_lost=lambda why: (lost.append(why), event.set()))
body = engine.add(scene.plate, listener=scene.listener, gain=0.1)
engine.start()
while engine.stats.callbacks < 10:
    time.sleep(0.01)
print("lost before", engine.stats.device_lost, len(lost), flush=True)
server._process.terminate()  # the server goes away (cleanly: JACK's registry stays clean)
server._process.wait()
print("lost event", event.wait(60.0), len(lost), "called back" in lost[0], flush=True)
print("device_lost", engine.stats.device_lost, flush=True)
print("silent", engine.stats.silent_for > 0.5, flush=True)
try:
    body.hit(scene.ball, 1.0)
    print("accepted", flush=True)
except SynthError as exc:
    print("refused:", exc, flush=True)
done = threading.Event()
threading.Thread(target=lambda: (engine.stop(timeout=1.0), done.set()), daemon=True).start()
print("stop returned", done.wait(60.0), flush=True)
print("running", engine.running, "failed", engine.stats.failed is not None, flush=True)
for call in (lambda: body.hit(scene.ball, 1.0), engine.start):
    try:
        call()
        print("accepted", flush=True)
    except SynthError as exc:
        print("refused:", exc, flush=True)
# PortAudio's own exit handler (Pa_Terminate) would wait on the abandoned stream
os._exit(0)
"""


def test_a_stop_held_up_past_its_timeout_still_fades_and_closes(jack, scene, monkeypatch):
    # the process is held up as stop() begins (a stalled machine: its clock jumps 2.5 s, past
    # the 2 s timeout, while the server had no chance to call back): the stall does not count
    # against the server, so the stop fades as always, closes, and the engine stays usable
    import synth.live.engine as live_engine

    fade = 0.01
    engine = synth.Engine(
        samplerate=FS, blocksize=BLOCK, device=jack.device, record_seconds=1.0, fade=fade
    )
    engine.add(scene.plate, listener=scene.listener, gain=0.1).hit(scene.ball, 1.0, at=0.05)
    looks = []

    class HeldUp:
        """The time module as stop() sees it: 2.5 s later from its second look on."""

        def __getattr__(self, name):
            return getattr(time, name)

        def monotonic(self):
            looks.append(None)
            return time.monotonic() + (2.5 if len(looks) > 1 else 0.0)

    engine.start()
    assert wait_for(lambda: engine.time > 0.2, 10.0)
    monkeypatch.setattr(live_engine, "time", HeldUp())
    engine.stop(timeout=2.0)
    monkeypatch.undo()
    assert len(looks) > 2 and not engine.running and engine.failed is None
    start = fade_frame(engine)
    out = engine.recording[:, 0]
    assert 0 < start < engine.recorded and np.any(out[:start])
    assert not np.any(out[start + int(fade * FS) : engine.recorded])  # faded, then silent
    assert client_ports(jack) == []
    assert engine.process(BLOCK).shape == (BLOCK, 1)  # usable: no SynthError


@pytest.mark.slow  # a new process imports the package and loads the engine's kernels
def test_stop_is_bounded_when_the_server_dies():
    # PortAudio's stop waits for the JACK server for ever once it is gone: stop(timeout=)
    # abandons the stream, marks the engine failed, and hits are then refused clearly; before
    # stop(), the lost server is seen in the stats (silent_for) and hits are refused.
    # In a child process, which waits for stop() on a thread (a hang is a failure, not a
    # slow pass)
    import os
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", DEATH_SCRIPT, str(REPOSITORY)],
        capture_output=True,
        text=True,
        timeout=300,
        env=os.environ.copy(),
    )
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    # while it runs, a stream that stopped calling back is reported (once, through
    # on_device_lost, and in the stats), and hits refused
    assert lines.pop(0) == "lost before False 0"
    assert lines.pop(0) == "lost event True 1 True"
    assert lines.pop(0) == "device_lost True"
    assert lines.pop(0) == "silent True"
    line = lines.pop(0)
    assert line.startswith("refused:") and "has not called back" in line
    assert lines[0] == "stop returned True"
    assert lines[1] == "running False failed True"
    assert lines[2].startswith("refused:") and "failed" in lines[2]
    assert lines[3].startswith("refused:") and "failed" in lines[3]


@pytest.mark.parametrize(
    "path, index", [("README.md", 1), ("docs/live.md", 0)], ids=["readme", "live.md"]
)
def test_the_live_examples_run_as_printed(jack, path, index, monkeypatch, capsys):
    # the examples use the default output device: here the JACK server's. They play a hit
    # before the stop fade (it is not cut), then go on without a device
    import sounddevice

    monkeypatch.setattr(sounddevice.default, "device", [None, jack.device])
    code = python_blocks(path)[index]
    assert "synth.Engine(" in code and "process(" in code
    namespace = {}
    exec(compile(code, path, "exec"), namespace)
    engine, audio = namespace["engine"], namespace["audio"]
    printed = capsys.readouterr().out
    assert "EngineStats(" in printed
    stats = engine.stats
    assert stats.callbacks > 0 and stats.failed is None
    assert stats.impacts_played >= 2 and stats.impacts_refused == 0
    # the hit of the stream rang before the fade: its peak is in the meter, and the hit
    # played without a stream is in process()'s output
    assert stats.peak > 0.0
    assert audio.dtype == np.float32 and np.max(np.abs(audio)) > 0.0
    assert client_ports(jack) == []
    if path == "README.md":
        # the stream's one hit played whole, not cut by the stop fade: the bus' peak that
        # the example prints (the meter before process() adds its own hit) is the hit's
        # own, as process() plays it, within the spread of its peaks over the fraction of
        # a sample at which a live hit starts (unknown: it depends on the call's time; 2 %
        # beyond the extremes of a 32-point grid of fractions, whose spread is about 1 %)
        streamed = float(re.search(r"\bpeak=([0-9.eE+-]+)", printed).group(1))
        lo, hi = hit_peak_range(namespace["table"], namespace["ball"])
        assert 0.98 * lo <= streamed <= 1.02 * hi
        # and it rang its 0.5 s: the stop fade began no sooner after its start
        voice = namespace["voice"]
        assert fade_frame(engine) / FS - voice.onset >= 0.5 - 0.05


def fade_frame(engine) -> int:
    """The frame where the engine's last stop fade began (-1: none)."""
    return int(engine._native.ctl[st.FADE_FRAME])


def hit_peak_range(table, ball, fractions=32):
    """The least and the largest bus peak of the README's hit (1.5 m/s at (0.3, 0.2) on the
    example's stereo ``table``) played by process() from ``fractions`` evenly spaced
    fractions of a sample (one hit at a time, each silenced before the next)."""
    engine = synth.Engine(samplerate=FS, blocksize=BLOCK, channels=2)
    body = engine.add(table.plate, listener=table.listener)
    peaks = []
    for f in range(fractions):
        body.hit(ball, 1.5, position=(0.3, 0.2), at=engine.time + (BLOCK + f / fractions) / FS)
        engine.process(FS // 20)
        peaks.append(engine.stats.peak)
        body.stop_all()
        engine.reset_meter()
    return min(peaks), max(peaks)


def test_the_python_fallback_plays_through_the_same_block(jack, scene):
    # callback="python": a Python function runs the same compiled block (it needs the GIL
    # each block); what it plays is what process() plays
    engine = synth.Engine(
        samplerate=FS, blocksize=BLOCK, device=jack.device, callback="python", record_seconds=1.0
    )
    body = engine.add(scene.plate, listener=scene.listener, gain=0.1)
    with engine:
        onset = body.hit(scene.ball, 1.0, at=0.1).onset
        assert wait_for(lambda: engine.recorded >= engine.recording.shape[0], 10.0)
    assert engine.stats.impacts_played == 1 and onset == 0.1
    offline = synth.Engine(samplerate=FS, blocksize=BLOCK)
    offline.add(scene.plate, listener=scene.listener, gain=0.1).hit(scene.ball, 1.0, at=0.1)
    want = offline.process(FS)
    tol = float(np.spacing(np.float32(np.max(np.abs(want))))) * 4
    np.testing.assert_allclose(engine.recording, want, rtol=0, atol=tol)


def test_hits_queued_before_start_do_not_burden_the_first_callback(jack, scene):
    # hits queued without a stream are not bounded per block (process() has no deadline);
    # the first callback used to transform them all (55 % of a block). start() now
    # transforms them on the calling thread: no block of the stream transforms more than
    # max_hits_per_block pulses (counted by the audio thread)
    engine = synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device)
    body = engine.add(scene.plate, listener=scene.listener, gain=0.05)
    queued = 3 * engine.max_hits_per_block
    for k in range(queued):
        assert body.hit(scene.ball, 1.0, at=0.05 + 0.001 * k) is not None
    with engine:
        assert wait_for(lambda: engine.stats.impacts_played == queued, 5.0)
        for _ in range(engine.max_hits_per_block):  # the stream's own bound still holds
            body.hit(scene.ball, 1.0)
        assert wait_for(lambda: engine.stats.impacts_pending == 0, 5.0)
    from synth.live import kernel

    assert 1 <= body._counters[kernel.MOST_PULSES] <= engine.max_hits_per_block
    assert engine.stats.impacts_refused == 0


def test_voices_stop_and_stealing_play_live_as_process_plays_them(jack, scene):
    # two voice slots: hits scheduled ahead steal the oldest voice; a voice stopped while
    # it rings fades out from the block after the call. The stream plays what process()
    # plays for the same hits with the stop taken at that block (the block found as the
    # first one where the recording leaves the render without the stop)
    seconds = 1.5
    kw = dict(samplerate=FS, blocksize=BLOCK, max_voices=2)
    engine = synth.Engine(device=jack.device, record_seconds=seconds, **kw)
    hits = [(1.5, 0.30, (0.3, 0.2)), (0.4, 0.31, (0.6, 0.3)), (1.0, 0.35, (0.9, 0.2))]
    hits.append((0.8, 0.5, (0.5, 0.25)))
    body = engine.add(scene.plate, listener=scene.listener, gain=0.1)
    with engine:
        voices = [body.hit(scene.ball, v, position=p, at=at) for v, at, p in hits]
        assert wait_for(lambda: engine.time > 0.6, 10.0)
        assert voices[2].playing
        voices[2].stop(fade=0.01)
        assert wait_for(lambda: engine.recorded >= engine.recording.shape[0], seconds + 10)
        stats = engine.stats
    assert stats.voices_stolen == 2 and stats.impacts_played == 4 and stats.impacts_late == 0
    # stolen at the third and fourth hits, stopped, silenced by stop()
    assert engine.ended() == [voices[k].id for k in (0, 1, 2, 3)]
    live = engine.recording[:, 0].astype(float)

    def offline(stop_frame=None):
        e = synth.Engine(**kw)
        b = e.add(scene.plate, listener=scene.listener, gain=0.1)
        vs = [b.hit(scene.ball, v, position=p, at=at) for v, at, p in hits]
        if stop_frame is None:
            return e.process(live.size)[:, 0].astype(float)
        head = e.process(stop_frame)
        vs[2].stop(fade=0.01)
        return np.concatenate([head, e.process(live.size - stop_frame)])[:, 0].astype(float)

    unstopped = offline()
    tol = float(np.spacing(np.float32(np.max(np.abs(unstopped))))) * 4
    differs = np.flatnonzero(np.abs(live - unstopped) > tol)
    assert differs.size and differs[0] > 0.6 * FS
    want = offline(stop_frame=int(differs[0]) // BLOCK * BLOCK)
    np.testing.assert_allclose(live, want, rtol=0, atol=tol)


def test_pause_holds_the_voices_live_as_process_holds_them(jack, scene):
    # pause while a voice rings, resume a while later: the stream ran on (callbacks
    # counted, silence written), and what it recorded on the engine's clock (held while
    # paused) is process() with the pause taken at the block where the recording first
    # leaves the unpaused render

    kw = dict(samplerate=FS, blocksize=BLOCK)
    engine = synth.Engine(device=jack.device, record_seconds=1.0, **kw)
    body = engine.add(scene.plate, listener=scene.listener, gain=0.1)
    with engine:
        voice = body.hit(scene.ball, 1.0, at=0.2)
        assert wait_for(lambda: engine.time > 0.4, 10.0)
        engine.pause()
        assert wait_for(lambda: engine._native.times[st.PAUSE_LEVEL] == 0.0, 5.0)
        callbacks, held = engine.stats.callbacks, engine.time
        time.sleep(0.2)
        assert engine.stats.callbacks > callbacks and engine.time == held and voice.playing
        engine.resume()
        assert wait_for(lambda: engine.recorded >= engine.recording.shape[0], 10.0)
        engine.pause()  # stop() while paused: the output is silent already
        assert wait_for(lambda: engine._native.times[st.PAUSE_LEVEL] == 0.0, 5.0)
    assert not engine.running and not engine.paused and client_ports(jack) == []
    live = engine.recording[:, 0].astype(float)

    def offline(pause_frame=None):
        e = synth.Engine(**kw)
        e.add(scene.plate, listener=scene.listener, gain=0.1).hit(scene.ball, 1.0, at=0.2)
        if pause_frame is None:
            return e.process(live.size)[:, 0].astype(float)
        head = e.process(pause_frame)
        e.pause()
        fading = e.process(4 * BLOCK)[: int(round(e.time * FS)) - pause_frame]
        e.resume()
        rest = e.process(live.size - int(round(e.time * FS)))
        return np.concatenate([head, fading, rest])[:, 0].astype(float)

    unpaused = offline()
    tol = float(np.spacing(np.float32(np.max(np.abs(unpaused))))) * 4
    differs = np.flatnonzero(np.abs(live - unpaused) > tol)
    assert differs.size and differs[0] > 0.4 * FS
    want = offline(pause_frame=int(differs[0]) // BLOCK * BLOCK)
    np.testing.assert_allclose(live, want, rtol=0, atol=tol)


def test_a_body_removed_while_the_stream_runs_is_freed_and_its_room_reused(jack, scene):
    # two bodies ring; one is removed with a fade while the stream runs: the callback
    # leaves it at a block boundary and the engine lets go of its arrays; the other plays
    # on as process() plays it alone, and the freed room takes a new body
    import gc
    import weakref

    seconds = 1.0
    kw = dict(samplerate=FS, blocksize=BLOCK, max_bodies=2)
    engine = synth.Engine(device=jack.device, record_seconds=seconds, **kw)
    keep = engine.add(scene.plate, listener=scene.listener, gain=0.1)
    gone = engine.add(scene.plate, listener=scene.listener, gain=0.1)
    with engine:
        keep.hit(scene.ball, 1.0, at=0.3)
        gone.hit(scene.ball, 1.5, position=(0.3, 0.2), at=0.3)
        assert wait_for(lambda: engine.time > 0.4, 10.0)
        arrays = weakref.ref(gone._ring.amplitudes)
        gone.remove(fade=0.01)
        quiet = engine._frame + BLOCK + int(0.01 * FS)  # the fade ends by then
        assert wait_for(lambda: engine.stats and gone.memory == 0, 5.0)
        gc.collect()
        assert arrays() is None and engine.bodies == (keep,)
        assert engine.add(scene.plate, listener=scene.listener, gain=0.1).modes == keep.modes
        assert wait_for(lambda: engine.recorded >= engine.recording.shape[0], seconds + 10)
        stats = engine.stats
    assert stats.impacts_played == 2 and stats.impacts_late == 0
    live = engine.recording[:, 0].astype(float)
    e = synth.Engine(**kw)
    e.add(scene.plate, listener=scene.listener, gain=0.1).hit(scene.ball, 1.0, at=0.3)
    alone = e.process(live.size)[:, 0].astype(float)
    tol = 4 * float(np.spacing(np.float32(np.max(np.abs(alone)))))
    # once the removed body's fade has ended, only the kept body sounds
    assert quiet < live.size
    np.testing.assert_allclose(live[quiet:], alone[quiet:], rtol=0, atol=tol)


def test_priorities_and_the_engine_cap_hold_while_the_stream_runs(jack, scene):
    # one slot a body, three voices in the engine: a priority-5 hit on each body; lower
    # ones from another thread never sound: each is refused by its body's slot when it
    # comes to join (the first one at least: the engine had room for it), or, while an
    # earlier one waits, steals that one in the engine's cap (equal priorities: the
    # oldest goes) or is refused there; which of these depends on the thread's timing,
    # what plays does not: the stream plays the two kept hits as process() plays them
    seconds = 1.0
    kw = dict(samplerate=FS, blocksize=BLOCK, max_voices=1, max_total_voices=3)
    engine = synth.Engine(device=jack.device, record_seconds=seconds, **kw)
    bodies = [engine.add(scene.plate, listener=scene.listener, gain=0.1) for _ in range(2)]
    kept = [(0, 1.0, 0.3), (1, 1.5, 0.31)]
    refused = []
    with engine:
        for b, v, at in kept:
            bodies[b].hit(scene.ball, v, at=at, priority=5)

        def low():
            for k in range(20):
                refused.append(bodies[k % 2].hit(scene.ball, 2.0, priority=1))
                time.sleep(0.005)

        assert wait_for(lambda: engine.time > 0.33, 10.0)  # both kept hits ring
        t = threading.Thread(target=low)
        t.start()
        t.join()
        assert wait_for(lambda: engine.recorded >= engine.recording.shape[0], seconds + 10)
        stats = engine.stats
    assert len(refused) == 20 and not any(v is not None and v.playing for v in refused)
    # a hit its body refuses as the cap steals it counts in both (the cap cannot know):
    # every low hit is counted once at least, and its impact dropped exactly once
    assert stats.voices_refused >= 1 and stats.voices_refused + stats.voices_stolen >= 20
    assert stats.impacts_played == 2 and stats.impacts_dropped + stats.impacts_refused == 20
    e = synth.Engine(**kw)
    offline = [e.add(scene.plate, listener=scene.listener, gain=0.1) for _ in range(2)]
    for b, v, at in kept:
        offline[b].hit(scene.ball, v, at=at, priority=5)
    want = e.process(engine.recording.shape[0])[:, 0].astype(float)
    live = engine.recording[:, 0].astype(float)
    tol = 4 * float(np.spacing(np.float32(np.max(np.abs(want)))))
    np.testing.assert_allclose(live, want, rtol=0, atol=tol)


def test_the_limiter_holds_the_ceiling_on_the_stream_as_process_does(jack, scene):
    # a stereo hit at +12 dBFS through the stream with the true-peak limiter: the samples
    # the callback sent are process()'s of the same hit (the same compiled bus), none and
    # no 4x-oversampled point between them above the ceiling; a hit without ``at`` counts
    # the look-ahead in its latency (it is not played late)
    from synth.live.limiter import true_peak

    ears = synth.live.ears((0.6, -0.4, 0.5), (0.0, 1.0))

    def engine_with_hit(**kw):
        engine = synth.Engine(
            samplerate=FS, blocksize=BLOCK, channels=2, clip=False, limiter=True,
            ceiling_db=-1.0, **kw,
        )  # fmt: skip
        body = engine.add(scene.plate, listener=ears, gain=1.0)
        return engine, body

    probe, body = engine_with_hit()
    body.hit(scene.ball, 2.0, at=0.05)
    probe.process(FS // 5)
    gain = 10.0 ** (12.0 / 20.0) / probe.stats.peak  # the bus' peak before the limiter
    live, body = engine_with_hit(device=jack.device, record_seconds=0.5)
    body.gain = gain
    with live:
        body.hit(scene.ball, 2.0, at=0.05)
        assert wait_for(lambda: live.recorded >= live.recording.shape[0], 10.0)
        late = body.hit(scene.ball, 2.0)  # on the stream's own clock
        assert wait_for(lambda: live.stats.impacts_played == 2, 5.0)
    offline, body = engine_with_hit()
    body.gain = gain
    body.hit(scene.ball, 2.0, at=0.05)
    want = offline.process(FS // 2)
    ceiling = 10.0 ** (-1.0 / 20.0)
    assert offline.stats.peak > 10.0 ** (11.0 / 20.0)  # the bus before the limiter
    tol = 4 * float(np.spacing(np.float32(ceiling)))
    np.testing.assert_allclose(live.recording, want, rtol=0, atol=tol)
    assert np.max(np.abs(live.recording)) <= ceiling and true_peak(live.recording) <= ceiling
    stats = live.stats
    assert stats.limiter_max_reduction_db > 11.0 and stats.limiter_active > 0
    assert stats.impacts_late == 0 and late is not None


#: The ramp tests' hits: one every RAMP_HITS_EVERY s from 0.05 s to RAMP_RECORD s, queued
#: before the stream starts (start() transforms them), so that a change lands on a ringing
#: plate whenever the calling thread gets it done (a move computes its gains there, 0.3 s of
#: CPU for two ears of the default plate, and a loaded machine gives that thread a fraction
#: of a core). A hit's sound falls by about 70 dB in RAMP_HITS_EVERY, far above the
#: tolerance; a voice rings about a second, so fewer than the body's 8 slots ring at once
#: and no voice is stolen; 100 hits fit the body's max_pending
RAMP_HITS_EVERY = 0.3
#: The ramp tests' recording, s: the longest the change may take to be handed over.
RAMP_RECORD = 30.0


@dataclass(frozen=True)
class LiveChange:
    """A stream's recording up to its stop fade, around a change made from another thread
    while it ran: the engine's clock (frames) read just before the change and just after."""

    live: np.ndarray
    called: int
    returned: int


def ramp_hits(body, ball):
    """Queue the ramp tests' hits on ``body`` (see :data:`RAMP_HITS_EVERY`)."""
    for at in np.arange(0.05, RAMP_RECORD, RAMP_HITS_EVERY):
        assert body.hit(ball, 1.0, at=float(at)) is not None


def change_while_running(engine, change) -> LiveChange:
    """Start ``engine``'s stream, call ``change()`` once its clock has passed 0.2 s and stop
    it 0.2 s of its clock after the call returned."""
    with engine:
        assert wait_for(lambda: engine.time > 0.2, 10.0)
        called = round(engine.time * FS)
        change()
        returned = round(engine.time * FS)
        assert wait_for(lambda: engine.time * FS > returned + 0.2 * FS, 10.0)
    end = fade_frame(engine)
    assert 0 < end <= engine.recorded, (end, engine.recorded, engine.stats)
    return LiveChange(engine.recording[:end].copy(), called, returned)


def assert_ramped_in_one_block(change: LiveChange, before, after):
    """``change.live`` is ``before`` up to one block, that block ramps linearly (old + u (new -
    old)) to ``after``, which it is from the next block on; the block that ramps is the first
    to start after the change was handed over: not before the clock read before the call, at
    most one block after the clock read after it (a block may have begun meanwhile).
    Tolerance: two float32 steps at the larger peak (the stream and process() mix alike,
    rounded to float32)."""
    live = change.live
    before, after = before[: live.shape[0]], after[: live.shape[0]]
    tol = 2 * float(np.spacing(np.float32(max(np.abs(before).max(), np.abs(after).max()))))
    differs = np.abs(live - before).max(axis=1) > tol
    assert differs.any(), "the change never reached the output"
    k = int(np.argmax(differs)) // BLOCK  # the block that took the change
    assert change.called <= k * BLOCK <= change.returned + BLOCK, (k * BLOCK, change)
    assert live.shape[0] >= (k + 1) * BLOCK + FS // 10  # a tenth of a second after it
    np.testing.assert_allclose(live[: k * BLOCK], before[: k * BLOCK], rtol=0, atol=tol)
    u = (np.arange(1, BLOCK + 1) / BLOCK)[:, None]
    span = slice(k * BLOCK, (k + 1) * BLOCK)
    ramp = before[span] + u * (after[span] - before[span])
    np.testing.assert_allclose(live[span], ramp, rtol=0, atol=2 * tol)
    np.testing.assert_allclose(live[(k + 1) * BLOCK :], after[(k + 1) * BLOCK :], rtol=0, atol=tol)


def ramp_engine(scene, listener, pan=None, **options):
    """A stereo engine (``options``) of one body of the default plate heard by ``listener``
    at ``pan``, the ramp tests' hits queued; returns the engine and the body."""
    engine = synth.Engine(samplerate=FS, blocksize=BLOCK, channels=2, floor_db=-200.0, **options)
    body = engine.add(scene.plate, listener=listener, pan=pan)
    ramp_hits(body, scene.ball)
    return engine, body


def assert_a_change_while_running_ramps(jack, make, change, load=None):
    """The stream of the engine ``make(**options)`` returns (with its body; ``load(engine)``
    called before it starts), changed by ``change(engine, body)`` while it runs, ramps in one block
    (:func:`assert_ramped_in_one_block`) from process() of the same engine unchanged to
    process() of it changed after its first block, which is silent and transforms the
    queued hits as start() does: their in-contact samples are heard by the listener of
    then, their ringing by the new one."""
    engine, body = make(device=jack.device, record_seconds=RAMP_RECORD)
    if load is not None:
        load(engine)
    live = change_while_running(engine, lambda: change(engine, body))
    frames = live.live.shape[0]
    before = make()[0].process(frames)
    engine, body = make()
    first = engine.process(BLOCK)
    assert not np.any(first)
    change(engine, body)
    assert_ramped_in_one_block(
        live, before, np.concatenate([first, engine.process(frames - BLOCK)])
    )


def test_a_listener_moved_while_the_stream_runs_ramps_within_one_block(jack, scene):
    # the game moves its listener while hits ring: the samples the callback sent are the
    # old listener's render up to one block, that block (the first after the move was
    # handed over) ramps every mode's gain linearly (old + u (new - old)) at both ears,
    # and from the next block on they are the new listener's render
    def make(**options):
        return ramp_engine(scene, synth.live.ears((0.6, -0.4, 0.5), (0.0, 1.0)), **options)

    def move(engine, body):
        engine.move_listener((0.3, 0.5, 0.3), facing=(1.0, 0.0))

    # as a game at load time: the move takes the sums alone
    assert_a_change_while_running_ramps(jack, make, move, load=synth.Engine.prepare_moves)


def test_a_device_without_the_engine_s_rate_is_refused_naming_both_rates(jack, scene):
    # the JACK server runs at 48 kHz only: an engine at 44.1 kHz is refused at start() with
    # a SynthError naming the rate asked and the device's default one (the engine does no
    # rate conversion), and stays usable without a device
    engine = synth.Engine(samplerate=44100, blocksize=BLOCK, device=jack.device)
    engine.add(scene.plate, listener=scene.listener).hit(scene.ball, 1.0, at=0.01)
    with pytest.raises(synth.SynthError, match=r"does not take 44100 Hz.*default rate is 48000 Hz"):
        engine.start()
    assert not engine.running and engine.failed is None and client_ports(jack) == []
    assert np.any(engine.process(4410))


def test_a_pan_set_while_the_stream_runs_ramps_within_one_block(jack, scene):
    # a body panned at -0.6 rings; the game pans it to 0.8 while the stream runs: the
    # samples the callback sent are process()'s at -0.6 up to one block, that block (the
    # first after the pan was set) ramps each channel's gain linearly (old + u (new - old)),
    # and from the next block on they are process()'s at 0.8
    def make(**options):
        return ramp_engine(scene, scene.listener, pan=-0.6, **options)

    def pan(engine, body):
        body.pan = 0.8

    assert_a_change_while_running_ramps(jack, make, pan)


def test_the_callback_timing_tells_a_gil_wait_from_the_callback_s_work(jack, scene):
    # a thread holds the GIL for 0.4 s (75 blocks), sleeping in C. The native callback
    # needs no GIL: its entries stay about one block apart (callback_gap_max; a few blocks
    # at most on a loaded machine, far below the hold) and its blocks keep coming. The
    # Python fallback cannot run while the GIL is held: its gap shows the whole wait (at
    # least the hold less a block of slack each side), while its callback_* figures, timed
    # once it holds the GIL, exclude the wait (as its docs say): its callback_max stays
    # far below the gap
    hold = 0.4
    blocks = hold * FS / BLOCK
    stats = {}
    for callback in ("native", "python"):
        engine = synth.Engine(samplerate=FS, blocksize=BLOCK, device=jack.device, callback=callback)
        engine.add(scene.plate, listener=scene.listener, gain=0.05)
        with engine:
            time.sleep(0.2)
            before = engine.stats
            hold_the_gil(hold)
            time.sleep(0.1)
            after = engine.stats
        assert after.failed is None and not after.device_lost
        stats[callback] = (before, after)
    before, after = stats["native"]
    assert after.callback_gap_max < blocks / 4
    assert after.callbacks - before.callbacks > 0.9 * (hold + 0.1) * FS / BLOCK
    assert 0.0 < after.callback_mean <= after.callback_max
    before, after = stats["python"]
    assert after.callback_gap_max > blocks - 2
    assert after.callback_max < blocks / 4
