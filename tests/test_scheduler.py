"""The bounce scheduler (docs/physics.md, "Bounces")."""

import math

import pytest

from synth.errors import ParameterError
from synth.physics.bounces import BounceOptions, simulate_bounces, simulate_scene
from synth.physics.scene import Ball, Plate, Scene

BALL = Ball("steel", 0.005, mass=4.17e-3)
MDF18 = Plate("mdf-18", 0.018, 1.227, 0.49)


@pytest.fixture(scope="module")
def thesis():
    return simulate_bounces(BALL, MDF18, drop_height=0.1)


def test_first_impact_is_free_fall(thesis):
    # t1 = sqrt(2 h0 / g), v1 = sqrt(2 g h0) (closed form, 1e-12).
    assert thesis[0].time == pytest.approx(math.sqrt(2 * 0.1 / 9.81), rel=1e-12)
    assert thesis[0].speed == pytest.approx(math.sqrt(2 * 9.81 * 0.1), rel=1e-12)


def test_flight_law(thesis):
    # t_(n+1) = t_n + tau_n + 2 v_out,n / g and v_(n+1) = v_out,n (docs/physics.md, "Bounces",
    # rounding), tau_n the time to separation (the contact time of this elastic law).
    for a, b in zip(thesis, thesis[1:]):
        r = a.result
        assert r.separation_time == r.contact_time
        assert b.time == pytest.approx(
            a.time + r.separation_time + 2 * r.rebound_speed / 9.81, rel=1e-12
        )
        assert b.speed == pytest.approx(r.rebound_speed, rel=1e-12)


def test_thesis_series_first_restitution_and_physical_end(thesis):
    # e = 0.87 +- 0.01 at the first impact (thesis); the series ends by a physical rule
    # (the ball settles or its flight becomes shorter than its contact) before the -60 dB
    # floor, and the restitution first rises as the speed falls (thesis Fig. 3.x trend).
    assert thesis[0].result.restitution == pytest.approx(0.87, abs=0.01)
    assert thesis.stop_reason in ("settled", "flight-shorter-than-contact", "floor")
    assert thesis[5].result.restitution > thesis[0].result.restitution
    assert len(thesis) > 10


def test_energy_falls_by_e_squared_per_bounce(thesis):
    # Kinetic energy of impact n+1 over impact n is e_n^2 (by the flight law, 1e-12).
    for a, b in zip(thesis, thesis[1:]):
        assert b.speed**2 / a.speed**2 == pytest.approx(a.result.restitution**2, rel=1e-12)


def test_floor_stops_the_series():
    # A -20 dB floor stops when (v_n / v_1)^2 < 0.01: the last impact's rebound is below it.
    seq = simulate_bounces(BALL, MDF18, drop_height=0.1, floor_db=-20.0)
    assert seq.stop_reason == "floor"
    assert (seq[-1].result.rebound_speed / seq[0].speed) ** 2 < 0.01
    assert (seq[-1].speed / seq[0].speed) ** 2 >= 0.01


def test_max_impacts_and_duration():
    assert (
        simulate_bounces(BALL, MDF18, drop_height=0.1, max_impacts=3).stop_reason == "max-impacts"
    )
    seq = simulate_bounces(BALL, MDF18, drop_height=0.1, max_duration=0.5)
    assert seq.stop_reason == "max-duration" and seq[-1].time <= 0.5


def test_options_object_and_keywords_agree():
    # BounceOptions holds the keywords' fields: the same series either way (same arithmetic),
    # keywords replacing the object's fields, and a bad field refused when the object is made.
    by_keywords = simulate_bounces(BALL, MDF18, drop_height=0.1, max_impacts=3, floor_db=-20.0)
    options = BounceOptions(max_impacts=5, floor_db=-20.0)
    by_object = simulate_bounces(BALL, MDF18, drop_height=0.1, options=options, max_impacts=3)
    assert by_object.table() == by_keywords.table()
    assert by_object.stop_reason == by_keywords.stop_reason
    with pytest.raises(ParameterError, match="max_impacts"):
        BounceOptions(max_impacts=0)


def test_heavy_ball_on_thin_plate_settles():
    # lambda >> 1 (50 mm steel ball on 0.5 mm aluminium): the first impact does not separate.
    seq = simulate_bounces(
        Ball("steel", 0.025), Plate("aluminium", 0.0005, 1.0, 0.8), drop_height=0.1
    )
    assert seq.stop_reason == "settled" and len(seq) == 1 and seq[0].result.restitution == 0.0


def test_corner_impact_loses_more():
    # Near a free corner the plate is ~7.5x more compliant: lower restitution.
    mid = simulate_bounces(BALL, MDF18, drop_height=0.1, max_impacts=1)
    corner = simulate_bounces(BALL, MDF18, drop_height=0.1, position=(0.0, 0.0), max_impacts=1)
    assert corner[0].result.restitution < mid[0].result.restitution - 0.2


def test_simulate_scene_uses_scene_contact():
    from synth.physics.scene import Contact

    s = Scene(BALL, MDF18, drop_height=0.1, contact=Contact("hunt-crossley", dissipation=0.3))
    hc = simulate_scene(s, max_impacts=1)
    hz = simulate_scene(Scene(BALL, MDF18, drop_height=0.1), max_impacts=1)
    assert hc[0].result.restitution < hz[0].result.restitution


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(drop_height=0.0), "drop_height"),
        (dict(drop_height=float("nan")), "drop_height"),
        (dict(drop_height=0.1, gravity=0.0), "gravity"),
        (dict(drop_height=0.1, floor_db=3.0), "floor_db"),
        (dict(drop_height=0.1, max_duration=-1.0), "max_duration"),
        (dict(drop_height=0.1, max_impacts=0), "max_impacts"),
        (dict(drop_height=0.1, position=(5.0, 0.1)), "position"),
        (dict(drop_height=0.1, contact_law="glue"), "contact"),
    ],
)
def test_simulate_bounces_rejects_bad_input(kw, word):
    with pytest.raises(ParameterError, match=word):
        simulate_bounces(BALL, MDF18, **kw)


def test_simulate_scene_rejects_non_scene():
    with pytest.raises(ParameterError, match="scene"):
        simulate_scene("default")


def test_rebound_rule_replaces_the_restitution():
    # A rule e' = 0.5: every flight starts at half the impact speed (v_(n+1) = e' v_n, exact
    # arithmetic), each impact still solved physically; and a rule e' = 0 stops at once.
    seq = simulate_bounces(
        BALL, MDF18, drop_height=0.1, max_impacts=5, rebound=lambda result, speed: 0.5
    )
    for a, b in zip(seq, seq[1:]):
        assert b.speed == 0.5 * a.speed
        assert a.restitution == 0.5
    stop = simulate_bounces(BALL, MDF18, drop_height=0.1, rebound=lambda result, speed: 0.0)
    assert len(stop) == 1 and stop.stop_reason == "settled"
    with pytest.raises(ParameterError, match="rebound"):
        simulate_bounces(BALL, MDF18, drop_height=0.1, rebound=0.5)


def test_flight_starts_at_separation_with_a_lossy_contact():
    # With MDF's viscoelastic surface the force ends before the penetration returns to zero:
    # the flight starts at the separation (the contact time, the force pulse's, is shorter),
    # t_(n+1) = t_n + separation_n + 2 v_out,n / g (rounding).
    seq = simulate_bounces(BALL, MDF18, drop_height=0.1, surface="fitted", max_impacts=6)
    for a, b in zip(seq, seq[1:]):
        r = a.result
        assert r.contact_time < r.separation_time
        assert b.time == pytest.approx(
            a.time + r.separation_time + 2 * r.rebound_speed / 9.81, rel=1e-12
        )
