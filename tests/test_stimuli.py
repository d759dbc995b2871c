"""Perception stimuli (thesis section 5.2)."""

import math

import pytest

import synth
from synth.cli import main
from synth.errors import ParameterError
from synth.physics import contact
from synth.stimuli import sequences as stimuli


@pytest.fixture(scope="module")
def default():
    """The scene of the thesis' stimuli (section 5.2): the thesis' scene and model (e = 0.87)."""
    return synth.load_preset("default", ["contact.model=thesis"])


def test_scale_one_is_the_physical_sequence(default):
    # k = 1 leaves every tick as computed (exact).
    a = synth.simulate_scene(default)
    b = stimuli.scaled_sequence(default, 1.0)
    assert [i.time for i in a] == [i.time for i in b]
    assert [i.restitution for i in b] == [i.result.restitution for i in b]


@pytest.mark.parametrize("k", [0.5, 2.0])
def test_scaled_restitution_follows_the_thesis_rule(k, default):
    # 1 - e' = k (1 - e) per tick, the next speed is e' v and the next time t + tau + 2 e' v / g
    # (rounding, 1e-12); each tick is still the physical impact at its own speed (its
    # contact equals solve_impact at that speed: the spectrum's physics is kept).
    seq = stimuli.scaled_sequence(default, k, max_impacts=8)
    for a, b in zip(seq, seq[1:]):
        e = a.result.restitution
        assert a.restitution == pytest.approx(1 - k * (1 - e), rel=1e-12)
        assert b.speed == pytest.approx(a.restitution * a.speed, rel=1e-12)
        assert b.time == pytest.approx(
            a.time + a.result.separation_time + 2 * b.speed / 9.81, rel=1e-12
        )
    c = default.contact
    ref = contact.solve_impact(
        default.ball, default.plate, seq[3].speed, position=default.position, rtol=c.rtol
    )
    assert seq[3].result.restitution == pytest.approx(ref.restitution, rel=1e-12)


def test_large_scale_stops_the_ball(default):
    # k >= 1 / (1 - e) gives e' <= 0: the ball does not leave the plate.
    seq = stimuli.scaled_sequence(default, 1.0 / (1.0 - 0.87) * 1.05)
    assert seq.stop_reason == "settled" and len(seq) == 1 and seq[0].restitution == 0.0


def test_mismatch_keeps_timing_and_swaps_ticks(default):
    # Times and speeds from the 19 mm ball's scene, contacts of the 10 mm ball at those
    # speeds (exact).
    timing = synth.load_preset("thesis-steel19-mdf18")
    seq = stimuli.mismatch_sequence(timing, default)
    ref = synth.simulate_scene(timing)
    assert [i.time for i in seq] == [i.time for i in ref]
    assert [i.speed for i in seq] == [i.speed for i in ref]
    small = contact.solve_impact(
        default.ball,
        default.plate,
        ref[2].speed,
        position=default.position,
        rtol=default.contact.rtol,
    )
    assert seq[2].result.contact_time == pytest.approx(small.contact_time, rel=1e-12)
    assert seq[2].result.contact_time < ref[2].result.contact_time


def test_cli_render_stimuli(tmp_path, capsys):
    # The options reach the renderer: the report's first restitution follows the rule.
    out = tmp_path / "k.wav"
    rep = tmp_path / "k.json"
    assert (
        main(
            ["render", "default", "-o", str(out), "--restitution-scale", "2", "--report", str(rep)]
        )
        == 0
    )
    import json

    data = json.loads(rep.read_text())
    e = data["impacts"][0]["restitution"]
    # the default preset's own first restitution (the measured model's), scaled by the rule
    e1 = synth.simulate_scene(synth.load_preset("default"), max_impacts=1)[0].restitution
    assert e == pytest.approx(1 - 2 * (1 - e1), abs=1e-9)
    assert (
        main(
            [
                "render",
                "default",
                "-o",
                str(tmp_path / "m.wav"),
                "--timing-from",
                "thesis-steel19-mdf18",
            ]
        )
        == 0
    )


@pytest.mark.parametrize("bad", [-0.5, math.nan, math.inf])
def test_scaled_sequence_rejects_bad_scale(bad, default):
    with pytest.raises(ParameterError, match="restitution_scale"):
        stimuli.scaled_sequence(default, bad)


def test_mismatch_sequence_rejects_non_scenes(default):
    with pytest.raises(ParameterError, match="timing_scene"):
        stimuli.mismatch_sequence("default", default)
    with pytest.raises(ParameterError, match="spectrum_scene"):
        stimuli.mismatch_sequence(default, None)


def test_scaled_restitution_on_the_modal_plate():
    # The measured model's "auto" plate is the modal one on a small plate: the rule holds
    # there too. Each tick records 1 - e' = k (1 - e) of its physical contact (rounding,
    # 1e-12), the first tick is the physical one (solved before any rule applies, exact),
    # and k = 0 makes the first flight elastic (e' = 1).
    from synth.io.presets import scene_from_dict

    scene, _ = scene_from_dict(
        {
            "ball": {"material": "steel", "radius": 0.005},
            "plate": {"material": "mdf-18", "thickness": 0.018, "length": 0.3, "width": 0.2,
                      "boundary": "simply-supported"},
            "drop": {"height": 0.02, "position": [0.15, 0.1]},
            "contact": {"plate": "modal"},
        },
        "<modal scene>",
    )  # fmt: skip
    physical = synth.simulate_scene(scene, max_impacts=4)
    for k in (0.0, 0.5):
        seq = stimuli.scaled_sequence(scene, k, max_impacts=4)
        assert len(seq) > 1
        for tick in seq:
            e = tick.result.restitution
            assert tick.restitution == pytest.approx(1 - k * (1 - e), rel=1e-12)
        assert seq[0].result.restitution == physical[0].result.restitution
    assert stimuli.scaled_sequence(scene, 0.0, max_impacts=2)[0].restitution == 1.0
