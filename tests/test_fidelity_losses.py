"""Losses in the contact (Hunt & Crossley's viscoelastic law) on the impedance and the modal
plate, and MDF's fitted contact surface (docs/physics.md, "Contact losses")."""

import math

import pytest

import benchmarks as bench
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import modal_contact as mc
from synth.physics.contact import solve_contact, solve_impact
from synth.physics.contact_law import contact_parameters, hertz_stiffness
from synth.physics.materials import MDF_SURFACE, contact_surface, get
from synth.physics.scene import Ball, Contact, Plate
from validation.losses import gap_met

STEEL = Ball("steel", 0.005, 4.17e-3)
MDF18 = Plate("mdf-18", 0.018, 1.227, 0.49)
V1 = math.sqrt(2.0 * 9.81 * 0.1)


@pytest.mark.parametrize("n", [1.5, 2.0])
def test_hunt_crossley_small_loss_closed_form(n):
    # Hunt & Crossley (1975): on a rigid support without gravity, to first order in the loss,
    # e = 1 - 2/3 mu v for any exponent n (the loss 2/3 mu m v^3 over the elastic path).
    # The next term is O((mu v)^2): the defect (1 - e) / (mu v) - 2/3 must shrink in
    # proportion to mu v (a ratio near 2 for a halving, 1.6-2.4 allowed).
    K, m, v = 1e9, 4.17e-3, 1.4
    defects = []
    for mu in (4e-3, 2e-3, 1e-3):
        r = solve_contact(
            mass=m,
            stiffness=K,
            admittance=0.0,
            speed=v,
            gravity=0.0,
            exponent=n,
            dissipation=mu,
            rtol=1e-11,
        )
        assert r.energy_residual < 1e-8
        defects.append((1.0 - r.restitution) / (mu * v) - 2.0 / 3.0)
    assert abs(defects[-1]) < 2e-3
    for a, b in zip(defects, defects[1:], strict=False):
        assert 1.6 < a / b < 2.4, defects


@pytest.mark.parametrize(
    "law, loss",
    [
        ("hunt-crossley", {"dissipation": 0.05}),
        ("hunt-crossley", {"dissipation": 0.25}),
        # a viscous time of the size that gives e = 0.76 on this board (MDF_SURFACE's order)
        ("viscoelastic", {"viscous_time": 2.65e-6}),
    ],
)
@pytest.mark.slow
def test_modal_plate_lossy_contact_energy_and_impedance_limit(law, loss):
    # Mid-plate the reflections return after the contact: the modal plate's impact equals the
    # impedance model's with the same loss (restitution within 1e-3: the modal plate's step
    # and band error at its default settings, `synth bench contact`), its energy books close
    # (residual 1e-5) and the loss it books is the energy the ball lost beyond what the
    # plate took.
    c = mc.ModalContact.for_pair(STEEL, MDF18, None, speed=V1, law=law, **loss)
    modal = c.solve(V1)
    ref = solve_impact(STEEL, MDF18, V1, contact=law, rtol=1e-9, **loss)
    assert modal.restitution == pytest.approx(ref.restitution, abs=1e-3)
    assert modal.contact_time == pytest.approx(ref.contact_time, rel=1e-3)
    assert modal.energy_residual < 1e-5
    assert modal.contact_loss > 0.0
    # the pulse is the lossy law's force: positive while compressing
    t = 0.25 * modal.contact_time
    f, _ = modal.force_and_slope_at([t])
    assert f[0] > 0.0


@pytest.mark.slow
def test_modal_plate_without_loss_is_unchanged():
    # mu = 0 takes the elastic path of the kernel: no contact loss booked
    c = mc.ModalContact.for_pair(STEEL, MDF18, None, speed=V1)
    r = c.solve(V1)
    assert r.contact_loss == 0.0 and r.law_dissipation == 0.0


def test_fitted_surface_contact_law():
    # MDF's fitted surface: Hertz at its through-thickness modulus with its one loss, the
    # viscoelastic one (no Hunt-Crossley term beside it)
    law = contact_parameters(STEEL, MDF18, "hertz", surface="fitted")
    assert law.exponent == 1.5 and law.viscous_time == MDF_SURFACE.viscous_time > 0.0
    assert law.dissipation == MDF_SURFACE.dissipation == 0.0
    K = law.stiffness
    assert K == pytest.approx(hertz_stiffness(STEEL, MDF18, MDF_SURFACE.transverse_ratio))
    assert K < hertz_stiffness(STEEL, MDF18)
    with pytest.raises(ParameterError, match="hertz"):
        contact_parameters(STEEL, MDF18, "elastic-foundation", surface="fitted")
    with pytest.raises(ParameterError, match="no fitted contact surface"):
        contact_surface(get("aluminium"))


def test_contact_surface_has_exactly_one_loss():
    # A surface carries one contact loss: Hunt-Crossley mu (s/m) or the viscoelastic A (s);
    # both or neither is a ParameterError naming the two fields, as is a negative one.
    from synth.physics.materials import ContactSurface

    assert ContactSurface(0.2, 0.25).viscous_time == 0.0
    assert ContactSurface(0.2, viscous_time=7e-6).dissipation == 0.0
    for kwargs in (dict(), dict(dissipation=0.25, viscous_time=7e-6)):
        with pytest.raises(ParameterError, match="exactly one"):
            ContactSurface(0.2, **kwargs)
    with pytest.raises(ParameterError, match="viscous_time"):
        ContactSurface(0.2, viscous_time=-1e-6)
    with pytest.raises(ParameterError, match="dissipation"):
        ContactSurface(0.2, dissipation=float("nan"))


def test_contact_model_names_law_plate_and_surface():
    fitted = Contact(model="fitted")
    assert (fitted.law, fitted.plate, fitted.surface) == ("hertz", "modal", "fitted")
    assert fitted.options() == {"surface": "fitted"}
    thesis = Contact(model="thesis")
    assert (thesis.law, thesis.plate, thesis.surface) == ("hertz", "impedance", "ideal")
    assert Contact() == Contact(law="hertz", plate="auto", surface="auto")
    assert Contact().options() == {"surface": "auto"}
    assert Contact(model="thesis").options() == {}
    # a key given explicitly takes precedence over the model's
    mixed = Contact(model="fitted", plate="impedance")
    assert (mixed.plate, mixed.surface) == ("impedance", "fitted")
    with pytest.raises(ParameterError, match="contact.model"):
        Contact(model="best")
    with pytest.raises(ParameterError, match="surface"):
        Contact(law="elastic-foundation", surface="fitted")


@pytest.mark.slow
def test_surface_fit_on_18_mm_and_predictions():
    # Two MDF parameters fitted on the 18 mm board only; the stored ones are the fit's
    # (E_t / E within 1 %, the viscoelastic A within 2 %: two rounds of the alternating fit
    # from the stored values, and their rounding to four figures), e at 1.4 m/s
    # meets the target (0.76 within 0.02), and the four contact times of the 12 and
    # 6 mm boards are predictions within the target's 15 %.
    fit = bench.surface_fit(rounds=2)
    assert fit["ratio"] == pytest.approx(MDF_SURFACE.transverse_ratio, rel=0.01)
    assert fit["viscous_time"] == pytest.approx(MDF_SURFACE.viscous_time, rel=0.02)
    assert fit["restitution"] == pytest.approx(0.76, abs=0.02)
    predictions = [r for r in fit["rows"] if r["role"] == "prediction"]
    assert {r["board"] for r in predictions} == {"12 mm", "6 mm"} and len(predictions) == 4
    for r in predictions:
        assert abs(r["error"]) < 0.15, r
    # the fit's own rows too: the target's 15 % for eight of the nine pairs (one modulus for five
    # balls; each ball as Table 3.3 measured it, with its 1 g accelerometer; contact times the
    # force pulse's length on both sides); the 12.55 mm glass ball, the shortest contact, is
    # 15.4 % short (asserted as that miss, under 16 %)
    for r in fit["rows"]:
        small_glass = (r["ball"], r["board"]) == ("glass 12.55 mm", "18 mm")
        assert (-0.16 < r["error"] < -0.15) if small_glass else abs(r["error"]) < 0.15, r
        assert r["bare_contact_time"] < r["contact_time"]
    # the fitted model's restitution gaps (the targets, the 12 and 6 mm boards
    # predictions): the viscoelastic loss meets the 18 mm board's speed dependence (-12 % at
    # 1 m/s against -18 %, -9 % at 0.2 m/s against -8 %) and the 12 mm board; the 6 mm
    # board's +57 % lies beyond the +35 % x 1.5 edge (asserted as that miss, under 5 %)
    met = [gap_met(g["gap"], g["measured"]) for g in fit["gaps"]]
    assert met == [True, True, True, False]
    assert 0.0 < fit["gaps"][3]["gap"] - 1.5 * 0.35 < 0.05
    text = bench.format_surface_fit(fit)
    assert "fitted on the 18 mm board only" in text and "predictions" in text


def test_viscoelastic_loss_follows_the_measured_speed_dependence():
    # the restitution-gap targets (section 3.2: the measured gap's sign, its size
    # within half) with each law's one loss fitted on e = 0.76 at 1.4 m/s (18 mm), on the
    # impedance plate: the viscoelastic Hertz loss (1 - e ~ v^(1/5)) meets the 18 mm board's
    # speed dependence and the 12 mm board's prediction; Hunt-Crossley (1 - e ~ v) misses
    # the 18 mm board's (at 0.2 m/s its gap even takes the wrong sign). The 6 mm board's
    # prediction lies beyond the target's edge (+35 % x 1.5): with the stored E_t / E (fitted
    # with the viscoelastic loss on the modal plate) both laws miss it, asserted as that miss,
    # under 5 % (+57 % viscoelastic). Both fits reproduce
    # the 0.76 they were fitted on to the solver's tolerance.
    from validation import losses, thesis_pair

    study = losses.loss_law_study()
    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    v1 = math.sqrt(2.0 * GRAVITY * 0.1)
    for law, keyword in losses.LOSS_LAWS.items():
        e = losses.impedance_plate_restitution(ball, plate, v1, **{keyword: study["losses"][law]})
        assert e == pytest.approx(0.76, abs=1e-6)
    met = {
        law: [losses.gap_met(r["gaps"][law], r["measured"]) for r in study["rows"]]
        for law in losses.LOSS_LAWS
    }
    assert met["viscoelastic Hertz"] == [True, True, True, False]
    assert met["Hunt-Crossley"][:2] == [False, False]
    thin = study["rows"][3]
    assert thin["board"] == "6 mm" and thin["measured"] == (0.10, 0.35)
    assert 0.0 < thin["gaps"]["viscoelastic Hertz"] - 1.5 * 0.35 < 0.05
    slow = next(r for r in study["rows"] if r["speed"] == 0.2)
    assert slow["gaps"]["Hunt-Crossley"] > 0.0 > slow["measured"]
    assert "viscoelastic Hertz A =" in losses.format_loss_law_study(study)


def test_render_takes_a_modal_sequence_of_its_scene_only():
    # A tick rendered alone from a fitted scene's series (the plate rang before it): accepted
    # for its own scene, refused for a scene with another ball (its contact law differs).
    from synth.io.presets import load_preset
    from synth.physics.bounces import BounceSequence, simulate_scene
    from synth.sound.render import check_sequence

    scene = load_preset("thesis-steel10-mdf6")
    assert scene.contact.model == "fitted" and scene.contact.plate == "modal"
    seq = simulate_scene(scene)
    # the series ends when a flight is shorter than the contact (after 15 impacts, at below
    # 1 cm/s), every impact a downward one (the end where the ringing board meets the rising
    # ball: the next test)
    assert seq.stop_reason == "flight-shorter-than-contact" and len(seq) == 15
    assert all(i.speed > 0.0 for i in seq.impacts)
    alone = BounceSequence(seq.impacts[2:3], "max-impacts", seq.drop_height, seq.gravity)
    assert check_sequence(scene, alone) is alone
    other = load_preset("thesis-steel10-mdf6", ["ball.radius=0.006"])
    with pytest.raises(ParameterError, match="modal contact"):
        check_sequence(other, alone)


def test_modal_series_ends_settled_when_the_ringing_plate_meets_the_rising_ball(monkeypatch):
    # A landing needs a downward ball, g * flight - v_out > 0. When the ringing plate's
    # surface comes up to the ball before the top of its flight (flight < v_out / g), the
    # ball rides the plate's motion: the series ends there, settled, instead of handing the
    # contact solver an upward landing speed (which it refuses). Forced here by halving
    # every flight below the top of the ball's arc.
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene

    scene = load_preset("thesis-steel10-mdf6")
    real = mc.next_touch

    def early(contact, ringing, displacement, v_out):
        flight, state = real(contact, ringing, displacement, v_out)
        return 0.5 * v_out / scene.gravity, state

    monkeypatch.setattr(mc, "next_touch", early)
    seq = simulate_scene(scene)
    assert seq.stop_reason == "settled" and len(seq) == 1
    assert seq.impacts[0].speed > 0.0
