"""The radiation rules behind one interface (synth.sound.radiation.rules): choose_rule takes
the cheapest rule that holds its error bound, and the chosen rule's gains lie within that
bound of a reference on presets and random plates."""

from __future__ import annotations

import numpy as np
import pytest

from synth import Microphone, Plate
from synth.cost import modal_count
from synth.cost.estimates import radiation_problem
from synth.io.presets import load_preset
from synth.physics import modes as plate_modes
from synth.sound import radiation as R
from synth.sound.radiation import rules

#: Presets of each shape family: simply supported (polar rule), clamped Ritz modes (a few:
#: the rectangle rule), free Ritz modes (the summed rule) at 48 kHz.
PRESETS = ("glass-marble-on-glass-table", "small-click-on-acrylic", "default")
#: The gains' tolerance, and the reference's (a thousandth of it: its own error is then
#: negligible against the bound tested).
TOL, REFERENCE_TOL = 1e-6, 1e-9


def _random_plates(count, seed=31):
    """``count`` random small plates (material, size, thickness, boundary) heard at a random
    microphone above them, up to a random highest frequency, Hz."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        a, b = rng.uniform(0.15, 0.45, 2)
        plate = Plate(
            str(rng.choice(["steel", "glass", "aluminium", "acrylic"])),
            thickness=float(rng.uniform(0.002, 0.008)),
            length=float(a),
            width=float(b),
            boundary=str(rng.choice(["free", "simply-supported", "clamped"])),
        )
        listener = (float(rng.uniform(-0.1, a + 0.1)), float(rng.uniform(-0.1, b + 0.1)), 0.2)
        out.append((plate, listener, float(rng.choice([6000.0, 11025.0]))))
    return out


def test_choose_rule_is_the_cheapest_rule_that_holds_the_bound():
    # On the presets and random plates (nothing solved): every rule that takes the shapes
    # and fits max_points states the bound tol; the chosen one costs least among them.
    cases = [(load_preset(n).plate, load_preset(n).listener.position, 24000.0) for n in PRESETS]
    for plate, listener, f_max in cases + _random_plates(6):
        problem = radiation_problem(plate, Microphone(listener), modal_count(plate, f_max), f_max)
        estimates = [r.estimate(problem) for r in rules.RULES if r.applies(problem)]
        fitting = [e for e in estimates if e.fits]
        assert fitting and all(e.error_bound == problem.tol for e in fitting)
        chosen = rules.choose_rule(problem)
        assert chosen.rule in [e.rule for e in fitting] and chosen.error_bound == problem.tol
        assert chosen.cost == min(e.cost for e in fitting)


def _check_against_reference(plate, listener, f_max):
    """The chosen rule's gains (plate_gains at TOL, the render's mirror poles) within
    TOL * max(|H|, 1e-4 S) of the rectangle rule's at REFERENCE_TOL (plus its own bound);
    returns the rule's name and the largest error over the bound."""
    m = plate_modes.modes(plate, max_frequency=f_max)
    omega, sigma = np.asarray(m.angular_frequencies), np.asarray(m.decay_rates)
    s = sigma + 1j * np.sqrt(np.maximum(omega**2 - sigma**2, 0.0))
    kb = (omega.max() ** 2 * plate.surface_density / plate.flexural_rigidity) ** 0.25
    kw = dict(max_wavenumber=kb, full_output=True)
    got = R.plate_gains(m, listener, s, tol=TOL, cache=False, **kw)
    size = (plate.length, plate.width)
    ref = R.rayleigh_gains(m.shapes, size, listener, s, tol=REFERENCE_TOL, **kw)
    assert got.success and ref.success
    scale = np.maximum(np.abs(ref.gains), 1e-4 * ref.coherent)
    ratio = np.abs(got.gains - ref.gains) / ((TOL + REFERENCE_TOL) * scale)
    return got.rule, float(ratio.max())


@pytest.mark.slow
@pytest.mark.parametrize("name", PRESETS)
def test_the_chosen_rules_gains_hold_their_bound_on_the_presets(name):
    # Each preset's microphone at 48 kHz, its gains by the chosen rule against the
    # reference: within the stated bound at every mode.
    scene = load_preset(name)
    rule, worst = _check_against_reference(scene.plate, scene.listener.position, 24000.0)
    assert worst <= 1.0, (name, rule, worst)


@pytest.mark.slow
def test_the_chosen_rules_gains_hold_their_bound_on_random_plates():
    # Random small plates of the three boundaries, microphones inside and outside the
    # plate's outline: within the stated bound at every mode, whichever rule is chosen.
    for plate, listener, f_max in _random_plates(4, seed=32):
        rule, worst = _check_against_reference(plate, listener, f_max)
        assert worst <= 1.0, (plate, listener, rule, worst)
