"""``synth bench thesis``: the engine against the thesis' model and the thesis' measurements
(restitution, contact times, impedances, critical distances, tick decay, the MDF surface fit)."""

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


def _tick_decay_times(scene, seq, ticks, samplerate):
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
    from scipy.signal import butter, sosfiltfilt

    from synth.io.presets import load_preset
    from synth.physics.bounces import BounceSequence, simulate_scene
    from synth.physics.contact import solve_impact
    from synth.sound.render import render

    rows = []
    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    first = solve_impact(ball, plate, math.sqrt(2.0 * GRAVITY * 0.1), rtol=1e-9)
    rows.append(
        thesis_row(
            "restitution, steel 10.0 mm on 18 mm, first impact (1.4 m/s)",
            "",
            first.restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
        )
    )
    impacts = {}
    for (ball_name, board_name), (tau_meas, ratio, _) in THESIS_IMPACTS.items():
        ball, plate = thesis_pair(ball_name, board_name)
        r = solve_impact(ball, plate, math.sqrt(2.0 * GRAVITY * 0.1), rtol=1e-9)
        impacts[ball_name, board_name] = (plate, r.contact_time)
        rows.append(
            thesis_row(
                f"contact time, {ball_name} on {board_name}",
                "s",
                r.contact_time,
                tau_meas / ratio,
                tau_meas,
                "model: Table 3.3 over Table 3.2's ratio",
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
                "model: the thesis' tau c / 2 from its measured tau and c",
            )
        )
    _, plate = thesis_pair("steel 10.0 mm", "18 mm")
    z_inf = impedance.infinite_plate_impedance(plate)
    engine_z = {
        "middle": z_inf,
        "edge": impedance.edge_impedance(plate),
        "corner": impedance.corner_impedance(plate),
    }
    for where, (model, measured) in THESIS_IMPEDANCE.items():
        note = (
            "engine: Z_inf times the measured middle/corner ratio of the 18 and 12 mm boards"
            if where == "corner"
            else ""
        )
        rows.append(
            thesis_row(
                f"impedance, 18 mm, {where}", "N s/m", engine_z[where], model, measured, note
            )
        )

    scene = load_preset("default")
    seq = simulate_scene(scene)
    decays = _tick_decay_times(scene, seq, sorted(THESIS_TICK_DECAY), samplerate)
    for n, measured in THESIS_TICK_DECAY.items():
        rows.append(
            thesis_row(
                f"tick {n} decay at 20 cm, envelope peak to 37 %",
                "s",
                decays[n],
                None,
                measured,
                "the thesis has no model of the sound",
            )
        )

    alone = BounceSequence(seq.impacts[:1], "max-impacts", seq.drop_height, seq.gravity)
    r = render(scene, samplerate=samplerate, normalize="none", sequence=alone)
    x = r.audio.astype(float)
    fs = r.samplerate
    spec = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(x.size, 1 / fs)
    band = sosfiltfilt(butter(4, [2000, 3000], btype="band", fs=fs, output="sos"), x)
    first_tick = dict(
        restitution=seq[0].result.restitution,
        contact_time=seq[0].result.contact_time,
        decay_time=envelope_decay_time(x, fs, DECAY_SMOOTHING),
        decay_time_2_3k=envelope_decay_time(band, fs, DECAY_SMOOTHING),
        edc_decay_time=_edc_decay_time(x, fs),
        edc_decay_time_2_3k=_edc_decay_time(band, fs),
        centroid=float(np.sum(f * spec) / np.sum(spec)),
        peak_pa=float(np.max(np.abs(x))),
    )
    out = dict(samplerate=samplerate, rows=rows, first_tick=first_tick)
    if modal:
        rows += thesis_modal_rows(samplerate=samplerate)
        rows += thesis_lowspeed_rows(samplerate)
        rows += thesis_transverse_shear_rows()
        out["surface"] = surface_fit()
        out["transverse_shear"] = transverse_shear_sensitivity()
    return out


#: Band of the impedance read from the modal plate (Hz): the band of an impact hammer and of
#: the contact pulses of Table 3.3 (their spectra fall off above about 1 / tau ~ 10 kHz).
MODAL_IMPEDANCE_BAND = (0.0, 10e3)
#: Restitution at the edge, 10 mm steel on 18 mm MDF, 1.4 m/s: the thesis' model (Eichler's
#: edge impedance) and its measurement, "about 5 % lower" (Chapter 3).
THESIS_EDGE_RESTITUTION = {"model": 0.63, "measured": 0.60}
#: Impact-speed bins (m/s) of the restitution at the end of a series.
LATE_SPEED_BINS = ((0.1, 0.2), (0.05, 0.1), (0.02, 0.05))


def modal_critical_distance(
    ball, plate, speed: float, step: float = 1e-3, **contact_options
) -> float:
    """Critical distance (m) of the modal plate: walking along the short midline from a long
    free edge, the distance at which the restitution stops rising, i.e. where, coming from the
    middle, it starts to fall (the thesis' definition, Table 3.3). The first local maximum of
    e on a grid of ``step`` (m), refined by a parabola through it and its neighbours.
    ``contact_options`` as in :func:`synth.physics.contact.contact_law`, and ``theory`` (the
    plate theory of :func:`synth.physics.modal_contact.modal_point`)."""
    from synth.physics import modal_contact as mc

    base = mc.ModalContact.for_pair(ball, plate, None, speed=speed, **contact_options)

    def e_at(d):
        point = mc.modal_point(
            plate,
            (0.5 * plate.length, d),
            max_frequency=base.point.max_frequency,
            theory=base.point.theory,
        )
        c = mc.ModalContact(
            point,
            base.mass,
            base.stiffness,
            base.exponent,
            base.gravity,
            base.steps_per_contact,
            base.dissipation,
        )
        return c.solve(speed).restitution

    e = [e_at(0.0), e_at(step)]
    d = step
    while d < 0.5 * plate.width - step:
        d += step
        e.append(e_at(d))
        if e[-2] >= e[-1] and e[-2] > e[-3]:
            y0, y1, y2 = e[-3], e[-2], e[-1]
            shift = 0.5 * (y0 - y2) / (y0 - 2.0 * y1 + y2)
            return d - step + shift * step
    return float("nan")


def _late_restitution_row(series, plain, lo_v: float, hi_v: float, label: str):
    """The thesis row of the mean restitution of ``series`` (the engine's ``label`` model)
    at speeds of ``lo_v``-``hi_v`` m/s late in the series, beside the impedance model's
    (``plain``)."""
    return thesis_row(
        f"restitution at {lo_v:g}-{hi_v:g} m/s, end of a series, {label}",
        "",
        _late_restitution(series, lo_v, hi_v),
        _late_restitution(plain, lo_v, hi_v),
        None,
        "model: the impedance model's; measured: e falls as the speed falls below 0.2 m/s",
    )


def _late_restitution(seq, lo, hi, spread=False):
    """Mean restitution of the impacts of ``seq`` at speeds in ``[lo, hi)`` (m/s), or with
    ``spread`` its standard deviation."""
    e = [i.restitution for i in seq if lo <= i.speed < hi]
    if not e:
        return float("nan")
    return float(np.std(e) if spread else np.mean(e))


def thesis_modal_rows(pairs=None, samplerate: int = 48000) -> list:
    """The rows of the thesis comparison for the modal plate (the finite plate's modes in the
    contact, :mod:`synth.physics.modal_contact`): restitution at the middle and at an edge,
    critical distances of the ball/board ``pairs`` (default: all of Table 3.3), impedance of
    the 18 mm board at the middle, an edge and a corner (band-averaged, Table 3.4), and the
    restitution at the end of a series (10 mm steel, 18 mm, from 10 cm) against the
    impedance model's; and with the fitted model (``contact.model = "fitted"``, MDF's fitted
    surface) the restitution and critical distances, the end of a series and the decay of
    ticks 1, 6 and 8 at the default scene's microphone (rendered at ``samplerate``, Hz)."""
    from synth.physics import modal_contact as mc
    from synth.physics.bounces import simulate_bounces
    from synth.physics.contact import solve_impact

    v1 = math.sqrt(2.0 * GRAVITY * 0.1)
    rows = []
    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    mid = mc.ModalContact.for_pair(ball, plate, None, speed=v1)
    rows.append(
        thesis_row(
            "restitution, modal plate, steel 10.0 mm on 18 mm, first impact (1.4 m/s)",
            "",
            mid.solve(v1).restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
        )
    )
    edge = (0.5 * plate.length, 0.0)
    e_edge = mc.ModalContact.for_pair(ball, plate, edge, speed=v1).solve(v1).restitution
    rows.append(
        thesis_row(
            "restitution at a long edge, modal plate, steel 10.0 mm on 18 mm (1.4 m/s)",
            "",
            e_edge,
            THESIS_EDGE_RESTITUTION["model"],
            THESIS_EDGE_RESTITUTION["measured"],
            "measured: about 5 % below the model's 0.63",
        )
    )
    chosen = THESIS_IMPACTS if pairs is None else {k: THESIS_IMPACTS[k] for k in pairs}
    # widest band first on each board: the modes' cache then serves the narrower ones
    order = sorted(chosen, key=lambda k: solve_impact(*thesis_pair(*k), v1, rtol=1e-6).contact_time)
    dc = {k: modal_critical_distance(*thesis_pair(*k), v1) for k in order}
    for (ball_name, board_name), (tau_meas, _, dc_meas) in chosen.items():
        wave_speed = THESIS_BOARDS[board_name][4]
        rows.append(
            thesis_row(
                f"critical distance, modal plate, {ball_name} on {board_name}",
                "m",
                dc[ball_name, board_name],
                0.5 * tau_meas * wave_speed,
                dc_meas,
                "engine: where e stops rising from the edge; model: the thesis' tau c / 2",
            )
        )
    fitted = mc.ModalContact.for_pair(ball, plate, None, speed=v1, surface="fitted")
    rows.append(
        thesis_row(
            "restitution, fitted model (modal plate, MDF's fitted surface), steel 10.0 mm on "
            "18 mm, first impact (1.4 m/s)",
            "",
            fitted.solve(v1).restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
            "the loss is fitted on this measurement",
        )
    )
    e_edge_fit = (
        mc.ModalContact.for_pair(ball, plate, edge, speed=v1, surface="fitted")
        .solve(v1)
        .restitution
    )
    rows.append(
        thesis_row(
            "restitution at a long edge, fitted model, steel 10.0 mm on 18 mm (1.4 m/s)",
            "",
            e_edge_fit,
            THESIS_EDGE_RESTITUTION["model"],
            THESIS_EDGE_RESTITUTION["measured"],
            "measured: about 5 % below the model's 0.63",
        )
    )
    dc_fit = {k: modal_critical_distance(*thesis_pair(*k), v1, surface="fitted") for k in order}
    for (ball_name, board_name), (tau_meas, _, dc_meas) in chosen.items():
        rows.append(
            thesis_row(
                f"critical distance, fitted model, {ball_name} on {board_name}",
                "m",
                dc_fit[ball_name, board_name],
                0.5 * tau_meas * THESIS_BOARDS[board_name][4],
                dc_meas,
                "engine: where e stops rising from the edge; model: the thesis' tau c / 2",
            )
        )
    lo, hi = MODAL_IMPEDANCE_BAND
    for where, pos in (
        ("middle", plate.centre),
        ("edge", edge),
        ("corner", (0.0, 0.0)),
    ):
        z = mc.modal_point(plate, pos, max_frequency=mid.point.max_frequency).band_impedance(lo, hi)
        model, measured = THESIS_IMPEDANCE[where]
        rows.append(
            thesis_row(
                f"impedance, modal plate, 18 mm, {where}",
                "N s/m",
                z,
                model,
                measured,
                f"engine: 1 / <Re Y> over {lo / 1e3:g}-{hi / 1e3:g} kHz",
            )
        )
    rows += _mindlin_rows(chosen, order, v1, mid.point.max_frequency)
    modal = simulate_bounces(ball, plate, drop_height=0.1, plate_model="modal")
    plain = simulate_bounces(ball, plate, drop_height=0.1, rtol=1e-9)
    for lo_v, hi_v in LATE_SPEED_BINS:
        rows.append(_late_restitution_row(modal, plain, lo_v, hi_v, "modal plate"))
        rows.append(
            thesis_row(
                f"spread (standard deviation) of those restitutions at {lo_v:g}-{hi_v:g} m/s",
                "",
                _late_restitution(modal, lo_v, hi_v, spread=True),
                _late_restitution(plain, lo_v, hi_v, spread=True),
                None,
                "the ringing of earlier bounces scatters e from bounce to bounce",
            )
        )
    fitted_series = simulate_bounces(
        ball, plate, drop_height=0.1, plate_model="modal", surface="fitted"
    )
    for lo_v, hi_v in LATE_SPEED_BINS:
        rows.append(_late_restitution_row(fitted_series, plain, lo_v, hi_v, "fitted model"))
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene

    scene = load_preset("default", ["contact.model=fitted"])
    decays = _tick_decay_times(scene, simulate_scene(scene), sorted(THESIS_TICK_DECAY), samplerate)
    for n, measured in THESIS_TICK_DECAY.items():
        rows.append(
            thesis_row(
                f"tick {n} decay at 20 cm, envelope peak to 37 %, fitted model",
                "s",
                decays[n],
                None,
                measured,
                "the thesis has no model of the sound",
            )
        )
    return rows


def _mindlin_rows(chosen: dict, order: list, v1: float, band: float) -> list:
    """The thick-plate rows (the modal plate with Mindlin's shear deformation and rotary
    inertia, ``theory="mindlin"`` of :func:`synth.physics.modal_contact.modal_point`, MDF's
    isotropic shear modulus, nothing refitted): the 18 mm board's impedance at the middle,
    an edge and a corner (Table 3.4, the Kirchhoff rows' ``band``, Hz), and with the fitted
    model's surface the restitution at the middle and at an edge (``v1``, m/s), the contact
    time (with the accelerometer) and critical distance of the ``chosen`` pairs."""
    from synth.physics import modal_contact as mc

    rows = []
    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    edge = (0.5 * plate.length, 0.0)
    lo, hi = MODAL_IMPEDANCE_BAND
    for where, pos in (("middle", plate.centre), ("edge", edge), ("corner", (0.0, 0.0))):
        point = mc.modal_point(plate, pos, max_frequency=band, theory="mindlin")
        model, measured = THESIS_IMPEDANCE[where]
        rows.append(
            thesis_row(
                f"impedance, Mindlin modal plate, 18 mm, {where}",
                "N s/m",
                point.band_impedance(lo, hi),
                model,
                measured,
                f"engine: 1 / <Re Y> over {lo / 1e3:g}-{hi / 1e3:g} kHz",
            )
        )
    thick = dict(surface="fitted", theory="mindlin")
    for where, pos, reference in (
        ("middle", None, THESIS_RESTITUTION),
        ("a long edge", edge, THESIS_EDGE_RESTITUTION),
    ):
        e = mc.ModalContact.for_pair(ball, plate, pos, speed=v1, **thick).solve(v1).restitution
        rows.append(
            thesis_row(
                f"restitution at {where}, fitted model on the Mindlin plate, steel 10.0 mm on "
                "18 mm (1.4 m/s)",
                "",
                e,
                reference["model"],
                reference["measured"],
            )
        )
    for k in chosen:
        b, p = thesis_pair(*k)
        contact = mc.ModalContact.for_pair(_with_accelerometer(b), p, None, speed=v1, **thick)
        tau_meas, model_ratio, _ = THESIS_IMPACTS[k]
        rows.append(
            thesis_row(
                f"contact time, fitted model on the Mindlin plate, {k[0]} on {k[1]}",
                "s",
                contact.solve(v1).contact_time,
                tau_meas / model_ratio,
                tau_meas,
                "with the 1 g accelerometer of the measurement",
            )
        )
    dc = {k: modal_critical_distance(*thesis_pair(*k), v1, **thick) for k in order}
    for k, (tau_meas, _, dc_meas) in chosen.items():
        rows.append(
            thesis_row(
                f"critical distance, fitted model on the Mindlin plate, {k[0]} on {k[1]}",
                "m",
                dc[k],
                0.5 * tau_meas * THESIS_BOARDS[k[1]][4],
                dc_meas,
                "engine: where e stops rising from the edge",
            )
        )
    return rows


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
        thin = getattr(impedance.kirchhoff_wave_speeds(plate, freq), kind)
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
                point.band_impedance(lo, hi),
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
                "mu not refitted",
            )
        )
    rows += _transverse_shear_gap_rows(band)
    taus, dcs = {}, {}
    for board_name in boards:
        opts = dict(TRANSVERSE_SHEAR_MODEL, max_frequency=band[board_name])
        for k in (k for k in chosen if k[1] == board_name):
            b, p = transverse_shear_pair(*k)
            contact = mc.ModalContact.for_pair(_with_accelerometer(b), p, None, **opts)
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
        lambda r: impedance.mindlin_band_impedance(_shear_plate("18 mm", r), lo, hi) - z_meas,
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
        contact = mc.ModalContact.for_pair(_with_accelerometer(ball), plate, None, **opts)
        out.append(
            dict(
                ratio=ratio,
                label=label,
                shear=plate.material.transverse_shear,
                group_speed=impedance.mindlin_wave_speeds(plate, freq).group,
                impedance=impedance.mindlin_band_impedance(plate, lo, hi),
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


def _with_accelerometer(ball):
    """``ball`` as Table 3.3 measured it: with the accelerometer's mass added."""
    from dataclasses import replace

    return replace(ball, mass=ball.mass + THESIS_ACCELEROMETER_MASS)


def _surface_contact(ball, plate, ratio: float, mu: float, speed: float):
    """The first impact at ``speed`` (m/s) at the middle of ``plate``, the finite plate in the
    contact (:mod:`synth.physics.modal_contact`, band 4 / tau of the stored surface) and the
    plate's side of the Hertz contact at ``ratio`` times its modulus with the Hunt-Crossley
    loss ``mu`` (s/m): a trial :class:`~synth.physics.materials.ContactSurface`."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact import hertz_stiffness, solve_contact
    from synth.physics.materials import MDF_SURFACE

    beta = 1.0 / impedance.infinite_plate_impedance(plate)

    def impedance_contact(r, m):
        K = hertz_stiffness(ball, plate, r)
        return solve_contact(
            mass=ball.mass, stiffness=K, admittance=beta, speed=speed, gravity=0.0, dissipation=m
        )

    # one band per pair for every trial (the stored surface's): the modal contact solves the
    # modes of exactly its band, so a band per trial would be a mode solve per trial
    stored = impedance_contact(MDF_SURFACE.transverse_ratio, MDF_SURFACE.dissipation)
    point = mc.modal_point(plate, plate.centre, max_frequency=mc.BAND_FACTOR / stored.contact_time)
    K = hertz_stiffness(ball, plate, ratio)
    return mc.ModalContact(point, ball.mass, K, 1.5, GRAVITY, mc.STEPS_PER_CONTACT, mu).solve(speed)


def surface_fit(rounds: int = 4) -> dict:
    """MDF's contact surface (:class:`synth.physics.materials.ContactSurface`) fitted on the
    18 mm board only, with the finite plate in the contact at the middle of the board:

    * ``E_t / E`` on the five first-impact contact times of Table 3.3 (least squares of
      log tau), each ball with the accelerometer those measurements had on it
      (:data:`THESIS_ACCELEROMETER_MASS`);
    * the Hunt-Crossley loss ``mu`` on the restitution 0.76 of the 10 mm steel ball at 1.4 m/s
      (section 3.2).

    The two are coupled (the loss lengthens the contact a little, the softer contact changes
    e): ``rounds`` alternations of the two one-dimensional fits. Returns the two parameters,
    the stored ones (:data:`synth.physics.materials.MDF_SURFACE`) and one row per Table 3.3
    pair with the role (fit or prediction), the measured, thesis-model and engine contact
    times (the engine's with and without the accelerometer) and the bare ball's restitution;
    and the restitution rows of :data:`THESIS_RESTITUTION_GAPS` (engine with the
    stored surface, the thesis' model, the gap between them against the measured gap)."""
    from scipy.optimize import brentq, minimize_scalar

    from synth.physics.contact import solve_impact
    from synth.physics.materials import MDF_SURFACE

    v = math.sqrt(2.0 * GRAVITY * 0.1)
    fit_pairs = [k for k in THESIS_IMPACTS if k[1] == "18 mm"]
    pairs = {k: thesis_pair(*k) for k in THESIS_IMPACTS}
    steel = pairs["steel 10.0 mm", "18 mm"]
    e_meas = THESIS_RESTITUTION["measured"]

    def measured_contact(k, r, mu):
        ball, plate = pairs[k]
        return _surface_contact(_with_accelerometer(ball), plate, r, mu, v)

    def tau_cost(log_ratio, mu):
        r = math.exp(log_ratio)
        return sum(
            math.log(measured_contact(k, r, mu).contact_time / THESIS_IMPACTS[k][0]) ** 2
            for k in fit_pairs
        )

    ratio, mu = MDF_SURFACE.transverse_ratio, MDF_SURFACE.dissipation
    for _ in range(rounds):
        mu = brentq(
            lambda m: _surface_contact(*steel, ratio, m, v).restitution - e_meas,
            0.0,
            2.0,
            xtol=1e-6,
        )
        best = minimize_scalar(
            tau_cost,
            bounds=(math.log(0.02), 0.0),
            args=(mu,),
            method="bounded",
            options=dict(xatol=1e-5),
        )
        ratio = math.exp(best.x)
    stored = (MDF_SURFACE.transverse_ratio, MDF_SURFACE.dissipation)
    rows = []
    for k, (tau_meas, model_ratio, _) in THESIS_IMPACTS.items():
        r = measured_contact(k, *stored)
        bare = _surface_contact(*pairs[k], *stored, v)
        rows.append(
            dict(
                ball=k[0],
                board=k[1],
                role="fit" if k in fit_pairs else "prediction",
                measured=tau_meas,
                model=tau_meas / model_ratio,
                contact_time=r.contact_time,
                error=r.contact_time / tau_meas - 1.0,
                bare_contact_time=bare.contact_time,
                restitution=bare.restitution,
            )
        )
    gaps = []
    for (ball_name, board, speed), measured in THESIS_RESTITUTION_GAPS.items():
        ball, plate = thesis_pair(ball_name, board)
        engine = _surface_contact(ball, plate, *stored, speed).restitution
        model = solve_impact(ball, plate, speed, rtol=1e-9).restitution
        role = "fit board" if board == "18 mm" else "prediction"
        gaps.append(
            dict(
                ball=ball_name,
                board=board,
                speed=speed,
                role=role,
                engine=engine,
                model=model,
                gap=engine / model - 1.0,
                measured=measured,
            )
        )
    e_fit = _surface_contact(*steel, *stored, v).restitution
    return dict(
        ratio=ratio,
        dissipation=mu,
        stored_ratio=stored[0],
        stored_dissipation=stored[1],
        restitution=e_fit,
        rows=rows,
        gaps=gaps,
    )


def _gap_met(gap: float, measured) -> bool:
    """The issue's target for a restitution gap: the sign right and the size within half of
    the measured one (a range: within half of its nearer end outside it)."""
    lo, hi = measured if isinstance(measured, tuple) else (measured, measured)
    return (gap * lo > 0.0) and (
        0.5 * min(abs(lo), abs(hi)) <= abs(gap) <= 1.5 * max(abs(lo), abs(hi))
    )


def format_surface_fit(fit: dict) -> str:
    """The tables of :func:`surface_fit` (Markdown)."""
    lines = [
        f"MDF's contact surface, fitted on the 18 mm board only (modal plate, middle): "
        f"E_t / E = {fit['ratio']:.4f} (stored {fit['stored_ratio']:.4f}), Hunt-Crossley "
        f"mu = {fit['dissipation']:.4f} s/m (stored {fit['stored_dissipation']:.4f}); "
        f"e at 1.4 m/s with the stored values {fit['restitution']:.3f} (measured "
        f"{THESIS_RESTITUTION['measured']:.2f}). The 12 and 6 mm rows are predictions. "
        f"Contact times as Table 3.3 measured them: the ball carrying the "
        f"{THESIS_ACCELEROMETER_MASS * 1e3:g} g accelerometer (the bare ball's beside them).",
        "",
        "| ball on board | role | contact time measured (us) | thesis model (us) | engine, "
        "with the accelerometer (us) | error | engine, bare ball (us) | e at 1.4 m/s, bare ball |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in fit["rows"]:
        lines.append(
            f"| {r['ball']} on {r['board']} | {r['role']} | {r['measured'] * 1e6:.0f} | "
            f"{r['model'] * 1e6:.0f} | {r['contact_time'] * 1e6:.0f} | "
            f"{100 * r['error']:+.0f} % | {r['bare_contact_time'] * 1e6:.0f} | "
            f"{r['restitution']:.3f} |"
        )
    lines += [
        "",
        "Restitution against the thesis' model (gap = engine / model - 1; target: the measured "
        "gap's sign, and its size within half):",
        "",
        "| ball on board, speed | role | engine | thesis model | gap | measured gap | met |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in fit["gaps"]:
        m = g["measured"]
        shown = (
            f"{100 * m[0]:+.0f} to {100 * m[1]:+.0f} %"
            if isinstance(m, tuple)
            else f"{100 * m:+.0f} %"
        )
        lines.append(
            f"| {g['ball']} on {g['board']}, {g['speed']:g} m/s | {g['role']} | "
            f"{g['engine']:.3f} | {g['model']:.3f} | {100 * g['gap']:+.1f} % | {shown} | "
            f"{'yes' if _gap_met(g['gap'], m) else 'no'} |"
        )
    return "\n".join(lines)


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
    lines = [
        "| quantity | engine | thesis model | thesis measurement | engine - measurement |",
        "|---|---|---|---|---|",
    ]
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
        lines.append(f"| {row['quantity']}{label} | {' | '.join(values)} | {gap_text} |")
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
    return "\n".join(lines)


#: Silence before the first tick of the series' render (s).
RENDER_PREROLL = 0.005
#: Band of the plate's low modes (Hz): those still ringing 250 ms after an impact in the
#: thesis' recordings (Chapter 5), the ones its section 3.5.1 (item 6) points at.
LOW_MODE_BAND = 500.0
#: The band above it that carries most of the ringing at touch late in a series (Hz).
MID_MODE_BAND = (500.0, 2000.0)
#: Smoothing windows (s) of the envelope for the tick decay "peak to 37 %": the thesis
#: names no window; 0.5 ms is the rows above, the others run from about the time the
#: edges' reflections take to come back (2 ms) to 10 ms.
TICK_DECAY_SMOOTHING = (2e-3, 5e-3, 10e-3)
#: Dynamic viscosity of air at 20 C (Pa s; Kaye & Laby) and the gap (m) at which the air
#: film between ball and board stops (an upper bound of the loss: the roughness of an MDF
#: surface is a few um).
AIR_VISCOSITY = 1.81e-5
AIR_FILM_CUTOFF = 1e-6
#: Upper bound of the work of adhesion of two dry solids in air (J/m^2; van der Waals,
#: Israelachvili, Intermolecular and Surface Forces, 3rd ed. 2011, chapter 13: 0.04-0.1).
WORK_OF_ADHESION = 0.1


def air_film_loss(ball, speed: float) -> float:
    """``1 - e`` (dimensionless, first order) that the air squeezed between the ball and a
    flat board takes at ``speed`` (m/s): Reynolds' lubrication force on a sphere near a
    plane, ``F = 6 pi eta R^2 v / h`` (Brenner 1961), integrated from ``h = R`` down to
    :data:`AIR_FILM_CUTOFF` on the way in and back on the way out at the impact speed (an
    upper bound: the flow slips below the air's mean free path, 68 nm). Lost energy over
    ``m v^2``: it grows as ``1 / v``."""
    r = ball.radius
    work = 2.0 * 6.0 * math.pi * AIR_VISCOSITY * r * r * speed * math.log(r / AIR_FILM_CUTOFF)
    return work / (ball.mass * speed * speed)


def adhesion_loss(ball, speed: float, modulus: float) -> float:
    """``1 - e`` (dimensionless, first order) of the adhesion hysteresis of a JKR contact
    (Johnson, Kendall & Roberts 1971) at ``speed`` (m/s), bounded by the pull-off force
    ``1.5 pi w R`` times the pull-off approach ``(3/4) (pi^2 w^2 R / E*^2)^(1/3)`` with
    ``w`` = :data:`WORK_OF_ADHESION` and ``E*`` = ``modulus`` (Pa, the contact's): a fixed
    energy per impact, so ``1 - e`` grows as ``1 / v^2``."""
    r, w = ball.radius, WORK_OF_ADHESION
    energy = 1.5 * math.pi * w * r * 0.75 * (math.pi**2 * w * w * r / modulus**2) ** (1.0 / 3.0)
    return energy / (ball.mass * speed * speed)


def thesis_lowspeed_rows(samplerate: int = 48000) -> list:
    """The rows of the end of a series and of the tick decay's definition, for the fitted
    model (``contact.model = "fitted"``; 10 mm steel on the middle of the 18 mm board, 10 cm
    drop, the default scene's microphone 20 cm above the impact, rendered at
    ``samplerate``, Hz).

    End of a series (thesis 3.5: e falls as the speed falls below 0.2 m/s), per speed bin
    of :data:`LATE_SPEED_BINS`: the restitution as the thesis measured it, from bounce
    times, both from the scheduler's onsets and from the ticks the analysis
    (:func:`synth.analysis.analyze`) finds in the render; the ringing left by earlier
    impacts (thesis 3.5.1, item 6): the plate's velocity under the ball at touch over the
    impact speed (RMS), the same of the modes below :data:`LOW_MODE_BAND` alone and of
    those in :data:`MID_MODE_BAND` alone, and the mean change of e it makes (each impact
    solved again on a plate at rest); and the losses of the air film and of adhesion (closed-form bounds,
    :func:`air_film_loss`, :func:`adhesion_loss`) at the bin's lower speed.

    Tick decay (Chapter 5: 11, 12.3, 14 ms for ticks 1, 6, 8): envelope from its peak to
    37 % smoothed over each of :data:`TICK_DECAY_SMOOTHING`, in the rendered series (the
    earlier ticks' tails under each tick) and, at 5 ms, each tick rendered alone; and the
    analysis' own decay time (a log-linear fit of the tick's own sound's envelope)."""
    from synth.analysis import analyze
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene
    from synth.sound.render import render

    scene = load_preset("default", ["contact.model=fitted"])
    seq = simulate_scene(scene)
    audio = render(
        scene, samplerate=samplerate, normalize="none", sequence=seq, preroll=RENDER_PREROLL
    )
    x = audio.audio.astype(float)
    found = analyze(x, samplerate, gravity=seq.gravity)
    rows = _lowspeed_restitution_rows(scene, seq, found)
    rows += _tick_decay_definition_rows(scene, seq, x, samplerate, found)
    return rows


def _bin_mean(values, speeds, lo: float, hi: float) -> float:
    """Mean of ``values`` whose speed (m/s) is in ``[lo, hi)``; nan when none is."""
    v = [x for x, s in zip(values, speeds, strict=True) if lo <= s < hi]
    return float(np.mean(v)) if v else float("nan")


def _lowspeed_restitution_rows(scene, seq, found) -> list:
    """The end-of-series rows of :func:`thesis_lowspeed_rows`: ``seq`` the fitted model's
    series of ``scene``, ``found`` the analysis of its render."""
    from synth.physics import modal_contact as mc
    from synth.physics.bounces import bounce_time_restitution
    from synth.physics.contact import contact_law

    c = scene.contact
    contact = mc.ModalContact.for_pair(
        scene.ball,
        scene.plate,
        scene.position,
        gravity=scene.gravity,
        law=c.law,
        speed=seq[0].speed,
        **c.options(),
    )
    f = contact.point.omega / (2.0 * math.pi)
    low = f < LOW_MODE_BAND
    mid = (f >= MID_MODE_BAND[0]) & (f < MID_MODE_BAND[1])
    speeds = [i.speed for i in seq]
    e = [i.restitution for i in seq]
    timed = bounce_time_restitution(seq)
    # the analysis' e_n (tick n + 1) against the impact speed of tick n, g t_(n-1) / 2
    ticks = found.ticks
    heard = [t.restitution for t in ticks[2:]]
    heard_speeds = [t.speed for t in ticks[1:-1]]
    ring = [i.plate_velocity / i.speed for i in seq]
    ring_low = [float(i.plate_state.v[low].sum()) / i.speed for i in seq]
    ring_mid = [float(i.plate_state.v[mid].sum()) / i.speed for i in seq]
    K = contact_law(scene.ball, scene.plate, c.law, **c.options())[0]
    modulus = 0.75 * K / math.sqrt(scene.ball.radius)
    note = "measured: e falls as the speed falls below 0.2 m/s (thesis 3.5)"
    rows = []
    for lo, hi in LATE_SPEED_BINS:
        inside = [k for k, v in enumerate(speeds) if lo <= v < hi]
        at_rest = [contact.solve(speeds[k]).restitution for k in inside]
        change = float(np.mean([e[k] - r for k, r in zip(inside, at_rest, strict=True)]))
        rms = math.sqrt(float(np.mean([ring[k] ** 2 for k in inside])))
        low_rms = math.sqrt(float(np.mean([ring_low[k] ** 2 for k in inside])))
        mid_rms = math.sqrt(float(np.mean([ring_mid[k] ** 2 for k in inside])))
        span = f"{lo:g}-{hi:g} m/s"
        rows += [
            thesis_row(
                f"restitution at {span}, fitted model, from the onsets' bounce times "
                "e_n = t_n / t_(n-1)",
                "",
                _bin_mean(timed, speeds[1:-1], lo, hi),
                _bin_mean(e, speeds, lo, hi),
                None,
                "model: the same impacts' rebound over impact speed; " + note,
            ),
            thesis_row(
                f"restitution at {span}, fitted model, from the ticks the analysis finds "
                "at the microphone",
                "",
                _bin_mean(heard, heard_speeds, lo, hi),
                _bin_mean(e, speeds, lo, hi),
                None,
                "binned by the analysis' own impact speed g t_(n-1) / 2; " + note,
            ),
            thesis_row(
                f"plate velocity under the ball at touch over impact speed, RMS, {span}",
                "-",
                rms,
                None,
                None,
                "the ringing left by earlier impacts (thesis 3.5.1, item 6)",
            ),
            thesis_row(
                f"the same, modes below {LOW_MODE_BAND:g} Hz only, RMS, {span}",
                "-",
                low_rms,
                None,
                None,
                "the modes still ringing 250 ms after an impact in the thesis' recordings",
            ),
            thesis_row(
                f"the same, modes of {MID_MODE_BAND[0]:g}-{MID_MODE_BAND[1]:g} Hz only, RMS, "
                f"{span}",
                "-",
                mid_rms,
                None,
                None,
                "the band that carries most of the ringing at touch late in a series",
            ),
            thesis_row(
                f"mean change of e by the ringing (e minus e on a plate at rest), {span}",
                "-",
                change,
                None,
                None,
                "each impact of the bin solved again at its speed on a plate at rest",
            ),
            thesis_row(
                f"loss 1 - e of the air film between ball and board at {lo:g} m/s",
                "-",
                air_film_loss(scene.ball, lo),
                None,
                None,
                "Reynolds lubrication, an upper bound; grows as 1 / v",
            ),
            thesis_row(
                f"loss 1 - e of adhesion (JKR hysteresis) at {lo:g} m/s",
                "-",
                adhesion_loss(scene.ball, lo, modulus),
                None,
                None,
                f"work of adhesion {WORK_OF_ADHESION:g} J/m^2, an upper bound; grows as 1 / v^2",
            ),
        ]
    return rows


def _tick_decay_definition_rows(scene, seq, x, fs: int, found) -> list:
    """The tick decay rows of :func:`thesis_lowspeed_rows`: ``x`` the render of ``seq``
    (Pa at ``fs``, Hz, the first touch :data:`RENDER_PREROLL` after its start), ``found``
    its analysis."""
    from synth.physics.bounces import BounceSequence
    from synth.sound.render import render

    onsets = [int(round((i.time - seq[0].time + RENDER_PREROLL) * fs)) for i in seq]
    onsets.append(x.size)
    rows = []
    for smooth in TICK_DECAY_SMOOTHING:
        for n, measured in THESIS_TICK_DECAY.items():
            rows.append(
                thesis_row(
                    f"tick {n} decay, envelope peak to 37 % smoothed over {smooth * 1e3:g} ms, "
                    "in the series, fitted model",
                    "s",
                    envelope_decay_time(x, fs, smooth, onsets[n - 1], onsets[n]),
                    None,
                    measured,
                    "moving average of the Hilbert envelope",
                )
            )
    for n, measured in THESIS_TICK_DECAY.items():
        alone = BounceSequence(seq.impacts[n - 1 : n], "max-impacts", seq.drop_height, seq.gravity)
        y = render(scene, samplerate=fs, normalize="none", sequence=alone).audio.astype(float)
        rows.append(
            thesis_row(
                f"tick {n} decay, envelope peak to 37 % smoothed over 5 ms, tick alone, "
                "fitted model",
                "s",
                envelope_decay_time(y, fs, 5e-3),
                None,
                measured,
                "the earlier ticks' tails left out",
            )
        )
    rows += _microphone_rows(scene, seq, fs)
    for n, measured in THESIS_TICK_DECAY.items():
        rows.append(
            thesis_row(
                f"tick {n} decay, the analysis' fit of its own sound's envelope, fitted model",
                "s",
                found.ticks[n - 1].decay_time,
                None,
                measured,
                "log-linear fit from the peak, RMS envelope over 2 ms (docs/analysis.md)",
            )
        )
    return rows


#: Where the direct pulse stops ruling the envelope (s after its peak): the reflections
#: from the board's long edges (24.5 cm away) are back by about 1 ms at the group velocity
#: of 2-3 kHz, the short edges' by about 2 ms.
DIRECT_PULSE_SPAN = 3e-3


def _microphone_rows(scene, seq, fs: int) -> list:
    """Tick 1 alone at the default microphone (20 cm above the impact) and at 20 cm from the
    impact at 45 degrees along the board's length: the peak of the 0.5 ms envelope over
    its level :data:`DIRECT_PULSE_SPAN` later (the direct pulse against the whole plate's
    ringing), and at the second the decay, peak to 37 %, smoothed over 0.5 and 2 ms (the
    first's are the rows of :func:`thesis_lowspeed_rows` and :func:`thesis_modal_rows`)."""
    from dataclasses import replace

    from synth.physics.bounces import BounceSequence
    from synth.physics.scene import Microphone
    from synth.sound.render import render

    x0, y0 = scene.position
    h = 0.2 / math.sqrt(2.0)
    first = BounceSequence(seq.impacts[:1], "max-impacts", seq.drop_height, seq.gravity)
    rows = []
    for where, mic in (
        ("20 cm above the impact", scene.listener),
        ("20 cm from the impact at 45 degrees", Microphone((x0 + h, y0, h))),
    ):
        y = render(replace(scene, listener=mic), samplerate=fs, normalize="none", sequence=first)
        y = y.audio.astype(float)
        env = smoothed_envelope(y, fs, DECAY_SMOOTHING)
        k = int(np.argmax(env))
        rows.append(
            thesis_row(
                f"tick 1 at {where}: peak of the 0.5 ms envelope over its level "
                f"{DIRECT_PULSE_SPAN * 1e3:g} ms later (dB), fitted model",
                "-",
                20.0 * math.log10(env[k] / env[k + int(DIRECT_PULSE_SPAN * fs)]),
                None,
                None,
                "the direct pulse near the impact point against the whole plate's ringing",
            )
        )
        for smooth in (DECAY_SMOOTHING, 2e-3) if mic is not scene.listener else ():
            rows.append(
                thesis_row(
                    f"tick 1 decay at {where}, envelope peak to 37 % smoothed over "
                    f"{smooth * 1e3:g} ms, fitted model",
                    "s",
                    envelope_decay_time(y, fs, smooth),
                    None,
                    THESIS_TICK_DECAY[1],
                    "tick alone",
                )
            )
    return rows
