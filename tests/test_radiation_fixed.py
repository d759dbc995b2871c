"""The fixed radiation grids of a moving listener (synth.sound.radiation.fixed): at any
microphone at least their height above the plate, the gains of plate_gains (the rule each
listener got before) within 2 tol, the shapes evaluated once."""

from __future__ import annotations

import numpy as np
import pytest

import synth
from synth.errors import ParameterError
from synth.physics import modes as P
from synth.physics.materials import LossFactor, Material
from synth.physics.modes import crossover
from synth.physics.scene import Microphone, Plate
from synth.sound import radiation as R
from synth.sound.radiation import rules
from synth.sound.radiation.common import COHERENT_FLOOR
from synth.sound.radiation.fixed import NEAR_FIELD_HEIGHT, GridTooLarge, ListenerGrid
from synth.sound.render import listener_grid, modal_model, nearest_distance

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))
TOL = 1e-6  # plate_gains' default, the grids' too


def _case(plate, max_frequency):
    """The plate's modes, their mirror poles (rad/s, as a microphone's gains take them) and
    largest bending wavenumber (rad/m)."""
    m = P.modes(plate, max_frequency=max_frequency, cache=False)
    sigma, omega = m.decay_rates, m.angular_frequencies
    s = sigma + 1j * np.sqrt(np.maximum(omega**2 - sigma**2, 0.0))
    kb = (omega.max() ** 2 * plate.surface_density / plate.flexural_rigidity) ** 0.25
    return m, s, kb


def _random_microphones(plate, n, seed):
    """``n`` microphones (seeded) over and around the plate (half a metre beyond each edge),
    from the grids' height to 1 m above it."""
    rng = np.random.default_rng(seed)
    a, b = plate.length, plate.width
    return [
        (
            rng.uniform(-0.5, a + 0.5),
            rng.uniform(-0.5, b + 0.5),
            rng.uniform(NEAR_FIELD_HEIGHT, 1.0),
        )
        for _ in range(n)
    ]


def _assert_within_two_tol(grid, m, s, kb, microphones):
    # each rule is within tol of the integral, relative to max(|H_k|, 1e-4 S_k) (the
    # refinement's test, synth.sound.radiation.common.refine): the two within 2 tol of each other
    for mic in microphones:
        r0 = nearest_distance(m.plate, Microphone(mic))
        exact = R.plate_gains(
            m, mic, s, max_wavenumber=kb, reference_distance=r0, full_output=True, cache=False
        )
        assert exact.success, exact.message
        fast = grid.gains(mic, r0)
        assert grid.gains(mic, r0) is fast and not fast.flags.writeable  # kept, read-only
        allowed = 2 * TOL * np.maximum(np.abs(exact.gains), COHERENT_FLOOR * exact.coherent)
        worst = int(np.argmax(np.abs(fast - exact.gains) / allowed))
        assert np.all(np.abs(fast - exact.gains) <= allowed), (mic, worst)


@pytest.mark.parametrize("boundary", ["free", "simply-supported", "clamped"])
def test_fixed_grids_give_plate_gains_at_random_microphones(boundary):
    plate = Plate(STEEL, 0.002, 0.3, 0.2, boundary)
    m, s, kb = _case(plate, 6000.0)
    grid = ListenerGrid(m, s, max_wavenumber=kb)
    _assert_within_two_tol(grid, m, s, kb, _random_microphones(plate, 5, seed=26))
    # the grids evaluate one exponential per mode and point of their band: fewer than the
    # modes times the points of one rule for the fastest mode (the bands' point)
    assert grid.points < len(m) * max(b.w.size for b in grid._bands)


@pytest.mark.slow
def test_fixed_grids_take_the_edge_effect_modes_shapes(monkeypatch):
    # a small free plate past a lowered Ritz crossover (as test_radiation_rectangle_bands):
    # its dynamic edge effect modes, which plate_gains sums by their factor tables, by
    # their shapes on the fixed grids
    monkeypatch.setattr(crossover, "CROSSOVER_UNKNOWNS", 80)
    monkeypatch.setattr(crossover, "LOW_BAND_UNKNOWNS", 50)
    monkeypatch.setattr(rules, "RULES", (rules.BandedRule(),))
    plate = Plate(STEEL, 0.002, 0.3, 0.2, "free")
    m, s, kb = _case(plate, 6000.0)
    assert m.edge_effect() is not None
    grid = ListenerGrid(m, s, max_wavenumber=kb)
    _assert_within_two_tol(grid, m, s, kb, _random_microphones(plate, 3, seed=27))


@pytest.mark.slow
def test_the_default_board_s_moved_microphones_keep_its_exact_gains():
    # the live engine's plate (494 modes at 48 kHz), as Body.move takes its gains: the
    # listener's output gains (ModalModel.heard_by with the grids) against modal_model's
    scene = synth.load_preset("default")
    model = modal_model(scene.plate, scene.listener, samplerate=48000)
    grid = listener_grid(model)
    for mic in _random_microphones(scene.plate, 3, seed=28):
        exact = modal_model(scene.plate, Microphone(mic), samplerate=48000)
        fast = model.heard_by(Microphone(mic), grid)
        # the output gains are G_k p_k: the bound of plate_gains' gains carries over; with
        # no in-phase bound here, the energy-weighted error stays under 2 tol of the norm
        err = np.linalg.norm(fast.output - exact.output) / np.linalg.norm(exact.output)
        assert err <= 2 * TOL, (mic, err)
        assert fast.delay == exact.delay and fast.units == exact.units == "Pa"


def test_a_microphone_below_the_grids_is_refused_and_modal_model_s_rule_kept():
    plate = Plate(STEEL, 0.002, 0.3, 0.2, "free")
    model = modal_model(plate, Microphone((0.1, 0.1, 0.2)), samplerate=16000)
    grid = listener_grid(model)
    low = (0.1, 0.05, 0.5 * NEAR_FIELD_HEIGHT)
    assert not grid.serves(low) and grid.serves((0.1, 0.05, NEAR_FIELD_HEIGHT))
    with pytest.raises(ParameterError, match="listener_position.z"):
        grid.gains(low)
    # heard_by leaves a microphone the grids do not serve to plate_gains: the same gains
    # as modal_model's, bit for bit
    exact = modal_model(plate, Microphone(low), samplerate=16000)
    np.testing.assert_array_equal(model.heard_by(Microphone(low), grid).output, exact.output)
    np.testing.assert_array_equal(model.heard_by(Microphone(low)).output, exact.output)


def test_grids_beyond_their_memory_budget_are_refused_before_any_shape():
    plate = Plate(STEEL, 0.002, 0.3, 0.2, "free")
    model = modal_model(plate, Microphone((0.1, 0.1, 0.2)), samplerate=16000)
    grid = listener_grid(model)
    with pytest.raises(GridTooLarge, match="MiB"):
        listener_grid(model, max_bytes=grid.nbytes - 1)
    assert listener_grid(model, max_bytes=grid.nbytes).nbytes == grid.nbytes  # the estimate


def test_an_engine_moves_a_plate_beyond_the_grids_budget_by_the_exact_rule(monkeypatch):
    import synth.sound.radiation.fixed as F

    monkeypatch.setattr(F, "MAX_GRID_BYTES", 1)
    plate = Plate(STEEL, 0.002, 0.3, 0.2, "free")
    engine = synth.Engine(samplerate=16000)
    body = engine.add(plate)
    mic = synth.Microphone((0.2, 0.1, 0.3))
    body.move(mic)
    engine.prepare_moves()
    assert engine.listener_grid_memory == 0 and body._grid is None
    exact = modal_model(plate, mic, samplerate=16000)
    np.testing.assert_array_equal(body._model.output, exact.output)
