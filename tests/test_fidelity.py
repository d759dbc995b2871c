"""Fidelity to the thesis' measurements: what the engine needs for a contact alone, the
robustness of edge and corner contacts, and the honesty of the thesis comparison."""

from pathlib import Path

import pytest

from synth.errors import ParameterError
from synth.physics.contact import solve_impact
from synth.physics.materials import Material
from synth.physics.scene import Ball, Plate

#: A plate material with no damping law (MDF's elastic constants, thesis Table 3.1).
UNDAMPED_MDF = Material("mdf-undamped", 700.0, 5.689e9, 0.4)


def test_contact_needs_no_damping_law():
    # The contact sees the plate's impedance only (stiffness and mass): the impact on a plate
    # without a damping law equals, to the last bit, the impact on the same plate with one.
    ball = Ball("steel", 0.005)
    bare = Plate(UNDAMPED_MDF, 0.018, 1.227, 0.49)
    damped = Plate("mdf-18", 0.018, 1.227, 0.49)
    for position in (None, (0.6, 0.245), (0.01, 0.245), (0.004, 0.003)):
        a = solve_impact(ball, bare, 1.4, position=position)
        b = solve_impact(ball, damped, 1.4, position=position)
        assert a.restitution == b.restitution and a.contact_time == b.contact_time


def test_bounces_need_no_damping_law():
    from synth.physics.bounces import simulate_bounces

    seq = simulate_bounces(Ball("steel", 0.005), Plate(UNDAMPED_MDF, 0.018, 1.227, 0.49),
                           drop_height=0.1)
    assert len(seq.impacts) > 3


def test_render_names_the_missing_damping_law():
    # Rendering computes the plate's modes: the error names the field and what is allowed,
    # before any bounce is computed.
    import synth
    from synth.physics.scene import Scene
    from synth.sound.render import render

    scene = Scene(Ball("steel", 0.005), Plate(UNDAMPED_MDF, 0.018, 1.227, 0.49),
                           drop_height=0.1)
    with pytest.raises(ParameterError,
                       match=r"plate\.material\.damping=None.*Rayleigh.*LossFactor"):
        render(scene, samplerate=48000)
    assert synth.ParameterError is ParameterError


def test_preset_with_undamped_inline_plate_material(tmp_path, capsys):
    # An inline plate material without damping: `synth info` (contacts only) works;
    # `synth render` stops with the missing damping law named (exit status 2).
    from synth.cli import main

    text = (Path(__file__).resolve().parent.parent / "presets" / "default.toml").read_text()
    inline = ('material = { name = "mdf-undamped", density = 700.0, young = 5.689e9, '
              'poisson = 0.4 }')
    assert 'material = "mdf-18"' in text
    path = tmp_path / "undamped.toml"
    path.write_text(text.replace('material = "mdf-18"', inline))
    assert main(["info", str(path)]) == 0
    capsys.readouterr()
    assert main(["render", str(path), "-o", str(tmp_path / "x.wav")]) == 2
    assert "plate.material.damping=None" in capsys.readouterr().err
    assert not (tmp_path / "x.wav").exists()
