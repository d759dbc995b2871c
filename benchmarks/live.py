"""``synth bench live``: what the live engine costs, measured in one run.

* the callback's mixing cost per block for 1, 4 and 16 bodies of the default preset's plate
  (all ringing: each is hit ten times a second), as a fraction of the block's duration;
* the listener moving: the cost of a block that ramps the listener's gains and of one that
  does not, ``Engine.move_listener`` on the calling thread, and ``Body.move`` per mono and
  stereo body (median and 99th percentile), beside the exact rule it replaces;
* the audio thread's share of a hit (its pulse transformed into mode amplitudes), and the
  cost of a block that takes the most hits a running stream allows;
* ``Body.hit`` on the calling thread (median over many calls; at one impact point, and at a
  new point each time, which adds the mode shapes there);
* ``Engine.add`` with a cold cache (an empty cache directory: plate modes and microphone
  gains computed) and warm (from memory, and from disk);
* through JACK's dummy server (:mod:`benchmarks.jack`): the time from ``hit()`` to the end of
  the callback whose block holds the tick's first sample (measured), and to that sample's
  output time (derived: one block plus the output latency plus the hand-over allowance,
  the onset ``hit()`` sets; not measured at the output); then, over ``seconds`` each, the
  underflows, late, refused and stolen voices of ``rate`` hits/s (200) on ``bodies`` bodies
  (16) from one thread alone, from one thread while a pure-Python thread spins, and from 8
  threads, the callback's cost and the master bus' peak.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time

import numpy as np

from benchmarks.common import target_verdict

#: The live engine's targets (fractions of a block, microseconds, counts).
TARGETS = dict(callback_1=0.05, callback_16=0.5, hit_us=50.0, underflows=0)


def _scene():
    import synth

    return synth.load_preset("default")


def add_times(samplerate=48000) -> dict:
    """``Engine.add`` of the default plate: cold (empty cache directory, nothing in memory),
    warm from disk (memory cleared), warm from memory; seconds."""
    from synth.live.engine import Engine
    from synth.physics import modes
    from synth.sound import radiation

    scene = _scene()
    saved = os.environ.get("SYNTH_CACHE_DIR")
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["SYNTH_CACHE_DIR"] = tmp
        try:
            engine = Engine(samplerate=samplerate)
            for name, clear in (("cold", True), ("warm_disk", True), ("warm_memory", False)):
                if clear:
                    modes.clear_memory_cache()
                    radiation.clear_memory_cache()
                t = time.perf_counter()
                engine.add(scene.plate, listener=scene.listener)
                out[name] = time.perf_counter() - t
        finally:
            if saved is None:
                os.environ.pop("SYNTH_CACHE_DIR", None)
            else:
                os.environ["SYNTH_CACHE_DIR"] = saved
    return out


def _mix_block(engine, out, blocksize: int) -> None:
    """One block mixed into ``out`` by the stream callback's compiled code, as PortAudio
    calls it (:func:`synth.live.native.mix_engine`, no checks)."""
    from synth.live import native

    native.mix_engine(engine._native.ctl, out[:blocksize])


def callback_cost(bodies=(1, 4, 16), samplerate=48000, blocksize=256, seconds=2.0, seed=0) -> list:
    """Mixing cost of one block (the callback's work, :func:`_mix_block`) with ``n``
    ringing bodies, each hit ten times a second as a live program would (each hit handed
    over in the block before its start, so the block that takes it transforms its pulse):
    mean and max over ``seconds`` of audio, as a fraction of the block."""
    from synth.live.engine import Engine

    scene = _scene()
    rng = np.random.default_rng(seed)
    rows = []
    block = blocksize / samplerate
    for n in bodies:
        engine = Engine(samplerate=samplerate, blocksize=blocksize)
        schedule = []
        for _ in range(n):
            body = engine.add(scene.plate, listener=scene.listener)
            for t in np.arange(block, seconds, 0.1) + rng.uniform(0.0, 0.1):
                v = float(rng.uniform(0.3, 2.0))
                pos = (float(rng.uniform(0.1, 1.1)), float(rng.uniform(0.05, 0.44)))
                body.prepare(pos)
                schedule.append((float(t), body, v, pos))
        schedule.sort(key=lambda hit: hit[0])
        out = np.zeros((blocksize, 1), dtype=np.float32)
        costs = []
        k = 0
        for b in range(int(seconds * samplerate / blocksize)):
            k = _hit_due(schedule, k, b, block, scene.ball)
            t = time.perf_counter()
            _mix_block(engine, out, blocksize)
            costs.append(time.perf_counter() - t)
        costs = np.array(costs) / block
        rows.append(
            dict(
                bodies=n,
                modes=engine.bodies[0].modes,
                mean=float(costs.mean()),
                memory=engine.bodies[0].memory,
                p99=float(np.percentile(costs, 99)),
                max=float(costs.max()),
                played=engine.stats.impacts_played,
            )
        )
    return rows


def move_cost(bodies=16, samplerate=48000, blocksize=256, seconds=1.0, every=25, seed=3) -> dict:
    """The listener moving: ``bodies`` stereo bodies (two ears each) ringing as in
    :func:`callback_cost`, the listener moved to a new point every ``every`` blocks
    (:meth:`Engine.move_listener`, between two blocks): the mixing cost of the blocks
    that ramp the gains and of the others (mean, fraction of the block), and
    ``move_listener`` on the calling thread (median, s; new radiation gains for every
    ear, from the plate's fixed grids, which the bodies share; a temporary cache
    directory)."""
    from synth.live.body import ears
    from synth.live.engine import Engine

    scene = _scene()
    rng = np.random.default_rng(seed)
    block = blocksize / samplerate
    saved = os.environ.get("SYNTH_CACHE_DIR")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["SYNTH_CACHE_DIR"] = tmp
        try:
            engine = Engine(samplerate=samplerate, blocksize=blocksize, channels=2)
            head = np.array([0.6, 0.25, 0.4])
            schedule = []
            for _ in range(bodies):
                body = engine.add(scene.plate, listener=ears(tuple(head), (0.0, 1.0)))
                for t in np.arange(block, seconds, 0.1) + rng.uniform(0.0, 0.1):
                    pos = (float(rng.uniform(0.1, 1.1)), float(rng.uniform(0.05, 0.44)))
                    body.prepare(pos)
                    schedule.append((float(t), body, float(rng.uniform(0.3, 2.0)), pos))
            schedule.sort(key=lambda hit: hit[0])
            out = np.zeros((blocksize, 2), dtype=np.float32)
            ramp, still, moves = [], [], []
            k = 0
            for b in range(int(seconds * samplerate / blocksize)):
                k = _hit_due(schedule, k, b, block, scene.ball)
                moved = b % every == every - 1
                if moved:
                    head = head + rng.uniform(-0.02, 0.02, 3)
                    t = time.perf_counter()
                    engine.move_listener(tuple(head), facing=(0.0, 1.0))
                    moves.append(time.perf_counter() - t)
                t = time.perf_counter()
                _mix_block(engine, out, blocksize)
                (ramp if moved else still).append((time.perf_counter() - t) / block)
        finally:
            if saved is None:
                os.environ.pop("SYNTH_CACHE_DIR", None)
            else:
                os.environ["SYNTH_CACHE_DIR"] = saved
    return dict(
        bodies=bodies,
        ramp=float(np.mean(ramp)),
        still=float(np.mean(still)),
        move_s=float(np.median(moves)),
        moves=len(moves),
    )


def listener_move_cost(samplerate=48000, moves=40, seed=5) -> dict:
    """:meth:`Body.move` on the calling thread, per body of the default plate: a mono and
    a stereo body (:func:`ears`) each moved ``moves`` times, every time to a point within
    2 cm of the last (a game's head from frame to frame), at least
    :data:`~synth.sound.radiation.fixed.NEAR_FIELD_HEIGHT` above the plate (median and
    99th percentile, s; the first move, which builds the plate's fixed radiation grids,
    apart); the exact rule at a new point for comparison (:func:`modal_model`, which a
    move took before the grids: one microphone, uncached); the grids' memory (bytes)."""
    from synth.live.body import ears
    from synth.live.engine import Engine
    from synth.physics.scene import Microphone
    from synth.sound.radiation import clear_memory_cache
    from synth.sound.render import modal_model

    scene = _scene()
    rng = np.random.default_rng(seed)
    saved = os.environ.get("SYNTH_CACHE_DIR")
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["SYNTH_CACHE_DIR"] = tmp
        try:
            engine = Engine(samplerate=samplerate, channels=2)
            mono = engine.add(scene.plate)
            head = np.array([0.6, 0.25, 0.4])
            stereo = engine.add(scene.plate, listener=ears(tuple(head), (0.0, 1.0)))
            for name, body in (("mono", mono), ("stereo", stereo)):
                times = []
                for _ in range(moves + 1):
                    head = head + rng.uniform(-0.02, 0.02, 3) / np.sqrt(3.0)
                    head[2] = max(head[2], 0.2)
                    listener = Microphone(tuple(head)) if name == "mono" else ears(tuple(head))
                    t = time.perf_counter()
                    body.move(listener)
                    times.append(time.perf_counter() - t)
                out[name] = dict(
                    first=times[0],
                    median=float(np.median(times[1:])),
                    p99=float(np.percentile(times[1:], 99)),
                )
            exact = []
            for _ in range(3):
                head = head + rng.uniform(-0.02, 0.02, 3)
                clear_memory_cache()
                t = time.perf_counter()
                modal_model(scene.plate, Microphone(tuple(head)), samplerate=samplerate)
                exact.append(time.perf_counter() - t)
            out["exact_s"] = float(np.median(exact))
            out["grid_bytes"] = engine.listener_grid_memory
            out["modes"] = mono.modes
            out["moves"] = moves
        finally:
            if saved is None:
                os.environ.pop("SYNTH_CACHE_DIR", None)
            else:
                os.environ["SYNTH_CACHE_DIR"] = saved
    return out


def transform_cost(samplerate=48000, blocksize=256, repeat=60) -> dict:
    """The audio thread's share of a hit: the cost of a block that takes ``k`` new hits on
    one default body (their pulses transformed into mode amplitudes), for ``k`` = 0, 1 and
    the engine's ``max_hits_per_block``; medians, as a fraction of the block, and the
    cost per hit in microseconds."""
    from synth.live.engine import Engine

    scene = _scene()
    engine = Engine(samplerate=samplerate, blocksize=blocksize)
    body = engine.add(scene.plate, listener=scene.listener)
    out = np.zeros((blocksize, 1), dtype=np.float32)
    block = blocksize / samplerate
    full = engine.max_hits_per_block
    medians = {}
    for k in (0, 1, full):
        costs = []
        for _ in range(repeat):
            for _ in range(k):
                body.hit(scene.ball, 1.0, at=engine.time + 2 * block)
            t = time.perf_counter()
            _mix_block(engine, out, blocksize)
            costs.append(time.perf_counter() - t)
            body.stop_all()
            _mix_block(engine, out, blocksize)
        medians[k] = float(np.median(costs))
    return dict(
        hits_per_block=full,
        modes=body.modes,
        empty=medians[0] / block,
        one=medians[1] / block,
        full=medians[full] / block,
        per_hit_us=(medians[full] - medians[0]) / full * 1e6,
    )


def hit_cost(samplerate=48000, repeat=400, seed=1) -> dict:
    """``Body.hit`` on the calling thread, microseconds: median and 90th percentile at one
    point, at a new point each call, and at one point with the fewest pulse points the
    grid rule allows (``pulse_points=5``). The pending impacts are dropped (untimed) as
    soon as a block's worth wait, as the audio thread would take them."""
    from synth.live.engine import Engine

    scene = _scene()
    rng = np.random.default_rng(seed)
    engines = {pp: Engine(samplerate=samplerate, pulse_points=pp) for pp in (65, 5)}
    bodies = {pp: e.add(scene.plate, listener=scene.listener) for pp, e in engines.items()}
    out = {}
    for name, new_point, pp in (
        ("same_point", False, 65),
        ("new_point", True, 65),
        ("same_point_coarse_pulse", False, 5),
    ):
        body = bodies[pp]
        times = []
        for _ in range(repeat):
            pos = (
                (float(rng.uniform(0.1, 1.1)), float(rng.uniform(0.05, 0.44)))
                if new_point
                else scene.position
            )
            v = float(rng.uniform(0.3, 2.0))
            t = time.perf_counter()
            body.hit(scene.ball, v, position=pos)
            times.append(time.perf_counter() - t)
            if body.pending >= engines[pp].max_hits_per_block:
                body.stop_all()
        body.stop_all()
        times = np.array(times) * 1e6
        out[name] = dict(
            median=float(np.median(times)),
            p90=float(np.percentile(times, 90)),
            p99=float(np.percentile(times, 99)),
        )
    return out


def _wait_mixed(engine, frame, timeout=1.0):
    """Wait until a callback has mixed ``frame``; the monotonic time (s) at that callback's
    end, or None."""
    from synth.live import state as st

    times = engine._native.times
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        end, mixed = times[st.END_TIME], times[st.END_FRAME]
        if mixed > frame:
            return float(end)
        time.sleep(0.0002)
    return None


def _busy_python(stop):
    """A game's own loop: pure Python that never sleeps."""
    x = 0
    while not stop.is_set():
        for i in range(1000):
            x += i * i


def _hitter(handles, ball, rate, seed):
    """A thread's loop of hits at ``rate`` hits/s (exponential gaps) on random bodies."""

    def run(stop):
        rng = np.random.default_rng(seed)
        while not stop.is_set():
            time.sleep(float(rng.exponential(1.0 / rate)))
            b = handles[int(rng.integers(len(handles)))]
            b.hit(
                ball,
                float(rng.uniform(0.2, 2.0)),
                position=(float(rng.uniform(0.1, 1.1)), float(rng.uniform(0.05, 0.44))),
            )

    return run


def _phase(engine, server, targets, seconds) -> dict:
    """Run ``targets`` (each ``f(stop)``) on threads for ``seconds``; the engine's counters
    over that time, and the JACK ``server``'s own cycles that ended late meanwhile."""
    late0 = server.late_cycles()
    s0 = engine.stats
    stop = threading.Event()
    threads = [threading.Thread(target=t, args=(stop,)) for t in targets]
    for t in threads:
        t.start()
    time.sleep(seconds)
    stop.set()
    for t in threads:
        t.join()
    time.sleep(0.1)
    s1 = engine.stats
    return dict(
        callbacks=s1.callbacks - s0.callbacks,
        underflows=s1.output_underflows - s0.output_underflows,
        played=s1.impacts_played - s0.impacts_played,
        late=s1.impacts_late - s0.impacts_late,
        refused=s1.impacts_refused - s0.impacts_refused,
        stolen=s1.voices_stolen - s0.voices_stolen,
        transforms_max=s1.transforms_max,
        server_late=server.late_cycles() - late0,
    )


def jack_run(seconds=30.0, samplerate=48000, blocksize=256, rate=200.0, bodies=16, seed=2) -> dict:
    """Through the JACK dummy server: end-to-end latency of single hits, then ``seconds``
    of ``rate`` hits/s on ``bodies`` bodies from one thread alone (the machine's baseline),
    the same while a pure-Python thread spins, then the same rate spread over 8 hitting
    threads."""
    from benchmarks.jack import JackDummyServer
    from synth.live import state as st
    from synth.live.engine import Engine

    scene = _scene()
    rng = np.random.default_rng(seed)
    with JackDummyServer(samplerate=samplerate, period=blocksize) as server:
        engine = Engine(samplerate=samplerate, blocksize=blocksize, device=server.device)
        handles = [
            engine.add(scene.plate, listener=scene.listener, gain=0.1) for _ in range(bodies)
        ]
        engine.start()
        time.sleep(0.2)
        to_callback = []
        for _ in range(40):
            time.sleep(float(rng.uniform(0.005, 0.03)))
            t = st.monotonic()
            onset = handles[0].hit(scene.ball, 1.0).onset
            end = _wait_mixed(engine, int(np.ceil(onset * samplerate)))
            if end is not None:
                to_callback.append(end - t)
        latency, nominal = engine.latency, float(engine._native.times[st.NOMINAL_LATENCY])
        engine.reset_meter()
        alone = _phase(engine, server, [_hitter(handles, scene.ball, rate, seed)], seconds)
        busy = _phase(
            engine, server, [_busy_python, _hitter(handles, scene.ball, rate, seed)], seconds
        )
        hitters = [_hitter(handles, scene.ball, rate / 8, seed + 1 + k) for k in range(8)]
        threads8 = _phase(engine, server, hitters, seconds)
        stats = engine.stats
        engine.stop()
        realtime = server.realtime
    block = blocksize / samplerate
    return dict(
        realtime_server=realtime,
        block_s=block,
        latency_s=latency,
        nominal_latency_s=nominal,
        handover_s=engine.handover,
        hit_to_callback_ms=dict(
            median=float(np.median(to_callback)) * 1e3, max=float(np.max(to_callback)) * 1e3
        )
        if to_callback
        else None,
        hit_to_output_ms=(block + latency + engine.handover) * 1e3,
        seconds=seconds,
        rate=rate,
        bodies=bodies,
        alone=alone,
        busy=busy,
        threads8=threads8,
        callback_mean=stats.callback_mean,
        callback_max=stats.callback_max,
        callback_gap_max=stats.callback_gap_max,
        transforms_max=stats.transforms_max,
        peak=stats.peak,
        output_peak=stats.output_peak,
        clipped=stats.clipped,
    )


def rolling_cost(samplerate=48000, blocksize=256, seconds=1.0, speeds=(0.1, 0.3, 1.0)) -> dict:
    """A rolling voice (:meth:`Body.roll`) on the default plate, a steel ball of 10 mm radius
    over a rough surface (the caller's roughness: RMS 1 um, correlation length 0.2 mm,
    Hurst 0.8), updated every 16 ms (three blocks) at each of ``speeds`` (m/s), on a body
    heard by the scene's microphone; and at the middle speed on a body heard through two
    ears (:func:`synth.live.ears`, two channels) and by an accelerometer. Each: the block's
    mixing cost with the voice alone on the body (mean, 99th percentile, max, as a fraction
    of the block), the integrator's steps per sample, :meth:`RollingVoice.update` on the
    calling thread (median and 99th percentile, s); and the memory of one rolling slot."""
    from synth.live.engine import ears
    from synth.physics import surface
    from synth.physics.scene import Accelerometer, Ball

    scene = _scene()
    ball = Ball("steel", 0.01)
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=2e-4, hurst=0.8)
    length = max(speeds) * seconds + 0.02
    profile = surface.rough_profile(spec, length=length, spacing=5e-6, seed=1)
    envelope = surface.contact_envelope(profile, ball.radius)
    plate = scene.plate
    mic = scene.listener
    rows = []
    for v in speeds:
        row, body = _rolling_row(plate, mic, ball, envelope, v, samplerate, blocksize, seconds)
        rows.append(dict(row, listener="microphone"))
    v = speeds[len(speeds) // 2]
    two_ears = ears(mic.position)
    sensor = Accelerometer((0.7 * plate.length, 0.3 * plate.width))
    for name, listener in (("two ears", two_ears), ("accelerometer", sensor)):
        row, _ = _rolling_row(plate, listener, ball, envelope, v, samplerate, blocksize, seconds)
        rows.append(dict(row, listener=name))
    slot = sum(
        int(a[0].nbytes)
        for k, a in body._rolls.items()
        if k.startswith("roll_") and isinstance(a, np.ndarray)
    )
    return dict(
        rows=rows, modes=body.modes, slot_bytes=slot, rows_per_table=body._rolls["roll_rows"]
    )


def _rolling_row(plate, listener, ball, envelope, v, samplerate, blocksize, seconds):
    """One case of :func:`rolling_cost` (a tuple of listeners: one channel each): its
    figures and the body."""
    from synth.live.engine import Engine

    channels = len(listener) if isinstance(listener, tuple) else 1
    block = blocksize / samplerate
    engine = Engine(samplerate=samplerate, blocksize=blocksize, channels=channels, max_rolls=1)
    body = engine.add(plate, listener=listener)
    start = np.array([0.05, 0.5 * plate.width])
    voice = body.roll(ball, start, (v, 0.0), envelope=envelope, start=0.01)
    out = np.zeros((blocksize, channels), dtype=np.float32)
    costs, updates = [], []
    for b in range(int(seconds * samplerate / blocksize)):
        if b and b % 3 == 0:
            t = time.perf_counter()
            voice.update(start + (voice.path_position - 0.01, 0.0), (v, 0.0))
            updates.append(time.perf_counter() - t)
        t = time.perf_counter()
        _mix_block(engine, out, blocksize)
        costs.append(time.perf_counter() - t)
    costs = np.array(costs) / block
    row = dict(
        speed=v,
        mean=float(costs.mean()),
        p99=float(np.percentile(costs, 99)),
        max=float(costs.max()),
        steps=voice.steps / max(voice.frames, 1),
        overruns=voice.overruns,
        update_median=float(np.median(updates)),
        update_p99=float(np.percentile(updates, 99)),
    )
    return row, body


def run_live(seconds=30.0) -> dict:
    """Every figure of the live benchmark (``seconds``: the JACK run's length)."""
    from benchmarks.jack import jackd_available

    result = dict(
        add_s=add_times(),
        callback=callback_cost(),
        move=move_cost(),
        listener_move=listener_move_cost(),
        transform=transform_cost(),
        hit_us=hit_cost(),
        rolling=rolling_cost(),
    )
    if jackd_available():
        result["jack"] = jack_run(seconds=seconds)
    else:
        result["jack"] = None
    return result


def format_live(result) -> str:
    """The live benchmark as Markdown, with the targets and whether they are met."""
    from synth.live.voice import MAX_VOICES
    from synth.sound.radiation.fixed import NEAR_FIELD_HEIGHT

    rows = result["callback"]
    by_n = {r["bodies"]: r for r in rows}
    lines = [
        "Callback (mixing) cost per 256-frame block at 48 kHz, default plate "
        f"({rows[0]['modes']} modes), every body ringing (hit 10 times a second; a block "
        "that takes a hit also transforms its pulse):",
        "| bodies | mean (% of block) | 99th percentile | max |",
        "|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['bodies']} | {100 * r['mean']:.2f} | {100 * r['p99']:.2f} | "
            f"{100 * r['max']:.2f} |"
        )
    h = result["hit_us"]
    a = result["add_s"]
    lines += [
        "",
        f"- 1 body: {100 * by_n[1]['mean']:.2f} % of the block (target < "
        f"{100 * TARGETS['callback_1']:.0f} %): "
        f"{target_verdict(by_n[1]['mean'] < TARGETS['callback_1'])}",
    ]
    if 16 in by_n:
        lines.append(
            f"- 16 bodies: {100 * by_n[16]['mean']:.2f} % (target < "
            f"{100 * TARGETS['callback_16']:.0f} %): "
            f"{target_verdict(by_n[16]['mean'] < TARGETS['callback_16'])}"
        )
    widest = rows[-1]
    per_body = widest["mean"] / widest["bodies"]
    lines.append(
        f"- per body ({widest['bodies']} ringing): {100 * per_body:.3f} % of a block, i.e. "
        f"{0.8 / per_body:.0f} bodies per core at 80 % of a block (mean cost; a block taking "
        f"hits costs more, see below); memory per body "
        f"{widest.get('memory', 0) / 2**20:.2f} MiB (Body.memory: modal state, pending ring "
        f"of {_max_pending()} impacts, workspace)"
    )
    m = result.get("move")
    if m is not None:
        lines.append(
            f"- the listener moving ({m['bodies']} stereo bodies ringing, "
            f"Engine.move_listener every few blocks, {m['moves']} moves): a block that ramps "
            f"every mode's gain at every ear costs {100 * m['ramp']:.2f} % of the block, one "
            f"that does not {100 * m['still']:.2f} %; move_listener on the calling thread "
            f"(new radiation gains for each ear; the bodies share one plate, whose fixed "
            f"grids compute the two ears' gains once): median {m['move_s'] * 1e3:.1f} ms"
        )
    lm = result.get("listener_move")
    if lm is not None:
        lines.append(
            f"- Body.move on the calling thread ({lm['modes']} modes, {lm['moves']} moves of "
            f"2 cm, microphones from the plate's fixed radiation grids): mono body median "
            f"{lm['mono']['median'] * 1e3:.1f} ms, 99th percentile "
            f"{lm['mono']['p99'] * 1e3:.1f} ms; stereo body median "
            f"{lm['stereo']['median'] * 1e3:.1f} ms, 99th percentile "
            f"{lm['stereo']['p99'] * 1e3:.1f} ms; the plate's first move (grids built) "
            f"{lm['mono']['first']:.2f} s, grids {lm['grid_bytes'] / 2**20:.0f} MiB a plate; "
            f"the exact rule at a new point (one microphone; a move lower than "
            f"{100 * NEAR_FIELD_HEIGHT:.0f} cm above the plate takes it) "
            f"{lm['exact_s'] * 1e3:.0f} ms"
        )
    x = result["transform"]
    lines += [
        f"- the audio thread's share of a hit (its pulse turned into {x['modes']} mode "
        f"amplitudes at the start of the block that takes it): {x['per_hit_us']:.0f} us; a "
        f"block taking {x['hits_per_block']} hits (max_hits_per_block, the most a running "
        f"stream takes between two blocks) costs {100 * x['full']:.1f} % of the block, one "
        f"hit {100 * x['one']:.2f} %, none {100 * x['empty']:.2f} %",
        f"- hit() on the calling thread (the contact solved, its pulse sampled and handed "
        f"over), same point: median {h['same_point']['median']:.0f} us, "
        f"90th percentile {h['same_point']['p90']:.0f} us, 99th "
        f"{h['same_point']['p99']:.0f} us (target < {TARGETS['hit_us']:.0f} us "
        f"median): {target_verdict(h['same_point']['median'] < TARGETS['hit_us'])}; "
        f"at a new point each "
        f"time: median {h['new_point']['median']:.0f} us; with pulse_points=5 (same point): "
        f"median {h['same_point_coarse_pulse']['median']:.0f} us",
        f"- Engine.add(default plate): cold cache {a['cold']:.2f} s, warm from disk "
        f"{a['warm_disk'] * 1e3:.0f} ms, warm from memory {a['warm_memory'] * 1e3:.0f} ms",
    ]
    lines += _rolling_lines(result.get("rolling"))
    j = result["jack"]
    if j is None:
        lines.append("- JACK dummy server: jackd not installed, not measured")
        return "\n".join(lines)
    lines += [
        f"- JACK dummy server ({'realtime' if j['realtime_server'] else 'not realtime'}), "
        f"{j['block_s'] * 1e3:.2f} ms blocks, output latency {j['latency_s'] * 1e3:.2f} ms "
        f"(PortAudio's nominal {j['nominal_latency_s'] * 1e3:.2f} ms), hand-over allowance "
        f"{j['handover_s'] * 1e3:.1f} ms:"
    ]
    if j["hit_to_callback_ms"]:
        target = (j["block_s"] + j["latency_s"]) * 1e3
        lines.append(
            f"  - hit() to the end of the callback holding the tick's first sample: median "
            f"{j['hit_to_callback_ms']['median']:.2f} ms, max "
            f"{j['hit_to_callback_ms']['max']:.2f} ms (target <= one block + latency = "
            f"{target:.2f} ms): {target_verdict(j['hit_to_callback_ms']['max'] <= target)}"
        )
    lines.append(
        f"  - hit() to the tick's first sample at the output: {j['hit_to_output_ms']:.2f} ms, "
        f"derived, not measured (one block + output latency + hand-over allowance: the onset "
        f"hit() sets, the same for every hit)"
    )
    for key, what in (
        ("alone", "one thread hitting and nothing else (the machine's baseline)"),
        ("busy", "one thread hitting while a pure-Python thread spins"),
        ("threads8", "8 threads hitting"),
    ):
        p = j.get(key)
        if p is None:
            continue
        lines.append(
            f"  - {j['seconds']:.0f} s of {j['rate']:.0f} hits/s on {j['bodies']} bodies, "
            f"{what}: {p['callbacks']} callbacks, {p['underflows']} output underflows (target "
            f"{TARGETS['underflows']}): {target_verdict(p['underflows'] <= TARGETS['underflows'])}"
            f"; {p['played']} impacts played, {p['late']} late, {p['refused']} refused, "
            f"{p.get('stolen', 0)} voices stolen (max_voices={MAX_VOICES} a body)"
            + (
                f"; the server's own cycle ended late {p['server_late']} times (its timer "
                f"thread was run late: every client's output is flagged then, whatever its "
                f"work)"
                if "server_late" in p
                else ""
            )
        )
    lines.append(
        f"  - callback from its entry (all phases): mean {100 * j['callback_mean']:.2f} %, max "
        f"{100 * j['callback_max']:.1f} % of the block, at most "
        f"{j.get('transforms_max', 0)} hits transformed in one callback (max_hits_per_block "
        f"over all bodies); longest time between two callbacks "
        f"{j.get('callback_gap_max', 0.0):.2f} blocks (the system's scheduling); master bus "
        f"peak "
        f"{_dbfs(j['peak'])} before the soft clipper, {_dbfs(j['output_peak'])} at the device, "
        f"{j['clipped']} samples reached full scale"
    )
    return "\n".join(lines)


def _rolling_lines(r) -> list:
    """The rolling voice's figures (:func:`rolling_cost`) as Markdown lines."""
    if r is None:
        return []
    from synth.live.rolling import HORIZON

    costs = "; ".join(
        f"{row['speed']:g} m/s, {row.get('listener', 'microphone')}: mean "
        f"{100 * row['mean']:.2f} %, 99th percentile {100 * row['p99']:.2f} %, max "
        f"{100 * row['max']:.2f} % of the block, {row['steps']:.2f} steps a sample"
        for row in r["rows"]
    )
    updates = ", ".join(
        f"{row['update_median'] * 1e6:.0f} us ({row['update_p99'] * 1e6:.0f} us) at "
        f"{row['speed']:g} m/s, {row.get('listener', 'microphone')}"
        for row in r["rows"]
    )
    return [
        f"- a rolling voice (Body.roll: a steel ball of 10 mm radius on the default plate, "
        f"{r['modes']} modes, its contact integrated and its force driving the modes in the "
        f"callback; through two ears, the contact once and each ear's modes), updated every "
        f"16 ms, alone on its body: {costs}{_ears_ratio(r['rows'])}",
        f"- RollingVoice.update on the calling thread (the mode-shape table {HORIZON * 1e3:.0f}"
        f" ms ahead), median (99th percentile): {updates}; a rolling slot's memory "
        f"{r['slot_bytes'] / 2**20:.2f} MiB (tables of {r['rows_per_table']} rows, three "
        f"buffers); an update sounds from the next block's start",
    ]


def _ears_ratio(rows) -> str:
    """The two ears' mean block cost over the microphone's at the same speed (this run), as
    a clause; empty without both rows."""
    by = {(row["speed"], row.get("listener", "microphone")): row["mean"] for row in rows}
    pairs = [(v, m) for (v, who), m in by.items() if who == "two ears" and (v, "microphone") in by]
    if not pairs:
        return ""
    v, ears = pairs[0]
    return f"; two ears cost {ears / by[(v, 'microphone')]:.2f} times the microphone's block"


def _max_pending() -> int:
    import inspect

    from synth.live.engine import Engine

    return inspect.signature(Engine).parameters["max_pending"].default


def _dbfs(x: float) -> str:
    return f"{20 * np.log10(x):.1f} dBFS" if x > 0 else "silence"


def _hit_due(schedule: list, k: int, b: int, block: float, ball) -> int:
    """Make the hits of ``schedule`` (``(time s, body, speed m/s, position m)``, in time
    order) from index ``k`` that fall before the end of block ``b + 1`` (blocks of ``block``
    s), each no earlier than block ``b + 1`` starts, as a game does a block ahead; returns
    the index of the first hit left."""
    while k < len(schedule) and schedule[k][0] < (b + 2) * block:
        t, body, v, pos = schedule[k]
        body.hit(ball, v, at=max(t, (b + 1) * block), position=pos)
        k += 1
    return k
