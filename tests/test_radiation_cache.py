"""Tests of synth.sound.radiation.plate_gains: the Rayleigh gains of a plate's modes, cached
in memory and on disk (keyed by everything that determines them), and of the
pipelined evaluation of the Rayleigh sums."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from synth.errors import ParameterError
from synth.physics import modes as P
from synth.physics.materials import LossFactor, Material
from synth.physics.scene import Plate
from synth.sound import radiation as R
from synth.sound.radiation import cache as radiation_cache
from synth.sound.radiation import rectangle

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))
LISTENER = (0.1, 0.05, 0.2)  # m, above a 0.3 m x 0.2 m plate


#: every test gets empty memory caches and its own disk cache directory
pytestmark = pytest.mark.usefixtures("empty_caches")


def _modes(width=0.2, thickness=0.002, max_frequency=3000.0):
    return P.modes(Plate(STEEL, thickness, 0.3, width, "free"), max_frequency=max_frequency)


def _args(modes):
    """Poles (rad/s) and the largest bending wavenumber (rad/m) of ``modes``."""
    plate = modes.plate
    s = -modes.decay_rates + 1j * modes.angular_frequencies
    kb = (
        modes.angular_frequencies.max() ** 2 * plate.surface_density / plate.flexural_rigidity
    ) ** 0.25
    return s, kb


def _gains(modes, listener=LISTENER, **kw):
    s, kb = _args(modes)
    return R.plate_gains(modes, listener, s, max_wavenumber=kb, **kw)


def _files(tmp_path):
    return sorted((tmp_path / "cache").glob("radiation-gains-*.npz"))


# ----------------------------------------------------------------------------------------
# The gains themselves


def test_plate_gains_equal_rayleigh_gains():
    m = _modes()
    s, kb = _args(m)
    direct = R.rayleigh_gains(
        m.shapes, (0.3, 0.2), LISTENER, s, max_wavenumber=kb, reference_distance=0.25
    )
    cached = R.plate_gains(m, LISTENER, s, max_wavenumber=kb, reference_distance=0.25)
    np.testing.assert_array_equal(cached, direct)
    assert not cached.flags.writeable  # shared between callers


@pytest.mark.parametrize(
    "modes, s, kwargs, match",
    [
        ("not modes", None, {}, "modes"),
        (None, "one short", {}, "poles"),
        (None, None, {"cache": 1}, "cache"),
        (None, None, {"tol": 0.0}, "tol"),
        (None, None, {"max_points": 0}, "max_points"),
    ],
)
def test_plate_gains_equal_rayleigh_gains_rejects_bad_input(modes, s, kwargs, match):
    m = _modes()
    poles, kb = _args(m)
    if s == "one short":
        poles = poles[:-1]
    with pytest.raises(ParameterError, match=match):
        R.plate_gains(m if modes is None else modes, LISTENER, poles, max_wavenumber=kb, **kwargs)
    assert R.cache_info()["computations"] == 0


def test_pipelined_sums_do_not_depend_on_workers(monkeypatch):
    # The sums over each chunk are split between worker threads; any number of them
    # gives the same gains to round-off (each sum is over a few 10^3 points).
    m = _modes()
    s, kb = _args(m)
    results = []
    for workers in (1, 3):
        monkeypatch.setattr(rectangle, "_workers", lambda: workers)
        results.append(
            R.rayleigh_gains(m.shapes, (0.3, 0.2), LISTENER, s, max_wavenumber=kb, full_output=True)
        )
    one, three = results
    np.testing.assert_allclose(three.gains, one.gains, rtol=0, atol=1e-13 * one.coherent.max())
    np.testing.assert_allclose(three.coherent, one.coherent, rtol=1e-13)


def test_pipelined_sums_do_not_depend_on_workers_rejects_failing_shape_fn():
    # An exception in shape_fn (on a later chunk, while a sum is running) reaches the
    # caller; nothing is left running.
    calls = []

    def shape(pts):
        calls.append(len(pts))
        if len(calls) == 3:
            raise ValueError("shape_fn failed")
        return np.ones((len(pts), 20000))

    with pytest.raises(ValueError, match="shape_fn failed"):
        R.rayleigh_gains(
            shape,
            (0.3, 0.2),
            (0.1, 0.1, 0.3),
            np.full(20000, 2j * np.pi * 200.0),
            max_wavenumber=0.0,
        )


# ----------------------------------------------------------------------------------------
# Cache


def test_cache_memory_hit():
    m = _modes()
    g1 = _gains(m)
    g2 = _gains(_modes())  # a new Modes of the same plate and band
    info = R.cache_info()
    assert info["computations"] == 1 and info["memory_hits"] == 1 and info["entries"] == 1
    assert g2 is g1


def test_cache_memory_hit_rejects_nothing_when_disabled(tmp_path):
    # cache=False neither reads nor writes: computed each time, no file, no entry.
    m = _modes()
    g1 = _gains(m, cache=False)
    g2 = _gains(m, cache=False)
    info = R.cache_info()
    assert info["computations"] == 2 and info["memory_hits"] == 0 and info["entries"] == 0
    assert _files(tmp_path) == []
    np.testing.assert_array_equal(g1, g2)


def test_cache_disk_round_trip(tmp_path):
    m = _modes()
    r1 = _gains(m, full_output=True)
    assert len(_files(tmp_path)) == 1 and R.cache_info()["disk_writes"] == 1
    R.clear_memory_cache()
    P.clear_memory_cache()
    r2 = _gains(_modes(), full_output=True)  # as in a new process: modes from disk too
    info = R.cache_info()
    assert info["disk_hits"] == 1 and info["computations"] == 0
    # Loaded, not recomputed: equal exactly, with the same diagnostics.
    np.testing.assert_array_equal(r2.gains, r1.gains)
    np.testing.assert_array_equal(r2.error, r1.error)
    np.testing.assert_array_equal(r2.coherent, r1.coherent)
    assert (r2.n_points, r2.refinements, r2.panels, r2.success, r2.status, r2.message) == (
        r1.n_points,
        r1.refinements,
        r1.panels,
        r1.success,
        r1.status,
        r1.message,
    )
    assert not r2.gains.flags.writeable


@pytest.mark.parametrize("rule", ["rectangle", "polar", "banded"])
def test_cache_disk_round_trip_keeps_every_rules_result(rule):
    # A stored result of each rule a gain comes from (the summed rule's says "polar", its
    # refinement's) is read back as written, exactly (nothing computed).
    gains = np.array([1.0 + 2.0j, -0.5j])
    result = R.RadiationResult(
        gains, np.array([1e-9, 2e-9]), np.array([3.0, 1.0]), 100, 1, (4, 5), True, 0, "ok", rule
    )
    radiation_cache.save_gains(result, f"key-{rule}")
    back = radiation_cache.load_gains(f"key-{rule}", gains.size)
    assert back is not None and back.rule == rule and back.message == "ok"
    np.testing.assert_array_equal(back.gains, gains)


def test_cache_disk_round_trip_rejects_unwritable_directory(tmp_path, monkeypatch):
    # A cache directory that cannot be created: computed, nothing stored, no error.
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(blocker / "cache"))
    g = _gains(_modes())
    assert np.all(np.isfinite(g))
    assert R.cache_info()["disk_writes"] == 0


@pytest.mark.parametrize("damage", ["garbage", "truncate", "wrong-key", "wrong-shape", "nan"])
def test_cache_corrupt_file_recomputed(tmp_path, damage, damage_cache_file):
    m = _modes()
    g1 = _gains(m)
    (path,) = _files(tmp_path)
    damage_cache_file(path, damage, "gains")
    R.clear_memory_cache()
    g2 = _gains(m)
    # The bad file is ignored: computed again, same result, file rewritten and readable.
    info = R.cache_info()
    assert info["computations"] == 1 and info["disk_hits"] == 0 and info["disk_writes"] == 1
    np.testing.assert_array_equal(g2, g1)
    R.clear_memory_cache()
    np.testing.assert_array_equal(_gains(m), g1)
    assert R.cache_info()["disk_hits"] == 1


def test_cache_key_changes_with_listener_and_plate(tmp_path):
    m = _modes()
    base = _gains(m)
    moved = _gains(m, listener=(0.1, 0.05, 0.21))
    assert R.cache_info()["computations"] == 2
    assert not np.array_equal(moved, base)
    other_plate = _modes(width=0.21)
    _gains(other_plate)
    assert R.cache_info()["computations"] == 3
    # Same shapes, other poles (thicker plate: other frequencies): another result.
    _gains(_modes(thickness=0.0021))
    assert R.cache_info()["computations"] == 4
    # Every accuracy setting and air constant is part of the key.
    s, kb = _args(m)
    for kw in (
        {"tol": 1e-5},
        {"air_density": 1.2},
        {"sound_speed": 340.0},
        {"reference_distance": 0.2},
        {"max_points": 3_000_000},
    ):
        R.plate_gains(m, LISTENER, s, max_wavenumber=kb, **kw)
    R.plate_gains(m, LISTENER, s, max_wavenumber=1.01 * kb)
    assert R.cache_info()["computations"] == 10
    assert len(_files(tmp_path)) == 10
    # The first request again: found, not recomputed.
    np.testing.assert_array_equal(_gains(m), base)
    assert R.cache_info()["computations"] == 10


def test_cache_does_not_serve_an_entry_of_edited_radiation_code(tmp_path, monkeypatch):
    # An entry computed while the radiation's sources read as edited (another digest of
    # them and all they import), as another revision with the same version numbers leaves
    # one: recomputed, not served, whatever it holds.
    m = _modes()
    base = _gains(m)
    (path,) = _files(tmp_path)
    with monkeypatch.context() as edited:
        edited.setattr(radiation_cache, "source_digest", lambda path: f"edited {path}")
        R.clear_memory_cache()
        _gains(m)
    assert R.cache_info()["computations"] == 1, "the edited code's key is another entry"
    for entry in _files(tmp_path):
        if entry != path:  # the edited code's entry: other values under its own key
            with np.load(entry) as z:
                arrays = {name: z[name] for name in z.files}
            arrays["gains"] = arrays["gains"] * (1.0 + 1e-12)
            np.savez(entry, **arrays)
    R.clear_memory_cache()
    np.testing.assert_array_equal(_gains(m), base)
    assert R.cache_info()["disk_hits"] == 1


def test_cache_key_changes_with_listener_and_plate_rejects_bad_listener():
    with pytest.raises(ParameterError, match="listener_position"):
        _gains(_modes(), listener=(0.1, 0.05, -0.2))
    assert R.cache_info()["computations"] == 0


def test_cache_memory_is_bounded(monkeypatch):
    monkeypatch.setattr(radiation_cache.CACHE, "max_entries", 2)
    m = _modes()
    for z in (0.2, 0.21, 0.22):
        _gains(m, listener=(0.1, 0.05, z))
    assert R.cache_info()["entries"] == 2


def test_cache_repeats_convergence_warning(monkeypatch):
    # A stored result that failed the convergence test warns again when loaded (the
    # rectangle rule, the only one choose_rule may take, made to fail).
    from synth.sound.radiation import rules

    m = _modes()
    real = R.rayleigh_gains
    monkeypatch.setattr(rules, "RULES", (rules.RectangleRule(),))

    def unconverged(*args, **kwargs):
        r = real(*args, **kwargs)
        return R.RadiationResult(
            r.gains,
            r.error,
            r.coherent,
            r.n_points,
            r.refinements,
            r.panels,
            False,
            1,
            "stopped (test)",
        )

    monkeypatch.setattr(rules, "rayleigh_gains", unconverged)
    with pytest.warns(RuntimeWarning, match="plate_gains: stopped"):
        _gains(m)
    R.clear_memory_cache()
    with pytest.warns(RuntimeWarning, match="plate_gains: stopped"):
        _gains(m)
    assert R.cache_info()["disk_hits"] == 1


def test_cache_repeats_convergence_warning_rejects_nothing_when_converged():
    m = _modes()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _gains(m)
        R.clear_memory_cache()
        _gains(m)
