"""A result's bytes depend only on its inputs, never on what ran before it: the modal
contact's point modes, a short bounce series on them, and the radiation gains of a band's
modes are compared bit for bit from an empty cache and from caches that other work filled
(the same band from memory or disk, a narrower or a wider band, another point, an entry
written by another revision or an edit of the mode solver, a crossed-over band solved with
another low Ritz band). A series of bounces amplifies any
difference in the modes' last bits into other impact times and counts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from synth import jitcache
from synth.physics import modal_contact as mc
from synth.physics import modes as plate_modes
from synth.physics.bounces import simulate_bounces
from synth.physics.modal_contact import point as point_module
from synth.physics.modes import common, crossover
from synth.physics.scene import Ball, Plate
from synth.sound import radiation
from synth.store.cache import cache_dir, cache_path, savez_atomic

BALL = Ball("steel", 0.005)
#: small plates of each boundary and a band of a few hundred modes (a Ritz solve of well
#: under a second for the free and clamped ones, the closed form for the simply supported)
PLATES = {
    "free": (Plate("aluminium", 0.004, 0.32, 0.25, "free"), (0.07, 0.19), 12000.0),
    "clamped": (Plate("glass", 0.005, 0.3, 0.24, "clamped"), (0.21, 0.06), 15000.0),
    "simply-supported": (Plate("steel", 0.003, 0.4, 0.3, "simply-supported"), (0.13, 0.1), 9000.0),
}


def _forget_memory():
    plate_modes.clear_memory_cache()
    mc.clear_memory_cache()
    radiation.clear_memory_cache()


def _point_files():
    return list(cache_dir().glob("contact-point-modes-*"))


def _fingerprint(plate, position, band):
    """The bytes of every oscillator the contact drives at ``position`` and of a short
    bounce series there (each impact's time, speed, restitution and force pulse)."""
    point = mc.modal_point(plate, position, max_frequency=band)
    seq = simulate_bounces(
        BALL, plate, drop_height=0.05, position=position, plate_model="modal",
        max_frequency=band, max_impacts=3,
    )  # fmt: skip
    series = [(i.time, i.speed, i.restitution, i.result.force.tobytes()) for i in seq.impacts]
    return [a.tobytes() for a in point.contact_modes], series


def _legacy_entry(plate, position, band):
    """An entry in the key the point cache had before it named the solver (every input but
    the solver's revision) holding other last bits, as a solve on other BLAS threads left
    one: it must not be served."""
    from synth.physics.modes import TOLERANCE

    key = json.dumps(
        dict(
            point_module._plate_key(plate, band),
            x=float(position[0]).hex(),
            y=float(position[1]).hex(),
            version=1,
            tolerance=TOLERANCE,
        ),
        sort_keys=True,
    )
    m = plate_modes.modes(plate, max_frequency=band, cache=False)
    phi = m.shapes(np.array([position]))[0]
    coupling = phi * phi / m.modal_masses * (1.0 + 1e-12)
    omega = np.array(m.angular_frequencies)
    savez_atomic(
        cache_path("contact-point-modes", key),
        {"key": np.array(key), "omega": omega, "coupling": coupling},
    )


def _edited_solver_entry(plate, position, band):
    """An entry under the key the point cache gives while its code reads as edited (the
    digest of its sources another), holding other last bits, as an edited solver or another
    revision with the same version numbers leaves one: it must not be served."""
    with pytest.MonkeyPatch.context() as edited:
        edited.setattr(jitcache, "source_digest", lambda path: f"edited {path}", raising=False)
        key = point_module._point_key(plate, position, band)
    _other_bits_entry(plate, position, band, key)


def _other_machine_entry(plate, position, band):
    """An entry under the key the point cache gives while its BLAS reads as another build's
    kernels (other last bits of the same library versions, as another CPU's): not served."""
    other = (("blas", [["openblas", "0.3.30", "SkylakeX"]]),)
    with pytest.MonkeyPatch.context() as moved:
        moved.setattr(common, "_numerics", lambda: other, raising=False)
        key = point_module._point_key(plate, position, band)
    _other_bits_entry(plate, position, band, key)


def _other_bits_entry(plate, position, band, key):
    """The point's modes with couplings 1e-12 off, stored under ``key``."""
    m = plate_modes.modes(plate, max_frequency=band, cache=False)
    phi = m.shapes(np.array([position]))[0]
    savez_atomic(
        cache_path("contact-point-modes", key),
        {"key": np.array(key), "omega": np.array(m.angular_frequencies),
         "coupling": phi * phi / m.modal_masses * (1.0 + 1e-12)},
    )  # fmt: skip


# each state: what runs before the measured call, in an empty private cache
STATES = {
    "from disk": lambda plate, pos, band: (
        mc.modal_point(plate, pos, max_frequency=band),
        _forget_memory(),
    ),
    "band modes in memory": lambda plate, pos, band: (
        mc.modal_point(plate, pos, max_frequency=band),
        [p.unlink() for p in _point_files()],
    ),
    "narrower band solved": lambda plate, pos, band: plate_modes.modes(
        plate, max_frequency=0.6 * band
    ),
    "wider band solved": lambda plate, pos, band: plate_modes.modes(
        plate, max_frequency=1.5 * band
    ),
    "this band solved": lambda plate, pos, band: plate_modes.modes(plate, max_frequency=band),
    "another point, wider band": lambda plate, pos, band: mc.modal_point(
        plate, (0.5 * plate.length, 0.5 * plate.width), max_frequency=1.5 * band
    ),
    "entry of another solver revision": _legacy_entry,
    "entry of an edited solver": _edited_solver_entry,
    "entry of another machine's BLAS": _other_machine_entry,
}


@pytest.mark.parametrize("boundary", sorted(PLATES))
def test_point_modes_and_bounces_are_the_same_bytes_in_every_cache_state(
    boundary, tmp_path, monkeypatch
):
    plate, position, band = PLATES[boundary]
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cold"))
    _forget_memory()
    cold = _fingerprint(plate, position, band)
    assert _point_files(), "the point's modes are stored on disk"
    for i, (name, before) in enumerate(STATES.items()):
        monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / f"state{i}"))
        _forget_memory()
        before(plate, position, band)
        assert _fingerprint(plate, position, band) == cold, name
    _forget_memory()


#: A band past the Ritz crossover: a low Ritz band of ~100 modes, then ~1700 edge effect modes.
CROSSED = (Plate("steel", 0.001, 0.3, 0.2, "clamped"), (0.07, 0.13), 100000.0)


def test_crossed_over_point_modes_are_keyed_on_the_low_band_they_were_solved_with(
    tmp_path, monkeypatch
):
    # The point's entry names the low Ritz band; one solved with another low band (another
    # crossover setting) holds other modes and must not be served to this one.
    plate, position, band = CROSSED
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cold"))
    _forget_memory()
    assert plate_modes.modes(plate, max_frequency=band, cache=False).edge_effect() is not None
    cold = _fingerprint(plate, position, band)
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "other low band"))
    _forget_memory()
    with monkeypatch.context() as m:
        m.setattr(crossover, "LOW_BAND_UNKNOWNS", 200)
        mc.modal_point(plate, position, max_frequency=band)
    _forget_memory()
    assert _fingerprint(plate, position, band) == cold
    _forget_memory()
    assert _fingerprint(plate, position, band) == cold, "from disk"
    _forget_memory()


def test_radiation_gains_are_the_same_bytes_after_a_wider_band(tmp_path, monkeypatch):
    # The gains are keyed by the modes' solution and poles: a wider band solved first (its
    # modes equal within the solver's tolerance, not to the bit) leaves them unchanged.
    plate, band = PLATES["free"][0], 4000.0
    listener = (0.1, 0.05, 0.2)

    def gains():
        m = plate_modes.modes(plate, max_frequency=band)
        s = -m.decay_rates + 1j * m.angular_frequencies
        kb = (s.imag.max() ** 2 * plate.surface_density / plate.flexural_rigidity) ** 0.25
        return radiation.plate_gains(m, listener, s, max_wavenumber=kb).tobytes()

    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cold"))
    _forget_memory()
    cold = gains()
    _forget_memory()
    assert gains() == cold, "from disk"
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "wider"))
    _forget_memory()
    plate_modes.modes(plate, max_frequency=1.5 * band)
    assert gains() == cold, "after a wider band"
    _forget_memory()
