"""A ball released with a horizontal velocity: its bounces along a path, the grip, the
rolling resistance, the end at rest or at the edge, the energy balance, and the render that
mixes bounces and rolling (synth.physics.path, synth.sound.rolling.render_path_audio;
docs/rolling.md, "The ball's path")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from synth import ParameterError
from synth.physics import rolling_kernels as _k
from synth.physics.path import c_rr_deceleration, simulate_path
from synth.physics.scene import Accelerometer, Ball, Contact, Plate, Rolling, Scene
from synth.sound.modal_bank import Bank, synthesize
from synth.sound.render import modal_model, render
from synth.sound.rolling import ModeState, drive_modes, path_excitation

SAMPLERATE = 48000
THESIS = Contact(model="thesis")  # Hertz on the plate's impedance: the path's plate


def scene(*, velocity=(0.3, 0.0), position=(0.3, 0.3), resistance=0.05, rms=0.0, **kw):
    """A 10 mm steel ball dropped 2 cm on 6 mm glass (1.0 m x 0.6 m)."""
    rough = dict(rms_height=rms, correlation_length=1e-4, hurst=0.8) if rms else {}
    return Scene(
        Ball("steel", 0.005),
        Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported"),
        drop_height=kw.pop("drop_height", 0.02),
        position=position,
        velocity=velocity,
        rolling=Rolling(resistance=resistance, spacing=5e-6, seed=3, **rough),
        contact=THESIS,
        listener=kw.pop("listener", None),
    )


@pytest.fixture(scope="module")
def stopping():
    """On a smooth plate with a large resistance: the ball bounces, rolls and stops."""
    return simulate_path(scene(), samplerate=SAMPLERATE, max_duration=5.0)


def test_grip_leaves_five_sevenths_and_the_impacts_lie_on_the_line(stopping):
    """A solid sphere without spin that grips keeps 5/7 of its horizontal speed (angular
    momentum about the contact point; Garwin 1969); the ball then keeps that speed between
    impacts, so the impacts lie along the release's direction at the distances the speed and
    the times give (exact arithmetic: 1e-12 relative)."""
    path = stopping
    assert path.rolling_speed == pytest.approx(0.3 * 5.0 / 7.0, rel=1e-15)
    times = np.array([i.time for i in path.impacts])
    x = path.impact_points[:, 0] - 0.3
    assert x[0] == pytest.approx(0.3 * times[0], rel=1e-12)
    first = path.impacts[0].result.separation_time
    # during the first contact the ball moves at the gripped speed
    expected = x[0] + path.rolling_speed * (times[1:] - times[0])
    assert np.allclose(x[1:], expected, rtol=1e-12, atol=0.0)
    assert first > 0.0
    assert np.all(path.impact_points[:, 1] == 0.3)
    assert len(path.impacts) > 3
    assert path.impacts.stop_reason in ("flight-shorter-than-contact", "settled")


def test_rolling_resistance_stops_the_ball_at_the_closed_form_distance(stopping):
    """On a smooth plate the roughness does no work, so Coulomb's rolling resistance alone
    decelerates the rolling sphere: (7/10) m v^2 = C_rr m g d, the distance d = (7/10) v^2 /
    (C_rr g) and the time v / ((5/7) C_rr g). The rolling's speed is held per sample, so
    both agree to a sample's travel (here 1e-4 relative is far above it: 4.5e-6 m of 0.065
    m)."""
    path = stopping
    r = path.rolling
    v0 = path.rolling_speed
    g = 9.81
    assert path.end == "stopped"
    assert r.energy.roughness_work == 0.0
    d = float(np.sum(r.speed)) / SAMPLERATE
    assert d == pytest.approx(0.7 * v0 * v0 / (0.05 * g), rel=1e-4)
    assert r.force.size / SAMPLERATE == pytest.approx(v0 / c_rr_deceleration(0.05, g), rel=1e-4)
    # the weight stays on the plate: the force after the end
    assert r.final_force == pytest.approx(0.005**3 * 4 / 3 * math.pi * 7800 * g, rel=1e-2)


def test_ball_rolls_off_the_edge_at_constant_speed_without_resistance():
    """Without resistance on a smooth plate the ball rolls at its gripped speed until its
    touching point reaches the edge at x = 1 m (within the profile's spacing and a sample's
    travel): the scene ends "left-plate", the force after it is 0."""
    path = simulate_path(
        scene(position=(0.9, 0.3), resistance=0.0), samplerate=SAMPLERATE, max_duration=5.0
    )
    assert path.end == "left-plate"
    assert path.end_point[0] == pytest.approx(1.0, abs=2e-5)
    r = path.rolling
    assert r.final_force == 0.0
    assert np.all(r.speed == path.rolling_speed)


def test_ball_that_flies_off_the_plate_ends_with_its_last_impact():
    """Thrown fast near the edge, the ball's second landing is off the plate: one impact,
    no rolling, the end at the first contact's separation."""
    path = simulate_path(
        scene(position=(0.7, 0.3), velocity=(2.0, 0.0), drop_height=0.1),
        samplerate=SAMPLERATE,
        max_duration=5.0,
    )
    assert path.end == "left-plate"
    assert path.rolling is None
    assert len(path.impacts) == 1
    first = path.impacts[0]
    assert path.end_time == pytest.approx(first.time + first.result.separation_time, rel=1e-15)


@pytest.mark.parametrize("resistance", [0.0, 0.02])
def test_energy_balance_of_the_rolling(resistance):
    """On a rough plate the rolling's energy (the rolling sphere's (7/10) m v^2 and the
    vertical mechanical energy) falls by what the plate's impedance, the contact and the
    rolling resistance take; the ledger's horizontal part is exact, its vertical part is the
    contact solver's (local tolerance 1e-6 per step): 1e-4 of the initial energy bounds
    both. Without resistance the plate takes all of it (the elastic Hertz law loses
    nothing)."""
    path = simulate_path(
        scene(position=(0.7, 0.3), resistance=resistance, rms=2e-7),
        samplerate=SAMPLERATE,
        max_duration=2.0,
    )
    e = path.rolling.energy
    assert path.rolling.flights > 0  # the roughness throws the ball: micro-bounces
    assert e.roughness_work > 0.0
    assert e.contact_loss == 0.0
    assert e.residual < 1e-4
    if resistance == 0.0:
        assert e.resistance_work == 0.0
        assert e.initial - e.final == pytest.approx(e.plate_energy, rel=1e-3)


def test_mode_state_continues_a_drive_exactly():
    """drive_modes from a ModeState: two calls give the signal of one call (the recursion
    is the same, sample by sample: 1e-12 of the signal's peak)."""
    plate = Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported")
    model = modal_model(plate, Accelerometer((0.3, 0.2)), samplerate=SAMPLERATE)
    table = path_excitation(model, origin=(0.1, 0.3), direction=(1.0, 0.0), start=0.0, stop=0.1)
    rng = np.random.default_rng(1)
    force = 0.04 + 0.01 * rng.standard_normal(2000)
    coordinate = np.linspace(0.0, 0.1, 2000)
    whole = drive_modes(force, coordinate, table, model.poles, model.output, SAMPLERATE)
    state = ModeState.at_rest(model.poles.size)
    parts = [
        drive_modes(force[a:b], coordinate[a:b], table, model.poles, model.output, SAMPLERATE,
                    state=state)
        for a, b in ((0, 777), (777, 2000))
    ]  # fmt: skip
    assert np.max(np.abs(np.concatenate(parts) - whole)) <= 1e-12 * np.max(np.abs(whole))


def test_per_impact_excitation_with_equal_rows_is_the_shared_one():
    """synthesize with one excitation row per impact, all equal, gives the bits of the
    shared excitation (the same arithmetic)."""
    from synth.physics.contact import solve_impact

    ball, plate = Ball("steel", 0.005), Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported")
    model = modal_model(plate, Accelerometer((0.3, 0.2)), samplerate=SAMPLERATE)
    hits = [solve_impact(ball, plate, v) for v in (0.6, 0.4)]
    b = model.excitation((0.4, 0.3))
    rows = np.array([b, b])
    common = dict(floor=1e-4, max_samples=4800)
    shared, _ = synthesize(hits, [0.001, 0.02], Bank(model.poles, b, model.output, SAMPLERATE),
                           direct=model.direct(b), **common)  # fmt: skip
    each, _ = synthesize(hits, [0.001, 0.02], Bank(model.poles, rows, model.output, SAMPLERATE),
                         direct=np.array([model.direct(b)] * 2), **common)  # fmt: skip
    assert np.array_equal(shared, each)


def test_a_blocks_travel_stays_within_its_bound_in_floats():
    """The bound that lets a block far from the edge skip its positions' cumulative sum
    (rolling_kernels.reach_bound) holds the centre's last position as floats give it (invariant: a
    float sum of n terms each at most v_max is at most n v_max (1 + n eps))."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(1, 4800))
        v, decel, x = rng.uniform(1e-3, 3.0), rng.uniform(0.0, 5.0), rng.uniform(0.0, 2.0)
        planned = v - decel * (np.arange(n) + 0.5) / SAMPLERATE
        planned = planned[planned > 0.0]
        if planned.size:
            reached = x + np.cumsum(planned) / SAMPLERATE
            assert reached[-1] <= x + _k.reach_bound(planned, planned.size, float(SAMPLERATE), x)


def test_touching_points_are_numpys_interpolation_to_the_bit():
    """The compiled touching points (rolling_kernels.touching_points) are the centre plus
    numpy's interp of the contact offsets on the nodes i * spacing, to the bit (the same
    interval and formula), at nodes, between them and held beyond the ends."""
    rng = np.random.default_rng(3)
    for spacing in (2e-6, 5e-6, 1e-3):
        offsets = spacing * rng.standard_normal(500)
        centres = np.concatenate((
            rng.uniform(-spacing, 501 * spacing, 20000), np.arange(500) * spacing,
        ))  # fmt: skip
        out = np.empty_like(centres)
        _k.touching_points(centres, offsets, spacing, out)
        expected = centres + np.interp(centres, np.arange(500) * spacing, offsets)
        assert np.array_equal(out, expected)


def test_render_mixes_bounces_and_rolling_in_one_signal():
    """A moving scene renders its bounces and its rolling in one signal: the rolling's part
    is there (the signal after the last bounce is not silent) and the settings say how the
    path ended."""
    s = scene(position=(0.8, 0.3), resistance=0.0, rms=2e-7, listener=Accelerometer((0.9, 0.2)))
    r = render(s, samplerate=SAMPLERATE, normalize="none", max_tail=0.2)
    st = r.settings
    assert st["path_end"] == "left-plate"
    assert st["rolling_seconds"] > 0.1
    assert st["n_impacts"] == len(r.impacts) > 3
    j0 = int(round((st["rolling_start"] + st["delay"] - st["audio_start"]) * SAMPLERATE))
    rolling = r.audio[j0 + 4800 : j0 + int(st["rolling_seconds"] * SAMPLERATE)]
    assert np.sqrt(np.mean(rolling.astype(float) ** 2)) > 0.0


@pytest.mark.parametrize(
    "change, field",
    [
        (dict(rolling=None), "drop.velocity"),
        (dict(contact=Contact(plate="modal")), "contact.plate"),
        (dict(velocity=(200.0, 0.0)), "drop.velocity"),
    ],
)
def test_bad_moving_scene_is_refused_naming_the_field(change, field):
    base = dict(
        drop_height=0.02, position=(0.3, 0.3), velocity=(0.3, 0.0),
        rolling=Rolling(resistance=0.01, spacing=5e-6), contact=THESIS,
    )  # fmt: skip
    with pytest.raises(ParameterError, match=field.replace(".", r"\.")):
        Scene(Ball("steel", 0.005), Plate("glass", 0.006, 1.0, 0.6), **{**base, **change})


@pytest.mark.parametrize(
    "kw, field",
    [
        (dict(resistance=-0.1, spacing=5e-6), "rolling.resistance"),
        (dict(resistance=0.01, spacing=0.0), "rolling.spacing"),
        (dict(resistance=0.01, spacing=5e-6, rms_height=1e-6), "rolling.correlation_length"),
        (dict(resistance=0.01, spacing=5e-6, seed=-1), "rolling.seed"),
    ],
)
def test_bad_rolling_is_refused_naming_the_field(kw, field):
    with pytest.raises(ParameterError, match=field.replace(".", r"\.")):
        Rolling(**kw)


def test_cli_renders_a_rolling_preset_and_reports_its_path(tmp_path, capsys):
    """`synth render` of a rolling preset writes its WAV and report on a real disk, the
    report saying how the path ended; `synth info` prints the path's impacts and end (the
    same impacts as the render)."""
    import json

    import soundfile

    from synth.cli import main

    wav, report = tmp_path / "roll.wav", tmp_path / "roll.json"
    name = "thesis-steel10-mdf18-rolling"
    assert main(["render", name, "-o", str(wav), "--report", str(report)]) == 0
    audio, fs = soundfile.read(wav)
    settings = json.loads(report.read_text())["settings"]
    assert fs == SAMPLERATE and audio.size / fs == pytest.approx(
        json.loads(report.read_text())["duration"], abs=1 / fs
    )
    assert settings["path_end"] == "left-plate" and settings["rolling_seconds"] > 0.0
    capsys.readouterr()
    assert main(["info", name, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["path_end"] == settings["path_end"]
    assert len(info["impacts"]) == settings["n_impacts"]


def test_time_running_out_while_rolling_leaves_the_weight_on_the_plate(stopping):
    """A path cut by max_duration while the ball rolls ends "max-duration" with the ball
    still on the plate: the force after the end is its weight (no step that would make a
    thump), within the samples up to the limit."""
    limit = stopping.rolling.start + 0.05
    path = simulate_path(scene(), samplerate=SAMPLERATE, max_duration=limit)
    assert path.end == "max-duration"
    r = path.rolling
    assert r.final_force == pytest.approx(stopping.rolling.final_force, rel=1e-15)
    assert r.start + r.duration <= limit + 1e-12
    assert r.duration == pytest.approx(0.05, abs=1.0 / SAMPLERATE)


def test_simulate_scene_of_a_moving_scene_gives_its_path_bounces(stopping):
    """simulate_scene follows a moving scene's path: the same impacts as simulate_path (the
    same solver at the same points: bit for bit), not a straight drop's; an option of the
    straight drop's scheduler is refused naming it."""
    from synth.physics.bounces import simulate_scene

    s = scene()
    assert simulate_scene(s).table() == stopping.impacts.table()
    with pytest.raises(ParameterError, match="floor_db"):
        simulate_scene(s, floor_db=-40.0)


def _preset_bytes(name: str, cache_dir) -> bytes:
    """The bytes of preset ``name``'s render (its physical units) with the disk cache in
    ``cache_dir`` and whatever the process holds in memory."""
    import os

    import synth

    old = os.environ.get("SYNTH_CACHE_DIR")
    os.environ["SYNTH_CACHE_DIR"] = str(cache_dir)
    try:
        audio = synth.render_preset(name, normalize="none").audio
    finally:
        if old is None:
            os.environ.pop("SYNTH_CACHE_DIR", None)
        else:
            os.environ["SYNTH_CACHE_DIR"] = old
    return np.ascontiguousarray(audio).tobytes()


def _other_work(tmp_path) -> None:
    """Other scenes in the same process: the other rolling presets, a straight drop on
    another plate, and the rolling and its drive called with read-only arrays (which
    compile other specialisations of their kernels)."""
    _preset_bytes("steel-ball-rolling-on-glass-table", tmp_path / "other")
    _preset_bytes("thesis-steel10-mdf18-rolling", tmp_path / "other")
    _preset_bytes("small-click-on-acrylic", tmp_path / "other")
    s = scene(rms=1e-6)
    path = simulate_path(s, samplerate=SAMPLERATE)
    model = modal_model(s.plate, s.listener, samplerate=SAMPLERATE)
    r = path.rolling
    table = path_excitation(
        model, origin=path.origin, direction=path.direction,
        start=float(r.contact_coordinate.min()), stop=float(r.contact_coordinate.max()),
    )  # fmt: skip
    force, coordinate = r.force.copy(), r.contact_coordinate.copy()
    force.setflags(write=False)
    coordinate.setflags(write=False)
    state = ModeState.at_rest(model.poles.size)
    drive_modes(force, coordinate, table, model.poles, model.output, SAMPLERATE, state=state)


@pytest.mark.slow
def test_a_rolling_render_depends_on_its_inputs_alone(tmp_path):
    # "a result's bytes depend only on its inputs": a rolling preset rendered from an empty
    # disk and memory cache, again after other scenes in the same process (other rolling
    # presets, another plate, the rolling kernels called with other argument types) from
    # the now warm cache, and once more from another empty cache, gives the same bytes. A
    # rolling render amplifies the last bit of its path (micro-bounces on a rough surface),
    # so anything a render inherits from the process or the cache shows here.
    from synth.physics import modes
    from synth.sound import radiation

    name = "marble-rolling-on-wooden-floor"
    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    first = _preset_bytes(name, tmp_path / "a")
    _other_work(tmp_path)
    warm = _preset_bytes(name, tmp_path / "a")
    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    empty = _preset_bytes(name, tmp_path / "b")
    assert warm == first
    assert empty == first


def test_the_surface_kept_for_the_next_path_is_the_one_made_afresh(monkeypatch):
    """A path over the surface of an earlier one reuses its envelope (a pure function of the
    roughness, its seed, the length and the radius): the same values as one made afresh,
    another seed or radius a surface of its own, and no more samples kept than the bound."""
    from synth.physics import path as path_module

    rough = Rolling(
        resistance=0.0, spacing=5e-6, rms_height=1e-6, correlation_length=1e-4, hurst=0.8,
        seed=3,
    )  # fmt: skip
    monkeypatch.setattr(path_module, "_ENVELOPES", [])
    kept = path_module._envelope(rough, 0.01, 0.005)
    assert path_module._envelope(rough, 0.01, 0.005) is kept
    monkeypatch.setattr(path_module, "_ENVELOPES", [])
    fresh = path_module._envelope(rough, 0.01, 0.005)
    for name in ("heights", "contact_offsets", "coefficients"):
        assert np.array_equal(getattr(fresh, name), getattr(kept, name))
    other_seed = Rolling(**{**rough.__dict__, "seed": 4})
    assert not np.array_equal(path_module._envelope(other_seed, 0.01, 0.005).heights, kept.heights)
    assert path_module._envelope(rough, 0.01, 0.004) is not fresh
    monkeypatch.setattr(path_module, "ENVELOPE_CACHE_SAMPLES", 2 * fresh.heights.size)
    path_module._envelope(rough, 0.01, 0.003)
    assert sum(e.heights.size for _, e in path_module._ENVELOPES) <= 2 * fresh.heights.size
