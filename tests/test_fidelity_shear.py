"""MDF's transverse shear modulus on the Mindlin plate against the thesis' measurements
(docs/validation.md, "Against the thesis' recordings"): the transverse-shear rows `synth bench
thesis` prints. ``G_t = E_t / (2 (1 + nu))`` is tied to the fitted through-thickness modulus
(no parameter is added); the 12 mm board is a prediction."""

import pytest

import benchmarks as bench
import validation as thesis_bench
from synth.physics import impedance
from validation.shear import mindlin_band_impedance

PAIRS = [("steel 10.0 mm", "18 mm"), ("steel 10.0 mm", "12 mm")]
THREE = ("middle", "edge", "corner")


@pytest.fixture(scope="module")
def rows():
    return {r["quantity"]: r for r in bench.thesis_transverse_shear_rows(pairs=PAIRS)}


@pytest.mark.slow
def test_group_speed_above_2_5_khz(rows):
    # Chapter 3: the components above 2.5 kHz on the 18 mm board arrive at 571 m/s, where the
    # thin plate's group speed is 1008 m/s (+77 %). The soft transverse shear slows them:
    # the engine's gap to the measurement is less than half the thin plate's (not fitted on it).
    r = rows["bending wave speed, above 2.5 kHz, transverse-shear plate, 18 mm"]
    assert r["measured"] == 571.0 and r["model"] == pytest.approx(1008.0, abs=1.0)
    assert abs(r["engine"] - 571.0) < 0.5 * abs(r["model"] - 571.0)


@pytest.mark.slow
def test_first_arrival_speeds(rows):
    # Chapter 3: first arrivals between accelerometers 1 m apart, 357 / 282 / 159 m/s; the
    # thesis gives no frequency, the engine's phase speed at 1 kHz is compared (the thin
    # plate's lies within 12 % of each). Shear can only slow the wave (below the thin
    # plate's), and the engine stays within 20 % of each measurement.
    for board in ("18 mm", "12 mm", "6 mm"):
        r = rows[f"bending wave speed, first arrival, transverse-shear plate, {board}"]
        assert r["engine"] < r["model"]
        assert r["engine"] == pytest.approx(r["measured"], rel=0.20), r


@pytest.mark.slow
def test_impedance_table_3_4(rows):
    # The modes of the free board's middle sum to the infinite plate with the same G_t (3 %:
    # a sum over the few modes that couple at the middle below 10 kHz, measured 2.6 % with the
    # G_t tied to E_t / E = 0.1814; 2 % for the isotropic Mindlin plate); the row adds the
    # residual's share below the band (the infinite plate's modes above the band, reactive
    # below it but for their damping:
    # the row lies within 12 % below the modes' sum). The tied G_t softens the 18 mm board
    # far below the hammer's 1271 / 389 / 168 N s/m (the target's 10 % is missed at all three:
    # docs/validation.md gives the G_t each measurement alone would need).
    import math

    from synth.physics import modal_contact as mc

    _, plate = thesis_bench.transverse_shear_pair("steel 10.0 mm", "18 mm")
    lo, hi = thesis_bench.MODAL_IMPEDANCE_BAND
    band = thesis_bench.transverse_shear_band("18 mm", math.sqrt(2.0 * 9.81 * 0.1))
    point = mc.modal_point(plate, plate.centre, max_frequency=band, theory="mindlin")
    inside = point.omega < 2.0 * math.pi * hi
    modes = 2.0 * math.pi * (hi - lo) / (0.5 * math.pi * point.coupling[inside].sum())
    infinite = mindlin_band_impedance(plate, lo, hi)
    assert modes == pytest.approx(infinite, rel=0.03)
    assert infinite < impedance.infinite_plate_impedance(plate)
    middle = rows["impedance, transverse-shear plate, 18 mm, middle"]
    assert 0.88 * modes < middle["engine"] < modes
    for where in THREE:
        r = rows[f"impedance, transverse-shear plate, 18 mm, {where}"]
        assert r["engine"] < 0.9 * r["measured"], r


@pytest.mark.slow
def test_restitution_middle_and_edge(rows):
    # the targets, e = 0.76 within 0.02 (the viscoelastic loss fitted on the thin
    # plate, not refitted; measured 0.772) and at the edge "about 5 %" below Eichler's 0.63
    # (0.60 +- 0.03: a value derived from the thesis' text, its two figures; measured 0.624):
    # both met. On this soft shear the
    # residual (the infinite plate's modes above the band) is reactive below the band and
    # takes no energy from the contact (docs/validation.md).
    r = rows["restitution at middle, transverse-shear model, steel 10.0 mm on 18 mm (1.4 m/s)"]
    assert r["engine"] == pytest.approx(0.76, abs=0.02), r
    r = rows["restitution at a long edge, transverse-shear model, steel 10.0 mm on 18 mm (1.4 m/s)"]
    assert r["engine"] == pytest.approx(0.60, abs=0.03), r


@pytest.mark.slow
def test_contact_times_table_3_3(rows):
    # the target, each within 15 % of Table 3.3 (the 12 mm board predicted), the ball
    # carrying the measurement's 1 g accelerometer
    for ball, board in PAIRS:
        r = rows[f"contact time, transverse-shear model, {ball} on {board}"]
        assert r["engine"] == pytest.approx(r["measured"], rel=0.15), r


@pytest.mark.slow
def test_critical_distances_table_3_3(rows):
    # the target, inside the measured range +- 5 mm: on the 18 mm board (the fit board)
    # missed by 2.1 mm (measured 52.1 mm against 35-45 mm; asserted as a miss under 3 mm: the
    # contact is lengthened by the soft shear's local compliance, which the residual carries);
    # on the 12 mm board (a prediction) the distance stays beyond it (the fitted
    # contact is long and the shear slows its waves too little there: docs/validation.md)
    r = rows["critical distance, transverse-shear model, steel 10.0 mm on 18 mm"]
    lo, hi = r["measured"]
    assert 0.0 < r["engine"] - (hi + 5e-3) < 3e-3, r
    r = rows["critical distance, transverse-shear model, steel 10.0 mm on 12 mm"]
    assert r["engine"] > r["measured"][1] + 5e-3, r


@pytest.mark.slow
def test_restitution_gaps_section_3_2(rows):
    # the target for the gaps to the thesis' model: the sign right and the size within
    # half. Missed by the 12 mm board's prediction (measured 5-10 % below): the sign is right
    # but the size short, -0.5 % (asserted as that miss: below zero, above half of -5 %); on
    # the 18 mm board at 1 m/s the sign is right but the size short of the measured -18 % (a
    # Hunt-Crossley loss falls with the speed: docs/validation.md).
    r = rows[
        "restitution gap to the thesis' model (engine / model - 1), transverse-shear model, "
        "steel 10.0 mm on 12 mm (1.4 m/s)"
    ]
    assert r["measured"] == [-0.10, -0.05]
    assert -0.05 / 2.0 < r["engine"] < 0.0, r
    r = rows[
        "restitution gap to the thesis' model (engine / model - 1), transverse-shear model, "
        "steel 10.0 mm on 18 mm (1 m/s)"
    ]
    assert -0.18 < r["engine"] < 0.0, r


@pytest.mark.slow
def test_what_each_measurement_alone_asks_of_g_t():
    # The sensitivity table: the G_t fitted alone on a measurement reproduces it (the root
    # finder's 1e-6 in G_t / G, 1e-3 in the figure); the tied value is E_t / E. A lower G_t
    # slows the 2.5 kHz group and softens the middle monotonically (the dispersion relation).
    # The tied G_t shortens the 10 mm steel ball's critical distance (the edge's waves return
    # later: measured 50.7 against 55.5 mm isotropic; past each maximum e falls by 4e-4 and
    # 1.6e-3 before it rises again). With the G_t fitted alone on 571 m/s e has no such bump:
    # it rises steadily from the edge (to within 5e-3 of its far value at 45 mm) and creeps
    # on, flat to 1e-5 from about 110 mm, where the first local maximum on the 1 mm grid is
    # a wiggle of 6e-6 at 119 mm: the definition's, asserted as such (docs/validation.md).
    from synth.physics.materials import MDF_SURFACE

    table = bench.transverse_shear_sensitivity()
    by_label = {r["label"].split(" (")[0].split(" on ")[0]: r for r in table}
    assert by_label["tied to the fitted E_t"]["ratio"] == MDF_SURFACE.transverse_ratio
    assert by_label["isotropic"]["ratio"] == 1.0
    speed = next(r for r in table if "m/s" in r["label"])
    assert speed["group_speed"] == pytest.approx(571.0, rel=1e-3)
    middle = next(r for r in table if "N s/m" in r["label"])
    assert middle["impedance"] == pytest.approx(1271.0, rel=1e-3)
    ratios = [r["ratio"] for r in table]
    assert ratios == sorted(ratios, reverse=True)
    for key in ("group_speed", "impedance"):
        values = [r[key] for r in table]
        assert values == sorted(values, reverse=True)
    isotropic, tied, fast = (table[0], by_label["tied to the fitted E_t"], table[-1])
    assert tied["critical_distance"] < isotropic["critical_distance"] - 4e-3
    assert fast["critical_distance"] > isotropic["critical_distance"] + 5e-3
