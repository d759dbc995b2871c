"""The thesis' measurements and model values (Chapters 3 and 5), one row of the comparison,
the tick decay's envelope, the first rows of ``synth bench thesis`` and its table."""

from __future__ import annotations

import math

import numpy as np

from synth.constants import GRAVITY
from synth.physics import impedance

#: Smoothing of the tick decay rows' envelope (s): short enough to keep the direct pulse.
DECAY_SMOOTHING = 0.5e-3


def smoothed_envelope(x, fs: float, smooth: float) -> np.ndarray:
    """The amplitude envelope of ``x`` (sampled at ``fs``, Hz): the magnitude of its
    analytic signal (Hilbert) averaged over a moving window of ``smooth`` (s), centred."""
    from scipy.signal import hilbert

    n = max(1, int(smooth * fs))
    return np.convolve(np.abs(hilbert(x)), np.ones(n) / n, mode="same")


def envelope_decay_time(x, fs: float, smooth: float, start: int = 0, stop: int | None = None):
    """The thesis' tick decay time (Chapter 5; s): from the peak of the amplitude envelope
    of ``x`` (sampled at ``fs``, Hz) to where it first falls below 1/e (37 %) of it. The
    envelope is the Hilbert envelope's moving average over ``smooth`` (s), computed on the
    whole of ``x`` (earlier ticks' tails stay under a tick) and searched over the samples
    ``[start, stop)``; nan if it does not fall that far there."""
    env = smoothed_envelope(x, fs, smooth)[start:stop]
    i = int(np.argmax(env))
    below = np.nonzero(env[i:] < env[i] / math.e)[0]
    return float(below[0] / fs) if below.size else float("nan")


def _edc_decay_time(x, fs, lo_db=-5.0, hi_db=-25.0):
    """Decay time (s, amplitude to 1/e, i.e. 8.69 dB) from the slope of the Schroeder
    energy decay curve fitted between ``lo_db`` and ``hi_db``."""
    edc = np.cumsum((x**2)[::-1])[::-1]
    edc_db = 10 * np.log10(edc / edc[0] + 1e-300)
    sel = (edc_db <= lo_db) & (edc_db >= hi_db)
    if sel.sum() < 10:
        return float("nan")
    t = np.nonzero(sel)[0] / fs
    slope = np.polyfit(t, edc_db[sel], 1)[0]  # dB/s, negative
    return float(-20 * math.log10(math.e) / slope)


#: The thesis' balls (Table 3.1): name, material, diameter (m), weighed mass (kg).
THESIS_BALLS = {
    "steel 10.0 mm": ("steel", 10.00e-3, 4.17e-3),
    "steel 14.3 mm": ("steel", 14.30e-3, 11.83e-3),
    "steel 19.0 mm": ("steel", 19.00e-3, 28.07e-3),
    "glass 12.55 mm": ("glass", 12.55e-3, 2.57e-3),
    "glass 17.0 mm": ("glass", 17.00e-3, 6.39e-3),
}
#: The thesis' MDF boards (Table 3.1): name, material, thickness, length, width (m), and the
#: wave speed measured between two accelerometers 1 m apart (m/s, Chapter 3).
THESIS_BOARDS = {
    "18 mm": ("mdf-18", 0.018, 1.227, 0.49, 357.0),
    "12 mm": ("mdf-12", 0.012, 1.226, 0.4885, 282.0),
    "6 mm": ("mdf-6", 0.00615, 1.200, 0.4895, 159.0),
}
#: First impacts of Table 3.3 (drop 10 cm, middle of the board): (ball, board) -> measured
#: contact time (s), the ratio measured / model contact time of Table 3.2, and the measured
#: critical distance from a free edge inside which e falls (m, range).
THESIS_IMPACTS = {
    ("steel 10.0 mm", "18 mm"): (219e-6, 2.19, (35e-3, 45e-3)),
    ("steel 10.0 mm", "12 mm"): (229e-6, 2.43, (25e-3, 30e-3)),
    ("steel 10.0 mm", "6 mm"): (313e-6, 2.52, (25e-3, 35e-3)),
    ("steel 14.3 mm", "18 mm"): (266e-6, 1.85, (45e-3, 50e-3)),
    ("steel 19.0 mm", "18 mm"): (354e-6, 1.76, (55e-3, 60e-3)),
    ("glass 12.55 mm", "18 mm"): (208e-6, 2.57, (28e-3, 30e-3)),
    ("glass 17.0 mm", "18 mm"): (224e-6, 2.00, (40e-3, 45e-3)),
    ("glass 17.0 mm", "12 mm"): (234e-6, 2.25, (30e-3, 35e-3)),
    ("glass 17.0 mm", "6 mm"): (318e-6, 2.63, (20e-3, 30e-3)),
}
#: Restitution of the first impact, 10 mm steel on 18 mm MDF at 1.4 m/s: the thesis' model
#: and its measurement (Chapter 3, sections 3.2 and 3.5).
THESIS_RESTITUTION = {"model": 0.87, "measured": 0.76}
#: Driving-point impedance of the 18 mm board (Table 3.4, N s/m): the thesis' theory (the
#: infinite plate; Eichler's 0.29 of it at an edge; no theory at a corner) and the impact
#: hammer's measurement.
THESIS_IMPEDANCE = {
    "middle": (1629.0, 1271.0),
    "edge": (0.29 * 1629.0, 389.0),
    "corner": (None, 168.0),
}
#: Decay time (envelope from its peak to 37 %) of ticks 1, 6 and 8 at the microphone 20 cm
#: from the impact point, 10 mm steel ball, 18 mm board, 10 cm drop (Chapter 5, s).
THESIS_TICK_DECAY = {1: 11.0e-3, 6: 12.3e-3, 8: 14.0e-3}


def thesis_pair(ball_name, board_name):
    from synth.physics.scene import Ball, Plate

    material, diameter, mass = THESIS_BALLS[ball_name]
    plate_material, h, a, b, _ = THESIS_BOARDS[board_name]
    return Ball(material, 0.5 * diameter, mass), Plate(plate_material, h, a, b)


def tick_decay_times(scene, seq, ticks, samplerate):
    """Envelope decay time (s, peak to 37 %) of each tick in ``ticks`` (1-based) of ``seq``,
    each rendered alone (the ticks before it left out) at the scene's microphone."""
    from synth.physics.bounces import BounceSequence
    from synth.sound.render import render

    out = {}
    for n in ticks:
        alone = BounceSequence(seq.impacts[n - 1 : n], "max-impacts", seq.drop_height, seq.gravity)
        r = render(scene, samplerate=samplerate, normalize="none", sequence=alone)
        out[n] = envelope_decay_time(r.audio.astype(float), r.samplerate, DECAY_SMOOTHING)
    return out


#: What the "thesis model" and "thesis measurement" columns hold, by the kind of quantity (the
#: first rule whose words the quantity contains): ``(words, model, measurement)``. A column
#: is "measured" only where the thesis gives the value as its measurement; "derived" says from
#: which measurements and how; "the thesis' model" is its theory's value.
COLUMN_SOURCES = (
    (
        ("restitution gap",),
        None,
        "measured gap to the thesis' model, read from the thesis' text (section 3.2)",
    ),
    (
        ("end of a series",),
        "the engine's impedance plate (not the thesis' model)",
        None,
    ),
    (
        ("restitution at", "fitted model, from the"),
        "the engine's rebound over impact speed of the same impacts (not the thesis' model)",
        None,
    ),
    (
        ("long edge",),
        "the thesis' model with Eichler's edge impedance (Chapter 3)",
        "derived: 0.63 less the thesis' 'about 5 % lower' (Chapter 3 gives no measured value)",
    ),
    (
        ("restitution",),
        "the thesis' model (section 3.2)",
        "measured from bounce times (section 3.2)",
    ),
    (
        ("contact time",),
        "derived: Table 3.3's measured time over Table 3.2's measured/model ratio",
        "measured force pulse, ball carrying a 1 g accelerometer (Table 3.3)",
    ),
    (
        ("critical distance",),
        "derived: the thesis' tau c / 2 from its measured tau and wave speed (Table 3.3)",
        "measured range (Table 3.3)",
    ),
    (
        ("impedance",),
        "the thesis' theory: Z_inf, at an edge Eichler's 0.29 Z_inf; none at a corner (Table 3.4)",
        "measured with an impact hammer (Table 3.4)",
    ),
    (
        ("decay",),
        None,
        "measured at the microphone, envelope peak to 37 %, rough by the thesis' own account "
        "(Chapter 5)",
    ),
    (
        ("first arrival",),
        "the thin plate's phase speed at 1 kHz",
        "measured: first arrival between two accelerometers 1 m apart (Chapter 3)",
    ),
    (
        ("above 2.5 kHz",),
        "the thin plate's group speed at 2.5 kHz",
        "measured: components above 2.5 kHz between the two accelerometers (Chapter 3)",
    ),
)


def column_sources(quantity: str, model, measured) -> str:
    """What the model and the measurement columns of a row hold (:data:`COLUMN_SOURCES`);
    "" where both are empty."""
    for words, model_is, measured_is in COLUMN_SOURCES:
        if all(w in quantity for w in words):
            parts = []
            if model is not None and model_is is not None:
                parts.append(f"model: {model_is}")
            if measured is not None and measured_is is not None:
                parts.append(f"measurement: {measured_is}")
            return "; ".join(parts)
    return ""


def thesis_row(
    quantity: str,
    unit: str,
    engine: float,
    model: float | None,
    measured: float | tuple[float, float] | None,
    note: str = "",
) -> dict:
    """One row of the thesis comparison: the engine's value, the thesis' model value (None:
    the thesis has none), its measurement (a value, a (low, high) range or None) and the
    engine's gap to the measurement (engine minus the nearest end of a range; 0 inside)."""
    if measured is None:
        gap = None
    elif isinstance(measured, tuple):
        lo, hi = measured
        gap = 0.0 if lo <= engine <= hi else (engine - lo if engine < lo else engine - hi)
    else:
        gap = engine - measured
    rel = None if gap is None or isinstance(measured, tuple) else gap / measured
    return dict(
        quantity=quantity,
        unit=unit,
        engine=engine,
        model=model,
        measured=list(measured) if isinstance(measured, tuple) else measured,
        gap=gap,
        relative_gap=rel,
        note=note,
        sources=column_sources(quantity, model, measured),
    )


def thesis_comparison(samplerate: int = 48000, *, modal: bool = False) -> dict:
    """The engine against the thesis' model and the thesis' measurements (Chapters 3 and 5),
    for every quantity the thesis measured (docs/validation.md, "Against the thesis'
    recordings"):

    * restitution of the first impact, 10 mm steel on 18 mm MDF, 1.4 m/s, middle;
    * contact time of the first impact of the nine ball/board pairs of Table 3.3 (model:
      the measurement over the ratio of Table 3.2);
    * critical distance from a free edge of the same pairs (engine: the distance at which
      the edge admittance starts to rise for the middle contact time; thesis prediction
      ``tau c / 2`` from its measured contact time and wave speed);
    * impedance of the 18 mm board at the middle, an edge and a corner (Table 3.4);
    * decay time of ticks 1, 6 and 8 at the microphone 20 cm away (envelope from its peak
      to 37 %), each tick rendered alone;
    * and, for the first tick, the spectral centroid, the 2-3 kHz decay time from the
      energy decay curve (the quantity the MDF damping law was fitted to) and the peak
      pressure, which have no measured counterpart.

    With ``modal``, the rows of :func:`thesis_modal_rows` follow (the finite plate in the
    contact; minutes on a cold cache of plate modes), and ``surface`` holds
    :func:`surface_fit` (MDF's contact surface fitted on the 18 mm board, its predictions).

    Returns a dict: ``rows`` (quantity, unit, engine, model, measured, gap, relative_gap,
    note; SI units, None where a value does not exist) and ``first_tick`` (figures of the
    first tick alone).
    """
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene

    rows = _impact_rows() + _impedance_rows()
    scene = load_preset("default", ["contact.model=thesis"])  # the thesis' model's sound
    seq = simulate_scene(scene)
    rows += _tick_decay_rows(scene, seq, samplerate)
    out = dict(samplerate=samplerate, rows=rows, first_tick=_first_tick(scene, seq, samplerate))
    if modal:
        _add_modal_study(out, samplerate)
    return out


def _impact_rows() -> list[dict]:
    """The first impact's restitution, and the contact time and critical distance of the nine
    pairs of Table 3.3, all at 1.4 m/s (a 10 cm drop)."""
    from synth.physics.contact import solve_impact

    speed = math.sqrt(2.0 * GRAVITY * 0.1)
    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    first = solve_impact(ball, plate, speed, rtol=1e-9)
    rows = [
        thesis_row(
            "restitution, steel 10.0 mm on 18 mm, first impact (1.4 m/s)",
            "",
            first.restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
        )
    ]
    impacts = {}
    for (ball_name, board_name), (tau_meas, ratio, _) in THESIS_IMPACTS.items():
        ball, plate = thesis_pair(ball_name, board_name)
        r = solve_impact(ball, plate, speed, rtol=1e-9)
        impacts[ball_name, board_name] = (plate, r.contact_time)
        rows.append(
            thesis_row(
                f"contact time, {ball_name} on {board_name}",
                "s",
                r.contact_time,
                tau_meas / ratio,
                tau_meas,
            )
        )
    for (ball_name, board_name), (tau_meas, _, dc_meas) in THESIS_IMPACTS.items():
        plate, tau = impacts[ball_name, board_name]
        wave_speed = THESIS_BOARDS[board_name][4]
        rows.append(
            thesis_row(
                f"critical distance, {ball_name} on {board_name}",
                "m",
                impedance.critical_distance(plate, tau),
                0.5 * tau_meas * wave_speed,
                dc_meas,
            )
        )
    return rows


def _impedance_rows() -> list[dict]:
    """The 18 mm board's impedance at the middle, an edge and a corner (Table 3.4)."""
    _, plate = thesis_pair("steel 10.0 mm", "18 mm")
    engine_z = {
        "middle": impedance.infinite_plate_impedance(plate),
        "edge": edge_impedance(plate),
        "corner": corner_impedance(plate),
    }
    notes = {
        "corner": "engine: derived from measurements, Z_inf over the mean measured middle/corner "
        "ratio 7.5 of the 18 and 12 mm boards (Table 3.4), not a prediction",
        "edge": "engine: Eichler's 0.29 Z_inf",
        "middle": "engine: the infinite thin plate's Z_inf",
    }
    return [
        thesis_row(
            f"impedance, 18 mm, {where}", "N s/m", engine_z[where], model, measured, notes[where]
        )
        for where, (model, measured) in THESIS_IMPEDANCE.items()
    ]


def _tick_decay_rows(scene, seq, samplerate: int) -> list[dict]:
    """The decay times of ticks 1, 6 and 8 at the microphone, each tick rendered alone."""
    decays = tick_decay_times(scene, seq, sorted(THESIS_TICK_DECAY), samplerate)
    return [
        thesis_row(
            f"tick {n} decay at 20 cm, envelope peak to 37 %",
            "s",
            decays[n],
            None,
            measured,
            "the thesis has no model of the sound",
        )
        for n, measured in THESIS_TICK_DECAY.items()
    ]


def _first_tick(scene, seq, samplerate: int) -> dict:
    """Figures of the first tick rendered alone, which have no measured counterpart."""
    from scipy.signal import butter, sosfiltfilt

    from synth.physics.bounces import BounceSequence
    from synth.sound.render import render

    alone = BounceSequence(seq.impacts[:1], "max-impacts", seq.drop_height, seq.gravity)
    r = render(scene, samplerate=samplerate, normalize="none", sequence=alone)
    x = r.audio.astype(float)
    fs = r.samplerate
    spec = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(x.size, 1 / fs)
    band = sosfiltfilt(butter(4, [2000, 3000], btype="band", fs=fs, output="sos"), x)
    return dict(
        restitution=seq[0].result.restitution,
        contact_time=seq[0].result.contact_time,
        decay_time=envelope_decay_time(x, fs, DECAY_SMOOTHING),
        decay_time_2_3k=envelope_decay_time(band, fs, DECAY_SMOOTHING),
        edc_decay_time=_edc_decay_time(x, fs),
        edc_decay_time_2_3k=_edc_decay_time(band, fs),
        centroid=float(np.sum(f * spec) / np.sum(spec)),
        peak_pa=float(np.max(np.abs(x))),
    )


def _add_modal_study(out: dict, samplerate: int) -> None:
    """The finite plate's rows (:func:`thesis_modal_rows` and the studies after it) added to
    ``out``'s rows, and the studies' own figures to ``out``."""
    from validation.edge import edge_study, edge_study_json, thesis_edge_rows
    from validation.losses import loss_law_study
    from validation.modal import thesis_modal_rows
    from validation.series import thesis_lowspeed_rows
    from validation.shear import thesis_transverse_shear_rows, transverse_shear_sensitivity
    from validation.surface import surface_fit

    rows = out["rows"]
    rows += thesis_modal_rows(samplerate=samplerate)
    rows += thesis_lowspeed_rows(samplerate)
    rows += thesis_transverse_shear_rows()
    readings = edge_study()
    rows += thesis_edge_rows(readings)
    out["edge_resolution"] = edge_study_json(readings)
    out["loss_laws"] = loss_law_study()
    out["surface"] = surface_fit()
    out["transverse_shear"] = transverse_shear_sensitivity()


#: Restitution gaps of the thesis' measurements to its model (section 3.2; measured / model - 1):
#: (ball, board, impact speed in m/s) -> the measured gap, a value or a (low, high) range.
THESIS_RESTITUTION_GAPS = {
    ("steel 10.0 mm", "18 mm", 1.0): -0.18,
    ("steel 10.0 mm", "18 mm", 0.2): -0.08,
    ("steel 10.0 mm", "12 mm", 1.4): (-0.10, -0.05),
    ("steel 10.0 mm", "6 mm", 1.4): (0.10, 0.35),
}


#: Mass of the accelerometer waxed on the ball for the contact times of Table 3.3 (kg; "about
#: 1 g", with its cable, Chapter 3): the ball of those measurements is this much heavier.
THESIS_ACCELEROMETER_MASS = 1e-3


def with_accelerometer(ball):
    """``ball`` as Table 3.3 measured it: with the accelerometer's mass added."""
    from dataclasses import replace

    return replace(ball, mass=ball.mass + THESIS_ACCELEROMETER_MASS)


#: Display scale and format of each unit in the thesis table.
_THESIS_UNITS = {
    "": (1.0, "", "{:.3f}"),
    "s": (1e6, " (us)", "{:.0f}"),
    "m": (1e3, " (mm)", "{:.0f}"),
    "N s/m": (1.0, " (N s/m)", "{:.0f}"),
    "-": (1.0, "", "{:.2g}"),
    "m/s": (1.0, " (m/s)", "{:.0f}"),
}


def _shown(value, scale, fmt):
    """A value (or a [low, high] range) of the thesis table, scaled and formatted."""
    if value is None:
        return "-"
    if isinstance(value, list | tuple):
        joint = " to " if min(value) < 0 else "-"  # "-0.10 to -0.05", not "-0.10--0.05"
        return joint.join(fmt.format(v * scale) for v in value)
    return fmt.format(value * scale)


def format_thesis(c: dict) -> str:
    """The table of :func:`thesis_comparison` (Markdown): engine, thesis model, thesis
    measurement and the engine's gap to the measurement, per quantity."""
    from validation.edge import format_edge_study
    from validation.losses import format_loss_law_study
    from validation.shear import format_transverse_shear_sensitivity
    from validation.surface import format_surface_fit

    lines = [
        "Engine: the thesis' model in the engine (Hertz, the plate as its impedance) unless the "
        "quantity names another model. The last column points to the list below the table, "
        "which says what the thesis model and thesis measurement columns hold (measured, "
        "derived from measurements and how, or the thesis' model) and how the engine's value "
        "was read.",
        "",
        "| quantity | engine | thesis model | thesis measurement | engine - measurement | "
        "columns hold |",
        "|---|---|---|---|---|---|",
    ]
    sources: dict[str, int] = {}  # what the columns hold -> its number in the list
    for row in c["rows"]:
        unit = row["unit"]
        scale, label, fmt = _THESIS_UNITS[unit]
        tick_ms = unit == "s" and row["quantity"].startswith("tick")
        if tick_ms:
            scale, label, fmt = 1e3, " (ms)", "{:.2f}"
        gap = row["gap"]
        if gap is None:
            gap_text = "-"
        elif row["relative_gap"] is not None:
            gap_text = f"{fmt.format(gap * scale)} ({100 * row['relative_gap']:+.0f} %)"
        else:
            gap_text = "inside" if gap == 0.0 else fmt.format(gap * scale)
        values = [_shown(row[k], scale, fmt) for k in ("engine", "model", "measured")]
        held = "; ".join(t for t in (row.get("sources", ""), row["note"]) if t) or "-"
        key = f"[{sources.setdefault(held, len(sources) + 1)}]"
        lines.append(f"| {row['quantity']}{label} | {' | '.join(values)} | {gap_text} | {key} |")
    lines += ["", "What the columns hold:", ""]
    lines += [f"- [{number}] {held}" for held, number in sources.items()]
    t = c["first_tick"]
    lines += [
        "",
        "First tick at 20 cm, figures without a measured counterpart:",
        "",
        "| quantity | engine |",
        "|---|---|",
        f"| decay time, 2-3 kHz band, energy decay curve -5 to -25 dB, amplitude to 37 % "
        f"(ms) | {t['edc_decay_time_2_3k'] * 1e3:.1f} |",
        f"| decay time, 2-3 kHz band, envelope peak to 37 % (ms) | "
        f"{t['decay_time_2_3k'] * 1e3:.2f} |",
        f"| decay time, whole tick, energy decay curve (ms) | {t['edc_decay_time'] * 1e3:.1f} |",
        f'| spectral centroid (Hz; the thesis: "a few kHz") | {t["centroid"]:.0f} |',
        f"| peak pressure (Pa) | {t['peak_pa']:.1f} |",
    ]
    if c.get("surface") is not None:
        lines += ["", format_surface_fit(c["surface"])]
    if c.get("transverse_shear") is not None:
        lines += ["", format_transverse_shear_sensitivity(c["transverse_shear"])]
    if c.get("edge_resolution"):
        lines += ["", format_edge_study(c["edge_resolution"])]
    if c.get("loss_laws") is not None:
        lines += ["", format_loss_law_study(c["loss_laws"])]
    return "\n".join(lines)


def edge_impedance(plate) -> float:
    """Driving-point impedance at a free straight edge, ``0.29 Z_inf``, N s/m."""
    return impedance.EDGE_RATIO * impedance.infinite_plate_impedance(plate)


def corner_impedance(plate) -> float:
    """Driving-point impedance at a free corner, ``Z_inf / 7.5``, N s/m."""
    return impedance.CORNER_RATIO * impedance.infinite_plate_impedance(plate)
