"""The rows of the transverse-shear model (MDF's fitted surface on the Mindlin plate with
the transverse shear modulus) and what that modulus does on the 18 mm board."""

from __future__ import annotations

import math

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import impedance
from validation.modal import (
    MODAL_IMPEDANCE_BAND,
    THESIS_EDGE_RESTITUTION,
    band_impedance,
    modal_critical_distance,
)
from validation.rows import (
    THESIS_BOARDS,
    THESIS_IMPACTS,
    THESIS_IMPEDANCE,
    THESIS_RESTITUTION,
    THESIS_RESTITUTION_GAPS,
    thesis_pair,
    thesis_row,
    with_accelerometer,
)

#: Bending-wave speeds the thesis measured (Chapter 3, m/s): board -> (frequency in Hz at
#: which the engine's speed is compared, "phase" or "group", measured speed). The first
#: arrival between two accelerometers 1 m apart, a speed the thesis gives without its
#: frequency, compared with the phase speed at 1 kHz; and the components above 2.5 kHz on the
#: 18 mm board, whose energy arrives at the group speed, compared with it at 2.5 kHz.
THESIS_WAVE_SPEEDS = {
    ("18 mm", "first arrival"): (1000.0, "phase", 357.0),
    ("12 mm", "first arrival"): (1000.0, "phase", 282.0),
    ("6 mm", "first arrival"): (1000.0, "phase", 159.0),
    ("18 mm", "above 2.5 kHz"): (2500.0, "group", 571.0),
}


def transverse_shear_pair(ball_name: str, board_name: str):
    """The thesis' ball and board (:func:`thesis_pair`), the board's material with the
    transverse shear modulus tied to its fitted through-thickness modulus
    (:func:`synth.physics.materials.with_transverse_shear`)."""
    from dataclasses import replace

    from synth.physics.materials import with_transverse_shear

    ball, plate = thesis_pair(ball_name, board_name)
    return ball, replace(plate, material=with_transverse_shear(plate.material))


#: The contact options of the transverse-shear model: MDF's fitted surface on the Mindlin
#: plate whose material carries the transverse shear modulus.
TRANSVERSE_SHEAR_MODEL = dict(surface="fitted", theory="mindlin")


def transverse_shear_band(board_name: str, speed: float) -> float:
    """Band limit (Hz) of the transverse-shear model's modes on a board: ``BAND_FACTOR / tau``
    of the bare 10 mm steel ball's contact at ``speed`` (m/s; the impedance model's contact
    time, :meth:`synth.physics.modal_contact.ModalContact.for_pair`). One band for every
    ball on the board, so that one mode solve serves them all (at least ``2 / tau`` for the
    shortest contact, where the band's error in e is below 1e-3)."""
    from synth.physics import modal_contact as mc

    ball, plate = transverse_shear_pair("steel 10.0 mm", board_name)
    tau = mc.impedance_contact_time(ball, plate, speed, surface="fitted")
    return mc.BAND_FACTOR / tau


def thesis_transverse_shear_rows(pairs=None) -> list:
    """The rows of the transverse-shear model (the fitted model on the Mindlin plate with
    MDF's transverse shear modulus ``G_t = E_t / (2 (1 + nu))``, nothing refitted; the 12 and
    6 mm boards are predictions): the bending-wave speeds of :data:`THESIS_WAVE_SPEEDS`
    (thesis model: the thin plate's), the 18 mm board's impedance at the middle, an edge and
    a corner (Table 3.4), the restitution at the middle and a long edge (10 mm steel, 18 mm,
    1.4 m/s), its gaps to the thesis' model beside the measured ones (section 3.2), and the
    contact time (with the accelerometer) and critical distance of the
    ball/board ``pairs`` (default: all of Table 3.3). One band per board
    (:func:`transverse_shear_band`)."""
    from synth.physics import modal_contact as mc

    v1 = math.sqrt(2.0 * GRAVITY * 0.1)
    rows = []
    for (board_name, what), (freq, kind, measured) in THESIS_WAVE_SPEEDS.items():
        _, plate = transverse_shear_pair("steel 10.0 mm", board_name)
        engine = getattr(impedance.mindlin_wave_speeds(plate, freq), kind)
        thin = getattr(kirchhoff_wave_speeds(plate, freq), kind)
        rows.append(
            thesis_row(
                f"bending wave speed, {what}, transverse-shear plate, {board_name}",
                "m/s",
                engine,
                thin,
                measured,
                f"engine and model (thin plate): the {kind} speed at {freq / 1e3:g} kHz",
            )
        )
    chosen = THESIS_IMPACTS if pairs is None else {k: THESIS_IMPACTS[k] for k in pairs}
    boards = [b for b in THESIS_BOARDS if any(k[1] == b for k in chosen) or b == "18 mm"]
    band = {b: transverse_shear_band(b, v1) for b in boards}
    ball, plate = transverse_shear_pair("steel 10.0 mm", "18 mm")
    edge = (0.5 * plate.length, 0.0)
    lo, hi = MODAL_IMPEDANCE_BAND
    for where, pos in (("middle", plate.centre), ("edge", edge), ("corner", (0.0, 0.0))):
        point = mc.modal_point(plate, pos, max_frequency=band["18 mm"], theory="mindlin")
        model, measured = THESIS_IMPEDANCE[where]
        rows.append(
            thesis_row(
                f"impedance, transverse-shear plate, 18 mm, {where}",
                "N s/m",
                band_impedance(point, lo, hi),
                model,
                measured,
                f"engine: 1 / <Re Y> over {lo / 1e3:g}-{hi / 1e3:g} kHz",
            )
        )
    opts = dict(TRANSVERSE_SHEAR_MODEL, max_frequency=band["18 mm"])
    for where, pos, reference in (
        ("middle", None, THESIS_RESTITUTION),
        ("a long edge", edge, THESIS_EDGE_RESTITUTION),
    ):
        e = mc.ModalContact.for_pair(ball, plate, pos, **opts).solve(v1).restitution
        rows.append(
            thesis_row(
                f"restitution at {where}, transverse-shear model, steel 10.0 mm on 18 mm (1.4 m/s)",
                "",
                e,
                reference["model"],
                reference["measured"],
                "the loss not refitted",
            )
        )
    rows += _transverse_shear_gap_rows(band)
    taus, dcs = {}, {}
    for board_name in boards:
        opts = dict(TRANSVERSE_SHEAR_MODEL, max_frequency=band[board_name])
        for k in (k for k in chosen if k[1] == board_name):
            b, p = transverse_shear_pair(*k)
            contact = mc.ModalContact.for_pair(with_accelerometer(b), p, None, **opts)
            taus[k] = contact.solve(v1).contact_time
            dcs[k] = modal_critical_distance(b, p, v1, **opts)
    for k, (tau_meas, model_ratio, _) in chosen.items():
        role = "fit board" if k[1] == "18 mm" else "prediction"
        rows.append(
            thesis_row(
                f"contact time, transverse-shear model, {k[0]} on {k[1]}",
                "s",
                taus[k],
                tau_meas / model_ratio,
                tau_meas,
                f"{role}; with the 1 g accelerometer of the measurement",
            )
        )
    for k, (tau_meas, _, dc_meas) in chosen.items():
        role = "fit board" if k[1] == "18 mm" else "prediction"
        rows.append(
            thesis_row(
                f"critical distance, transverse-shear model, {k[0]} on {k[1]}",
                "m",
                dcs[k],
                0.5 * tau_meas * THESIS_BOARDS[k[1]][4],
                dc_meas,
                f"{role}; engine: where e stops rising from the edge",
            )
        )
    return rows


def _transverse_shear_gap_rows(band: dict) -> list:
    """The transverse-shear model's restitution against the thesis' model, as the thesis
    measured its gaps (:data:`THESIS_RESTITUTION_GAPS`; section 3.2): engine / model - 1 at the
    middle of each board of ``band`` (board -> band limit, Hz), beside the measured gap."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact import solve_impact

    rows = []
    for (ball_name, board, speed), measured in THESIS_RESTITUTION_GAPS.items():
        if board not in band:
            continue
        ball, plate = transverse_shear_pair(ball_name, board)
        opts = dict(TRANSVERSE_SHEAR_MODEL, max_frequency=band[board])
        engine = mc.ModalContact.for_pair(ball, plate, None, **opts).solve(speed).restitution
        model = solve_impact(*thesis_pair(ball_name, board), speed, rtol=1e-9).restitution
        role = "fit board" if board == "18 mm" else "prediction"
        rows.append(
            thesis_row(
                f"restitution gap to the thesis' model (engine / model - 1), transverse-shear "
                f"model, {ball_name} on {board} ({speed:g} m/s)",
                "",
                engine / model - 1.0,
                None,
                measured,
                f"{role}; measured: section 3.2",
            )
        )
    return rows


def _shear_plate(board_name: str, ratio: float):
    """The thesis' board with its transverse shear modulus ``ratio`` times the isotropic
    ``E / (2 (1 + nu))``."""
    from dataclasses import replace

    _, plate = thesis_pair("steel 10.0 mm", board_name)
    m = plate.material
    return replace(plate, material=replace(m, transverse_shear=ratio * m.shear_modulus))


def transverse_shear_sensitivity() -> list:
    """What MDF's transverse shear modulus does on the 18 mm board, and what each
    measurement alone would ask of it: for ``G_t / G`` of 1 (isotropic), the value tied to
    the fitted ``E_t / E`` (:func:`synth.physics.materials.with_transverse_shear`), and the
    values that the group speed 571 m/s at 2.5 kHz and the middle's impedance 1271 N s/m
    (Table 3.4; the infinite plate's band average, :data:`MODAL_IMPEDANCE_BAND`) would each
    fit alone: the group speed at 2.5 kHz, that impedance, and with MDF's fitted surface the
    10 mm steel ball's contact time (with the accelerometer) and critical distance."""
    from scipy.optimize import brentq

    from synth.physics import modal_contact as mc
    from synth.physics.materials import MDF_SURFACE

    v1 = math.sqrt(2.0 * GRAVITY * 0.1)
    lo, hi = MODAL_IMPEDANCE_BAND
    freq, _, speed = THESIS_WAVE_SPEEDS["18 mm", "above 2.5 kHz"]
    z_meas = THESIS_IMPEDANCE["middle"][1]
    by_speed = brentq(
        lambda r: impedance.mindlin_wave_speeds(_shear_plate("18 mm", r), freq).group - speed,
        1e-3,
        1.0,
        xtol=1e-6,
    )
    by_impedance = brentq(
        lambda r: mindlin_band_impedance(_shear_plate("18 mm", r), lo, hi) - z_meas,
        0.05,
        1.0,
        xtol=1e-6,
    )
    choices = (
        (1.0, "isotropic"),
        (MDF_SURFACE.transverse_ratio, "tied to the fitted E_t (the model)"),
        (by_impedance, f"fitted alone on the middle's {z_meas:.0f} N s/m"),
        (by_speed, f"fitted alone on {speed:.0f} m/s at {freq / 1e3:g} kHz"),
    )
    ball, _ = thesis_pair("steel 10.0 mm", "18 mm")
    out = []
    for ratio, label in sorted(choices, reverse=True):
        plate = _shear_plate("18 mm", ratio)
        tau = mc.impedance_contact_time(ball, plate, v1, surface="fitted")
        opts = dict(TRANSVERSE_SHEAR_MODEL, max_frequency=mc.BAND_FACTOR / tau)
        contact = mc.ModalContact.for_pair(with_accelerometer(ball), plate, None, **opts)
        out.append(
            dict(
                ratio=ratio,
                label=label,
                shear=plate.material.transverse_shear,
                group_speed=impedance.mindlin_wave_speeds(plate, freq).group,
                impedance=mindlin_band_impedance(plate, lo, hi),
                contact_time=contact.solve(v1).contact_time,
                critical_distance=modal_critical_distance(ball, plate, v1, **opts),
            )
        )
    return out


def format_transverse_shear_sensitivity(rows: list) -> str:
    """The table of :func:`transverse_shear_sensitivity` (Markdown)."""
    tau, _, dc = THESIS_IMPACTS["steel 10.0 mm", "18 mm"]
    freq, _, speed = THESIS_WAVE_SPEEDS["18 mm", "above 2.5 kHz"]
    lines = [
        "MDF's transverse shear modulus on the 18 mm board (Mindlin plate, MDF's fitted "
        "surface, 10 mm steel ball at 1.4 m/s): what each choice of `G_t / G` gives, and what "
        "each measurement alone would ask of it.",
        "",
        f"| G_t / G | G_t (MPa) | choice | group speed at {freq / 1e3:g} kHz (m/s; measured "
        f"{speed:.0f}) | middle impedance, infinite plate (N s/m; measured "
        f"{THESIS_IMPEDANCE['middle'][1]:.0f}) | contact time with the accelerometer (us; "
        f"measured {tau * 1e6:.0f}) | critical distance (mm; measured "
        f"{dc[0] * 1e3:.0f}-{dc[1] * 1e3:.0f}) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['ratio']:.3f} | {r['shear'] / 1e6:.0f} | {r['label']} | "
            f"{r['group_speed']:.0f} | {r['impedance']:.0f} | {r['contact_time'] * 1e6:.0f} | "
            f"{r['critical_distance'] * 1e3:.0f} |"
        )
    return "\n".join(lines)


def mindlin_band_impedance(plate, low: float, high: float) -> float:
    """``1 / <Re Y>`` (N s/m) of the infinite Mindlin plate over ``[low, high]`` (Hz)."""
    from scipy.integrate import quad

    lo = checks.nonnegative("low", low, "Hz")
    hi = checks.positive("high", high, "Hz")
    if not hi > lo:
        raise ParameterError(f"high={high!r} must be > low={low!r} (Hz)")
    # Re Y is continuous down to 0 Hz (Kirchhoff's constant); start just above it
    admittance = impedance.mindlin_point_admittance
    mean = quad(lambda f: admittance(plate, f), max(lo, 1e-6 * hi), hi, limit=200)[0]
    return (hi - lo) / mean


def kirchhoff_wave_speeds(plate, frequency: float) -> impedance.WaveSpeeds:
    """The thin plate's bending-wave speeds at ``frequency`` (Hz, > 0): ``c = sqrt(omega)
    (D / (rho h))^(1/4)`` and ``c_g = 2 c`` (Cremer, Heckl & Petersson, section 3.7)."""
    f = checks.positive("frequency", frequency, "Hz")
    c = math.sqrt(2.0 * math.pi * f) * (plate.flexural_rigidity / plate.surface_density) ** 0.25
    return impedance.WaveSpeeds(c, 2.0 * c)
