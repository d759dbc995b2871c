"""The impacts of a drop in one compiled call (ContactSolver.solve_drop, the bounce
scheduler's loop in compiled code) against one call per impact: the same series, bit for bit,
where the compiled series serves, where it hands over (an edge's admittance, Radau IIA) and
at its limits."""

from __future__ import annotations

import dataclasses

import pytest

from synth.io.presets import load_preset
from synth.physics import contact, impedance
from synth.physics.bounces import simulate_bounces, simulate_scene
from synth.physics.scene import Ball, Plate


def _one_call_each(self, speed, start, **rules):
    """solve_drop handing every impact over: simulate_bounces' loop solves each alone."""
    return contact.DropImpacts((), (), (), "handed-over", float(start), float(speed))


def _fields(seq):
    return [
        (
            i.index,
            i.time,
            i.speed,
            i.restitution,
            i.result.contact_time,
            i.result.separation_time,
            i.result.peak_force,
            i.result.status,
            i.result.message,
            i.result.method,
            i.result.n_steps,
        )  # fmt: skip
        for i in seq
    ] + [seq.stop_reason]


def _both(monkeypatch, run):
    compiled = run()
    with monkeypatch.context() as m:
        m.setattr(contact.ContactSolver, "solve_drop", _one_call_each)
        alone = run()
    return compiled, alone


def _scene_on_impedance(name, **changes):
    scene = load_preset(name)
    return dataclasses.replace(
        scene, contact=dataclasses.replace(scene.contact, plate="impedance"), **changes
    )


@pytest.mark.parametrize(
    "scene",
    [
        load_preset("default"),
        load_preset("small-click-on-acrylic"),
        # 13 cm from a free edge: the slower impacts' longer contacts feel it, from there
        # each goes to solve() (its admittance there solved with its contact time)
        _scene_on_impedance("default", position=(0.6135, 0.13)),
    ],
    ids=["default", "small-click", "near-an-edge"],
)
def test_the_series_in_one_call_is_the_series_of_one_call_each(monkeypatch, scene):
    compiled, alone = _both(monkeypatch, lambda: simulate_scene(scene))
    assert len(compiled) > 5
    assert _fields(compiled) == _fields(alone)
    # the pulses come from the same dense outputs
    assert (compiled[-1].result.force == alone[-1].result.force).all()


def test_an_edge_hands_the_series_over_where_it_is_felt():
    # the edge is felt within a contact of tau from sqrt(pi tau) (D / rho h)^(1/4) on:
    # about 10 cm for the first contact of this drop, 18 cm for its last
    scene = _scene_on_impedance("default", position=(0.6135, 0.13))
    c = scene.contact
    solver = contact.ContactSolver.for_pair(
        scene.ball, scene.plate, gravity=scene.gravity, law=c.law, rtol=c.rtol, **c.options()
    )
    drop = solver.solve_drop(
        1.4, 0.1, position=scene.position, energy_floor=1e-6, max_duration=60.0, max_impacts=100
    )
    assert drop.end == "handed-over" and len(drop.results) > 2
    for res in drop.results:
        assert impedance.critical_distance(scene.plate, res.contact_time) <= 0.13
    last = drop.results[-1]
    assert drop.next_speed == last.rebound_speed
    assert drop.next_time == pytest.approx(
        drop.times[-1] + last.separation_time + 2.0 * last.rebound_speed / scene.gravity,
        rel=1e-15,
    )
    beyond = solver.solve(drop.next_speed, position=scene.position)
    assert impedance.critical_distance(scene.plate, beyond.contact_time) > 0.13


@pytest.mark.slow  # Radau IIA's kernels compile on a cold cache
def test_a_stiff_contact_is_handed_over_to_radau(monkeypatch):
    # a 50 mm steel ball on a 0.5 mm aluminium sheet: lam > 20, Radau IIA's; the series
    # hands it over and goes on one call each, as before
    ball, plate = Ball("steel", 0.025), Plate("aluminium", 0.0005, 1.0, 0.8)

    def run():
        return simulate_bounces(ball, plate, drop_height=0.5, max_impacts=4)

    compiled, alone = _both(monkeypatch, run)
    assert compiled[0].result.method == "Radau"
    assert _fields(compiled) == _fields(alone)


@pytest.mark.parametrize("max_impacts", [1, 2, 7])
def test_the_series_ends_as_the_loop_ends_at_its_limits(monkeypatch, max_impacts):
    scene = load_preset("default")

    def run():
        return simulate_scene(scene, max_impacts=max_impacts, max_duration=0.6)

    compiled, alone = _both(monkeypatch, run)
    assert _fields(compiled) == _fields(alone)
    assert len(compiled) <= max_impacts


def test_a_series_longer_than_one_call_holds_goes_on_one_call_each(monkeypatch):
    # the compiled series' arrays hold DROP_CAPACITY impacts (a user may allow any number):
    # past them the series is handed over and goes on one call each, the same series
    scene = load_preset("default")
    monkeypatch.setattr(contact, "DROP_CAPACITY", 4)
    compiled, alone = _both(monkeypatch, lambda: simulate_scene(scene))
    assert len(compiled) > 8
    assert _fields(compiled) == _fields(alone)
    c = scene.contact
    solver = contact.ContactSolver.for_pair(
        scene.ball, scene.plate, gravity=scene.gravity, law=c.law, rtol=c.rtol, **c.options()
    )
    drop = solver.solve_drop(
        1.4, 0.14, position=scene.position, energy_floor=1e-6, max_duration=60.0,
        max_impacts=10**12,
    )  # fmt: skip
    assert drop.end == "handed-over" and len(drop.results) == 4
    assert drop.next_speed == drop.results[-1].rebound_speed
